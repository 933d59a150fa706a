// Event gathering for C API worlds (see capi_events.hpp for what is compared and why).
#include "engine/api/capi_events.hpp"

#include <algorithm>
#include <string>

#include "engine/api/capi_internal.hpp"

namespace sinew::capi {

namespace {
constexpr std::uint8_t kNotDynamic = 2;
}

bool WorldEvents::Pair::operator<(const Pair& o) const {
    if (a != o.a) return a < o.a;
    if (b != o.b) return b < o.b;
    if (ga != o.ga) return ga < o.ga;
    return gb < o.gb;
}

WorldEvents::WorldEvents(World& world, const HostHooks& hooks)
    : world_(world),
      begin_(HostAllocator<sinew_contact_begin_event>(hooks)),
      end_(HostAllocator<sinew_contact_end_event>(hooks)),
      sleep_(HostAllocator<sinew_sleep_event>(hooks)),
      breaks_(HostAllocator<sinew_joint_break_event>(hooks)),
      soft_(HostAllocator<sinew_soft_contact_event>(hooks)),
      sensor_begin_(HostAllocator<sinew_sensor_event>(hooks)),
      sensor_end_(HostAllocator<sinew_sensor_event>(hooks)),
      soft_sums_(HostAllocator<SoftSum>(hooks)),
      awake_before_(HostAllocator<std::uint8_t>(hooks)),
      generation_before_(HostAllocator<std::uint32_t>(hooks)),
      pairs_(HostAllocator<Pair>(hooks)),
      new_pairs_(HostAllocator<Pair>(hooks)),
      approach_(HostAllocator<Approach>(hooks)),
      joints_(HostAllocator<JointMeta>(hooks)) {
    Pipeline& p = world.pipeline();
    const int rigid = p.find_system(world.rigid().name());
    // Before the first stage of the step and after the last stage of the last system: the whole step.
    hook_before_ = p.add_hook(rigid, Stage::IntegrateVelocities, HookWhen::Before,
                              [this](const StepContext&) { before_step(); }, "C API events: before");
    hook_solve_ = p.add_hook(rigid, Stage::DetectCollisions, HookWhen::After, [this](const StepContext&) { before_solve(); },
                             "C API events: approach speeds");
    hook_after_ = p.add_hook(p.system_count() - 1, Stage::IntegratePositions, HookWhen::After,
                             [this](const StepContext& ctx) { after_step(ctx.step_index + 1); }, "C API events: after");
}

WorldEvents::~WorldEvents() {
    world_.pipeline().remove_hook(hook_after_);
    world_.pipeline().remove_hook(hook_solve_);
    world_.pipeline().remove_hook(hook_before_);
}

void WorldEvents::clear() {
    begin_.clear();
    end_.clear();
    sleep_.clear();
    breaks_.clear();
    soft_.clear();
    sensor_begin_.clear();
    sensor_end_.clear();
    dropped_ = 0;
}

void WorldEvents::remember_joint(JointId id, const JointDef& def) {
    if (joints_.size() <= id.index) joints_.resize(id.index + 1);
    joints_[id.index] = {id.generation, def.body_a, def.body_b, def.user_data};
}

sinew_events WorldEvents::view() const {
    sinew_events e;
    e.contact_begin = begin_.data();
    e.contact_begin_count = static_cast<int>(begin_.size());
    e.contact_end = end_.data();
    e.contact_end_count = static_cast<int>(end_.size());
    e.sleep = sleep_.data();
    e.sleep_count = static_cast<int>(sleep_.size());
    e.joint_break = breaks_.data();
    e.joint_break_count = static_cast<int>(breaks_.size());
    e.soft_contact = soft_.data();
    e.soft_contact_count = static_cast<int>(soft_.size());
    e.sensor_begin = sensor_begin_.data();
    e.sensor_begin_count = static_cast<int>(sensor_begin_.size());
    e.sensor_end = sensor_end_.data();
    e.sensor_end_count = static_cast<int>(sensor_end_.size());
    e.dropped = dropped_;
    return e;
}

// The hooks run inside World::step: an allocation failure must not unwind through the pipeline (the
// world would be left mid-step), so it is counted and the step goes on.
void WorldEvents::before_step() {
    const RigidSystem& r = world_.rigid();
    const std::uint32_t n = static_cast<std::uint32_t>(r.slot_count());
    try {
        awake_before_.resize(n);
        generation_before_.resize(n);
    } catch (const std::bad_alloc&) {
        awake_before_.clear();
        generation_before_.clear();
        ++dropped_;
        return;
    }
    for (std::uint32_t s = 0; s < n; ++s) {
        if (!r.slot_alive(s) || r.slot_type(s) != BodyType::Dynamic) {
            awake_before_[s] = kNotDynamic;
            continue;
        }
        const BodyId id = r.id_of_slot(s);
        awake_before_[s] = r.awake(id) ? 1 : 0;
        generation_before_[s] = id.generation;
    }
}

void WorldEvents::before_solve() {
    approach_.clear();
    const RigidSystem& r = world_.rigid();
    const RigidSystem::State& st = r.state();
    const std::vector<ContactManifold>& contacts = r.contacts();
    // Both lists are sorted by body pair: a merge join, linear in the contacts (no search per manifold).
    std::size_t old = 0;
    for (const ContactManifold& c : contacts) {
        if (c.manifold.count == 0) continue;
        std::uint32_t a = c.body_a, b = c.body_b;
        if (a > b) std::swap(a, b);
        const Pair p{a, r.id_of_slot(a).generation, b, r.id_of_slot(b).generation, 0};
        if (!approach_.empty() && approach_.back().pair == p) continue;  // the pair's first manifold decides
        while (old < pairs_.size() && pairs_[old] < p) ++old;
        if (old < pairs_.size() && pairs_[old] == p) continue;  // touching already
        // Relative velocity of B's point against A's along the normal from A to B (in the manifold's
        // own order): closing when negative.
        const Vec3& x = c.manifold.points[0].position;
        const std::uint32_t ma = c.body_a, mb = c.body_b;
        const Vec3 va = st.v[ma] + st.w[ma].cross(x - st.x[ma]);
        const Vec3 vb = st.v[mb] + st.w[mb].cross(x - st.x[mb]);
        const Real closing = -(vb - va).dot(c.manifold.normal);
        try {
            approach_.push_back({p, float(std::max(Real(0), closing))});
        } catch (const std::bad_alloc&) {
            ++dropped_;
            return;
        }
    }
}

void WorldEvents::after_step(std::uint64_t step) {
    gather_sleep(step);
    gather_contacts(step);
    gather_breaks(step);
    gather_soft_contacts(step);
}

void WorldEvents::gather_sleep(std::uint64_t step) {
    const RigidSystem& r = world_.rigid();
    const std::uint32_t n = std::min(static_cast<std::uint32_t>(awake_before_.size()),
                                     static_cast<std::uint32_t>(r.slot_count()));
    for (std::uint32_t s = 0; s < n; ++s) {
        if (awake_before_[s] == kNotDynamic || !r.slot_alive(s)) continue;
        const BodyId id = r.id_of_slot(s);
        if (id.generation != generation_before_[s]) continue;
        const std::uint8_t now = r.awake(id) ? 1 : 0;
        if (now == awake_before_[s]) continue;
        try {
            sleep_.push_back({handle(s, id.generation), now, step});
        } catch (const std::bad_alloc&) {
            ++dropped_;
        }
    }
}

void WorldEvents::gather_contacts(std::uint64_t step) {
    const RigidSystem& r = world_.rigid();
    const std::vector<ContactManifold>& contacts = r.contacts();
    new_pairs_.clear();
    try {
        for (std::size_t k = 0; k < contacts.size(); ++k) {
            const ContactManifold& c = contacts[k];
            if (c.manifold.count == 0) continue;
            std::uint32_t a = c.body_a, b = c.body_b;
            if (a > b) std::swap(a, b);
            const Pair p{a, r.id_of_slot(a).generation, b, r.id_of_slot(b).generation, static_cast<std::uint32_t>(k)};
            if (!new_pairs_.empty() && new_pairs_.back() == p) continue;
            new_pairs_.push_back(p);
        }
    } catch (const std::bad_alloc&) {
        // Without this step's set no diff is possible: keep the old set, report the loss.
        ++dropped_;
        return;
    }
    // contacts() is sorted by body pair; sort anyway if a solver ever hands it back otherwise
    // (std::sort does not allocate).
    if (!std::is_sorted(new_pairs_.begin(), new_pairs_.end())) std::sort(new_pairs_.begin(), new_pairs_.end());

    // Merge join of last step's pairs and this step's.
    std::size_t i = 0, j = 0;
    while (i < pairs_.size() || j < new_pairs_.size()) {
        const bool take_old = j == new_pairs_.size() || (i < pairs_.size() && pairs_[i] < new_pairs_[j]);
        const bool take_new = i == pairs_.size() || (j < new_pairs_.size() && new_pairs_[j] < pairs_[i]);
        try {
            if (take_old) {
                const Pair& p = pairs_[i++];
                end_.push_back({handle(p.a, p.ga), handle(p.b, p.gb), step});
            } else if (take_new) {
                const Pair& p = new_pairs_[j++];
                sinew_contact_begin_event e{};
                e.body_a = handle(p.a, p.ga);
                e.body_b = handle(p.b, p.gb);
                e.step = step;
                // The pair's manifolds are consecutive in contacts() (sorted by pair) from `first`.
                Real impulse = 0;
                for (std::size_t k = p.first; k < contacts.size(); ++k) {
                    const ContactManifold& c = contacts[k];
                    const bool same = (c.body_a == p.a && c.body_b == p.b) || (c.body_a == p.b && c.body_b == p.a);
                    if (!same) break;
                    if (c.manifold.count == 0) continue;
                    if (k == p.first) {
                        // Normal from A to B in the event's order (lower slot first).
                        const Vec3 nrm = c.body_a == p.a ? c.manifold.normal : Vec3(-c.manifold.normal);
                        e.point = to_c(c.manifold.points[0].position);
                        e.normal = to_c(nrm);
                    }
                    for (int q = 0; q < c.manifold.count; ++q) impulse += c.manifold.points[q].total_normal_impulse;
                }
                e.normal_impulse = float(impulse);
                const auto found = std::lower_bound(approach_.begin(), approach_.end(), p,
                                                    [](const Approach& x, const Pair& y) { return x.pair < y; });
                if (found != approach_.end() && found->pair == p) e.approach_speed = found->speed;
                begin_.push_back(e);
            } else {
                ++i;
                ++j;
            }
        } catch (const std::bad_alloc&) {
            ++dropped_;
        }
    }
    std::swap(pairs_, new_pairs_);
}

sinew_sensor_event sensor_event_c(std::uint32_t tag, const SensorOverlap& o, std::uint64_t step) {
    sinew_sensor_event c{};
    c.sensor = {tag, o.sensor.index, o.sensor.generation};
    c.is_soft = o.soft ? 1 : 0;
    if (o.soft) c.soft = {tag, o.soft_body.index, o.soft_body.generation};
    else c.body = {tag, o.body.index, o.body.generation};
    c.step = step;
    return c;
}

void WorldEvents::gather_sensors(const std::vector<SensorEvent>& events) {
    for (const SensorEvent& e : events) {
        try {
            (e.begin ? sensor_begin_ : sensor_end_).push_back(sensor_event_c(tag_, e.overlap, e.step));
        } catch (const std::bad_alloc&) {
            ++dropped_;
        }
    }
}

void WorldEvents::gather_breaks(std::uint64_t step) {
    for (const JointId& id : world_.rigid().broken_joints()) {
        sinew_joint_break_event e{};
        e.joint = {tag_, id.index, id.generation};
        if (id.index < joints_.size() && joints_[id.index].generation == id.generation) {
            const JointMeta& m = joints_[id.index];
            e.body_a = handle(m.a.index, m.a.generation);
            e.body_b = handle(m.b.index, m.b.generation);
            e.user_data = m.user_data;
        }
        e.step = step;
        try {
            breaks_.push_back(e);
        } catch (const std::bad_alloc&) {
            ++dropped_;
        }
        log_message(SINEW_LOG_INFO, "joint {index " + std::to_string(id.index) + ", generation " +
                                        std::to_string(id.generation) + "} broke in step " + std::to_string(step) +
                                        " (user_data " + std::to_string(e.user_data) + ")");
    }
}

void WorldEvents::gather_soft_contacts(std::uint64_t step) {
    const std::size_t first = soft_.size();
    const RigidSystem& rigid = world_.rigid();
    const SoftSystem& soft = world_.soft();
    soft_sums_.clear();
    for (const CouplingImpulse& c : world_.coupling().impulses()) {
        if (!rigid.slot_alive(c.rigid) || !soft.slot_alive(c.soft)) continue;
        // A handful of pairs per step: a linear search of this step's events.
        std::size_t k = 0;
        while (k < soft_sums_.size() && !(soft_sums_[k].rigid == c.rigid && soft_sums_[k].soft == c.soft)) ++k;
        if (k == soft_sums_.size()) {
            try {
                soft_sums_.push_back({c.rigid, c.soft, Vec3::Zero(), Vec3::Zero(), 0, 0});
            } catch (const std::bad_alloc&) {
                ++dropped_;
                continue;
            }
        }
        SoftSum& sum = soft_sums_[k];
        const Real w = c.impulse.norm();
        sum.impulse += c.impulse;
        sum.weighted_point += w * c.point;
        sum.weight += w;
        ++sum.particles;
    }
    for (const SoftSum& sum : soft_sums_) {
        sinew_soft_contact_event e{};
        e.body = handle(sum.rigid, rigid.id_of_slot(sum.rigid).generation);
        e.soft = {tag_, sum.soft, soft.id_of_slot(sum.soft).generation};
        e.impulse = to_c(sum.impulse);
        e.point = to_c(sum.weight > 0 ? Vec3(sum.weighted_point / sum.weight) : Vec3::Zero());
        e.particles = sum.particles;
        e.step = step;
        try {
            soft_.push_back(e);
        } catch (const std::bad_alloc&) {
            ++dropped_;
        }
    }
    // In (soft slot, rigid slot) order, as documented.
    std::sort(soft_.begin() + std::ptrdiff_t(first), soft_.end(), [](const sinew_soft_contact_event& a, const sinew_soft_contact_event& b) {
        return a.soft.index != b.soft.index ? a.soft.index < b.soft.index : a.body.index < b.body.index;
    });
}

}  // namespace sinew::capi
