// The soft-body system: slots and handles, and the per-step loop over bodies.
#include "soft/soft_system.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <string>

#include "engine/core/format.hpp"
#include "soft/fem_elements.hpp"
#include "soft/soft_body_validate.hpp"
#include "soft/tet_mesh.hpp"
#include "soft/soft_integrators.hpp"
#include "soft/soft_methods.hpp"
#include "soft/soft_stability.hpp"
#include "soft/solver_caches.hpp"

namespace sinew {

SoftSystem::SoftSystem(const SoftSettings& settings) { set_settings(settings); }
SoftSystem::~SoftSystem() = default;

void SoftSystem::set_settings(const SoftSettings& s) {
    if (!is_finite(s.gravity)) throw SoftError("soft settings: gravity must be finite, got " + to_text(s.gravity));
    if (!(s.sleep_velocity >= 0) || !std::isfinite(s.sleep_velocity))
        throw SoftError("soft settings: sleep_velocity must be >= 0, got " + to_text(s.sleep_velocity));
    if (!(s.sleep_time > 0) || !std::isfinite(s.sleep_time))
        throw SoftError("soft settings: sleep_time must be > 0, got " + to_text(s.sleep_time));
    settings_ = s;
}

// ---- bodies -------------------------------------------------------------------------------------------

SoftBodyId SoftSystem::create_body(SoftBodyDef def) {
    ++structure_revision_;  // a refused definition counts too: a revision is a hint to look again, never wrong
    validate_soft_body_def(def);
    SoftBody b;
    const std::size_t n = def.positions.size();
    b.p.x.reserve(n);
    for (std::size_t i = 0; i < n; ++i) b.p.add(def.positions[i], def.masses[i]);
    for (Vec3& v : b.p.v) v = def.initial_velocity;
    for (std::uint32_t i : def.pinned) b.p.inv_mass[i] = 0;
    for (const Attachment& a : def.attachments) b.p.inv_mass[a.particle] = 0;
    for (std::size_t i = 0; i < n; ++i)
        if (b.p.inv_mass[i] == 0) b.p.v[i].setZero();
    b.links = std::move(def.links);
    if (!def.tets.empty()) {
        // FEM: the rest shape is the positions given; the boundary is the surface unless the caller gave one.
        b.fem = make_fem_state(def.rest_positions.empty() ? b.p.x : def.rest_positions, def.tets, def.fem, def.tet_order);
        if (!def.plastic_strain.empty()) b.fem->plastic = def.plastic_strain;
        if (!def.rest_positions.empty()) {
            // A deformed body (a saved one): its polar rotations start converged, as its steps had left them.
            const int cap = b.fem->polar_iterations;
            b.fem->polar_iterations = 50;
            fem_update_rotations(*b.fem, b.p.x, def.fem.rotation);
            b.fem->polar_iterations = cap;
        }
        if (def.triangles.empty()) def.triangles = boundary_triangles(def.tets, def.tet_order);
        def.tets = {};
        def.rest_positions = {};
        def.plastic_strain = {};
    }
    b.triangles = std::move(def.triangles);
    b.attachments = std::move(def.attachments);
    b.rest_volume = b.triangles.empty() ? Real(0) : std::max(Real(0), enclosed_volume(b.triangles, b.p.x));
    // Closed and wound outward (a positive volume): only then are the normals the outside's.
    b.closed_surface = b.rest_volume > 0 && SoftContactPass::closed_surface(b.triangles);
    def.positions.clear();
    def.positions.shrink_to_fit();
    def.masses.clear();
    def.masses.shrink_to_fit();
    b.def = std::move(def);
    if (b.def.long_range_attachments) build_long_range_attachments(b);

    // With no free slot, room for a new one first (may throw; nothing else has changed then).
    if (slots_.count() == slots_.size()) bodies_.emplace_back();
    const Slots::Acquired got = slots_.acquire();
    bodies_[got.index] = std::move(b);
    return {got.index, got.generation};
}

void SoftSystem::check(SoftBodyId id, const char* where) const {
    if (id.is_null()) throw SoftError(std::string(where) + ": soft body id is null");
    if (!valid(id))
        throw SoftError(std::string(where) + ": stale or unknown soft body id (index " + std::to_string(id.index) +
                        ", generation " + std::to_string(id.generation) + ")");
}

bool SoftSystem::valid(SoftBodyId id) const { return slots_.valid(id.index, id.generation); }

void SoftSystem::destroy_body(SoftBodyId id) {
    check(id, "destroy_body");
    ++structure_revision_;
    bodies_[id.index] = SoftBody{};
    slots_.release(id.index);
}

std::vector<SoftBodyId> SoftSystem::bodies() const {
    std::vector<SoftBodyId> out;
    for (std::uint32_t s = 0; s < bodies_.size(); ++s)
        if (slots_.alive(s)) out.push_back(id_of_slot(s));
    return out;
}

SoftBody& SoftSystem::body(SoftBodyId id) {
    check(id, "body");
    return bodies_[id.index];
}
const SoftBody& SoftSystem::body(SoftBodyId id) const {
    check(id, "body");
    return bodies_[id.index];
}

void SoftSystem::wake(SoftBodyId id) {
    check(id, "wake");
    bodies_[id.index].awake = true;
    bodies_[id.index].sleep_timer = 0;
}

void SoftSystem::set_filter(SoftBodyId id, const CollisionFilter& filter) {
    check(id, "set_filter");
    bodies_[id.index].def.filter = filter;
    wake(id);
}

bool SoftSystem::awake(SoftBodyId id) const {
    check(id, "awake");
    return bodies_[id.index].awake;
}

namespace {
void check_particle(const SoftBody& b, std::uint32_t i, const char* where) {
    if (i >= b.p.size())
        throw SoftError(std::string(where) + ": particle " + std::to_string(i) + " is out of range (" +
                        std::to_string(b.p.size()) + " particles)");
}
}  // namespace

void SoftSystem::set_particle_position(SoftBodyId id, std::uint32_t i, const Vec3& x) {
    check(id, "set_particle_position");
    SoftBody& b = bodies_[id.index];
    check_particle(b, i, "set_particle_position");
    if (!is_finite(x)) throw SoftError("set_particle_position: position must be finite, got " + to_text(x));
    b.p.x[i] = x;
    b.p.x_prev[i] = x;
    b.awake = true;
    b.sleep_timer = 0;
}

void SoftSystem::apply_particle_force(SoftBodyId id, std::uint32_t i, const Vec3& f) {
    check(id, "apply_particle_force");
    SoftBody& b = bodies_[id.index];
    check_particle(b, i, "apply_particle_force");
    if (!is_finite(f)) throw SoftError("apply_particle_force: force must be finite, got " + to_text(f));
    b.p.f[i] += f;
    b.awake = true;
    b.sleep_timer = 0;
}

void SoftSystem::set_pinned(SoftBodyId id, std::uint32_t i, bool pinned) {
    check(id, "set_pinned");
    SoftBody& b = bodies_[id.index];
    check_particle(b, i, "set_pinned");
    for (const Attachment& a : b.attachments)
        if (a.particle == i)
            throw SoftError("set_pinned: particle " + std::to_string(i) +
                            " is attached to a rigid body (its attachment moves it); detach it first");
    b.p.inv_mass[i] = pinned ? Real(0) : Real(1) / b.p.mass[i];
    if (pinned) b.p.v[i].setZero();
    // Long-range attachments tether to the pins: rebuilt for the new set (outside the step, so the
    // allocation is fine).
    if (b.def.long_range_attachments) build_long_range_attachments(b);
    b.awake = true;
    b.sleep_timer = 0;
}

bool SoftSystem::attached(SoftBodyId id, std::uint32_t i) const {
    check(id, "attached");
    const SoftBody& b = bodies_[id.index];
    check_particle(b, i, "attached");
    for (const Attachment& a : b.attachments)
        if (a.particle == i) return true;
    return false;
}

void SoftSystem::attach(SoftBodyId id, std::uint32_t i, std::uint64_t target, const Vec3& local_point) {
    check(id, "attach");
    SoftBody& b = bodies_[id.index];
    check_particle(b, i, "attach");
    if (!is_finite(local_point)) throw SoftError("attach: local_point must be finite, got " + to_text(local_point));
    Attachment* slot = nullptr;
    for (Attachment& a : b.attachments)
        if (a.particle == i) slot = &a;
    if (!slot) {
        b.attachments.emplace_back();  // may throw bad_alloc: nothing else has changed yet
        slot = &b.attachments.back();
    }
    *slot = Attachment{};
    slot->particle = i;
    slot->target = target;
    slot->local_point = local_point;
    // Kinematic from now on: the coupling layer writes the frame before the next soft step, which moves the
    // particle onto the point (follow_attachments).
    b.p.inv_mass[i] = 0;
    b.p.v[i].setZero();
    if (b.def.long_range_attachments) build_long_range_attachments(b);  // tethers follow the pins
    b.awake = true;
    b.sleep_timer = 0;
}

void SoftSystem::detach(SoftBodyId id, std::uint32_t i) {
    if (!attached(id, i)) throw SoftError("detach: particle " + std::to_string(i) + " is not attached");
    SoftBody& b = bodies_[id.index];
    for (std::size_t k = 0; k < b.attachments.size(); ++k)
        if (b.attachments[k].particle == i) {
            b.attachments.erase(b.attachments.begin() + static_cast<std::ptrdiff_t>(k));
            break;
        }
    set_pinned(id, i, false);  // free again; also wakes the body
}

std::size_t SoftSystem::particle_count() const {
    std::size_t n = 0;
    for (std::uint32_t s = 0; s < bodies_.size(); ++s)
        if (slots_.alive(s)) n += bodies_[s].p.size();
    return n;
}

double SoftSystem::kinetic_energy() const {
    double e = 0;
    for (std::uint32_t s = 0; s < bodies_.size(); ++s)
        if (slots_.alive(s)) e += bodies_[s].kinetic_energy();
    return e;
}

bool SoftSystem::all_finite() const {
    for (std::uint32_t s = 0; s < bodies_.size(); ++s) {
        if (!slots_.alive(s)) continue;
        for (std::size_t i = 0; i < bodies_[s].p.size(); ++i)
            if (!is_finite(bodies_[s].p.x[i]) || !is_finite(bodies_[s].p.v[i])) return false;
    }
    return true;
}

namespace {
/// The box of a body's particles, fattened by their radius.
Aabb particle_bounds(const SoftBody& b) {
    Aabb box;
    for (const Vec3& x : b.p.x) box.grow(x);
    return box.fattened(b.def.thickness);
}
}  // namespace

Aabb SoftSystem::bounds(std::uint32_t slot) const {
    const SoftBody& b = bodies_[slot];
    return b.awake ? particle_bounds(b) : b.sleep_box;  // a sleeping body's particles have not moved
}

void SoftSystem::put_to_sleep(SoftBodyId id) {
    check(id, "put_to_sleep");
    SoftBody& b = bodies_[id.index];
    if (!b.awake) return;
    b.sleep_box = particle_bounds(b);
    b.awake = false;
    b.sleep_timer = 0;
    for (Vec3& v : b.p.v) v.setZero();
}

// ---- stepping -----------------------------------------------------------------------------------------

void SoftSystem::set_substeps(int k, std::function<void(int, Real)> before_substep) {
    if (k < 1 || k > 64) throw SoftError("soft sub-steps must be in [1, 64], got " + std::to_string(k));
    if (k > 1 && !before_substep) throw SoftError("soft sub-steps > 1 need a callback that places the colliders");
    substeps_ = k;
    before_substep_ = std::move(before_substep);
}

void SoftSystem::run_stage(Stage stage, const StepContext& ctx) {
    const Real h = ctx.h / Real(substeps_);
    switch (stage) {
        case Stage::IntegrateVelocities:
            faults_.clear();
            faulted_.assign(bodies_.size(), 0);
            integrate_velocities(h);
            break;
        case Stage::DetectCollisions: detect_collisions(h); break;
        case Stage::SolveVelocities: solve_velocities(h); break;
        case Stage::IntegratePositions:
            integrate_positions(h);
            for (int j = 1; j < substeps_; ++j) {
                // The other sub-steps, whole: the rigid bodies have finished the step, so the callback
                // places them where they are at the end of this sub-step. Contacts are those of the last.
                before_substep_(j, h);
                integrate_velocities(h);
                detect_collisions(h);
                solve_velocities(h);
                integrate_positions(h);
            }
            break;
        default: break;
    }
}

namespace {

// Attached particles follow their rigid point: placed at the end-of-step position with its velocity.
// Returns true if any moved faster than `wake_speed` (which wakes the body: a resting rigid body's
// solver jitter must not).
bool follow_attachments(SoftBody& b, Real h, Real wake_speed) {
    bool moved = false;
    for (const Attachment& a : b.attachments) {
        if (!a.frame_valid) continue;
        const Vec3 target = a.frame.apply(a.local_point);
        const Vec3 v = a.frame_v + a.frame_w.cross(target - a.frame_com);
        if ((target - b.p.x[a.particle]).norm() > wake_speed * h || v.norm() > wake_speed) moved = true;
        b.p.x[a.particle] = target;
        b.p.v[a.particle] = v;
    }
    return moved;
}

void restore_attachment_velocities(SoftBody& b) {
    for (const Attachment& a : b.attachments)
        if (a.frame_valid) b.p.v[a.particle] = a.frame_v + a.frame_w.cross(b.p.x[a.particle] - a.frame_com);
}

// A sleeping body wakes when something that can touch it moves faster than `wake_speed` (at the
// corner of its box furthest from its centre of mass, for the rotation).
bool touched_by_moving_collider(const Aabb& box, const CollisionFilter& filter, const std::vector<Collider>& colliders,
                                Real wake_speed) {
    for (const Collider& c : colliders) {
        if (!c.box.overlaps(box) || !should_collide(filter, c.filter)) continue;
        const Real reach = (c.box.extent() * Real(0.5)).norm() + (c.box.center() - c.com).norm();
        if (c.v.norm() + c.w.norm() * reach > wake_speed) return true;
    }
    return false;
}

}  // namespace

void SoftSystem::integrate_velocities(Real h) {
    contacts_.clear();
    if (collision_.size() < bodies_.size()) collision_.resize(bodies_.size());
    if (body_contacts_.size() < bodies_.size()) body_contacts_.resize(bodies_.size());
    region_.run(tasks_for_stage(), [&] { integrate_velocities_in_region(h); });
}

bool SoftSystem::splits_loops(const SoftBody& b) {
    const bool splits = b.fem || ((b.def.method == SoftMethod::FastMassSpring || b.def.method == SoftMethod::ImplicitEuler ||
                                   (b.def.method == SoftMethod::Verlet && b.def.relaxation == SoftRelaxation::ByColour)) &&
                                  !b.solved_by_rows);
    return splits && b.p.size() >= kParallelParticles;
}

const TaskSystem* SoftSystem::tasks_for_stage() const {
    // Helpers only when there is enough to share: waking them for a 64x64 cloth under a method that
    // splits nothing (Verlet's relaxation) made its step 0.85x as fast. Asleep bodies step nothing (one
    // woken this step goes to the calling thread).
    if (!tasks_ || !tasks_->parallel()) return nullptr;
    std::size_t others = 0, other_particles = 0;
    for (std::uint32_t s = 0; s < bodies_.size(); ++s) {
        if (!slots_.alive(s) || !bodies_[s].awake) continue;
        if (splits_loops(bodies_[s])) return tasks_;
        ++others;
        other_particles += bodies_[s].p.size();
    }
    return others >= 2 && other_particles >= kParallelBodyParticles ? tasks_ : nullptr;
}

template <class Fn>
void SoftSystem::for_bodies(const std::vector<std::uint32_t>& slots, Fn&& fn) {
    small_slots_.clear();
    for (std::uint32_t s : slots) {
        if (splits_loops(bodies_[s])) {
            bodies_[s].region = &region_;
            fn(s);
        } else {
            small_slots_.push_back(s);
        }
    }
    if (region_.workers() > 1 && small_slots_.size() > 1) {
        // One body per item (a stage's blocks are cut into one range per worker, and a worker that
        // finishes its range takes from the others'); no body may open a stage from a helper.
        for (std::uint32_t s : small_slots_) bodies_[s].region = nullptr;
        region_.for_each(int(small_slots_.size()), 1, [&](int begin, int end, int) {
            for (int k = begin; k < end; ++k) fn(small_slots_[std::size_t(k)]);
        });
        for (std::uint32_t s : small_slots_) bodies_[s].region = &region_;
    } else {
        for (std::uint32_t s : small_slots_) {
            bodies_[s].region = &region_;
            fn(s);
        }
    }
}

void SoftSystem::integrate_velocities_in_region(Real h) {
    stage_slots_.clear();
    for (std::uint32_t s = 0; s < bodies_.size(); ++s)
        if (slots_.alive(s) && !(s < faulted_.size() && faulted_[s])) stage_slots_.push_back(s);  // faulted: sits out the step
    for_bodies(stage_slots_, [&](std::uint32_t s) {
        SoftBody& b = bodies_[s];
        b.stepping = false;
        b.gravity = settings_.gravity * b.def.gravity_scale;
        const bool attachments_moved = follow_attachments(b, h, settings_.sleep_velocity);
        if (!b.awake) {
            if (!attachments_moved) return;  // may still be woken by a collider (detect_collisions)
            b.sleep_timer = 0;
        }
        begin_step(b, h);
    });
}

void SoftSystem::wake_into_step(SoftBody& b, Real h) {
    b.sleep_timer = 0;
    b.region = &region_;  // on the calling thread
    begin_step(b, h);
}

void SoftSystem::collect_stepping_slots() {
    stage_slots_.clear();
    for (std::uint32_t s = 0; s < bodies_.size(); ++s)
        if (slots_.alive(s) && bodies_[s].stepping) stage_slots_.push_back(s);
}

void SoftSystem::begin_step(SoftBody& b, Real h) {
    b.awake = true;
    b.stepping = true;
    Particles& p = b.p;
    p.x_next.resize(p.size());  // no-op after the first step
    p.v_solved.resize(p.size());
    soft_stages_of(b).integrate_velocities(b, h);
    // The method wrote its prediction over x (x_prev = x_n): set it aside, positions stay x_n.
    p.x_next.swap(p.x);
    p.x = p.x_prev;
}

void SoftSystem::wake_touched_by_soft_bodies(Real h) {
    // A sleeping body wakes when a stepping soft body that may touch it (SoftContactPass::may_touch)
    // reaches its box this step moving faster than the sleep speed; it then takes this step's forces.
    bool any_asleep = false;
    for (std::uint32_t s = 0; s < bodies_.size(); ++s)
        any_asleep |= slots_.alive(s) && !bodies_[s].stepping && !(s < faulted_.size() && faulted_[s]);
    if (!any_asleep) return;
    moving_boxes_.assign(bodies_.size(), Aabb());
    for (std::uint32_t t = 0; t < bodies_.size(); ++t) {
        if (!slots_.alive(t) || !bodies_[t].stepping) continue;
        const Particles& p = bodies_[t].p;
        Aabb box;
        Real travel2 = 0;
        for (std::size_t i = 0; i < p.size(); ++i) {
            box.grow(p.x[i]);
            box.grow(p.x_next[i]);
            travel2 = std::max(travel2, (p.x_next[i] - p.x[i]).squaredNorm());
        }
        if (std::sqrt(travel2) > settings_.sleep_velocity * h) moving_boxes_[t] = box.fattened(bodies_[t].def.thickness);
    }
    for (std::uint32_t s = 0; s < bodies_.size(); ++s) {
        if (!slots_.alive(s) || bodies_[s].stepping || (s < faulted_.size() && faulted_[s])) continue;
        SoftBody& b = bodies_[s];
        const Aabb box = bounds(s);
        for (std::uint32_t t = 0; t < bodies_.size(); ++t) {
            if (!moving_boxes_[t].valid() || !moving_boxes_[t].overlaps(box) ||
                !SoftContactPass::may_touch(bodies_[t], t, b, s))
                continue;
            wake_into_step(b, h);
            break;
        }
    }
}

void SoftSystem::detect_collisions(Real h) {
    wake_touched_by_soft_bodies(h);
    stage_slots_.clear();
    for (std::uint32_t s = 0; s < bodies_.size(); ++s) {
        if (!slots_.alive(s) || (s < faulted_.size() && faulted_[s])) continue;
        SoftBody& b = bodies_[s];
        if (!b.stepping) {
            // Asleep: woken by a collider that moves near it. The colliders are refreshed just before
            // this stage, so the forces of this step are taken now.
            // An embedded body is woken by its proxy's island, not by colliders it does not meet.
            if (b.meets_colliders_through_proxy || b.meets_soft_bodies_only ||
                !touched_by_moving_collider(bounds(s), b.def.filter, colliders_, settings_.sleep_velocity))
                continue;
            wake_into_step(b, h);
        }
        stage_slots_.push_back(s);
    }
    // Each body's candidate colliders and planes, one body per item (the stage's colliders are only read).
    static const std::vector<Collider> kNone;
    region_.run(tasks_for_stage(), [&] {
        for_bodies(stage_slots_, [&](std::uint32_t s) {
            const SoftBody& b = bodies_[s];
            collision_[s].begin(b, b.meets_colliders_through_proxy || b.meets_soft_bodies_only ? kNone : colliders_, h);
        });
    });
}

void SoftSystem::solve_velocities(Real h) {
    contact_entries_.clear();
    bool any_holds = false;
    for (std::uint32_t s = 0; s < bodies_.size(); ++s)
        if (slots_.alive(s) && !(s < faulted_.size() && faulted_[s])) {
            contact_entries_.push_back({s, &bodies_[s], bodies_[s].stepping});
            any_holds = any_holds || (bodies_[s].stepping && bodies_[s].holds_soft_planes());
        }
    // Contacts with other soft bodies that a method holds inside its own solve (fast mass-spring), found
    // before any body solves, as its contacts with rigid shapes are (issue 14).
    if (any_holds) {
        soft_contacts_.gather_planes(contact_entries_, h);  // x is x_n here, x_next the prediction
    } else {
        for (const SoftContactPass::Entry& e : contact_entries_) e.body->soft_planes.clear();
    }
    region_.run(tasks_for_stage(), [&] { solve_bodies_in_region(h); });
    // Each body's contacts with colliders, in slot order.
    for (const SoftContactPass::Entry& e : contact_entries_)
        if (e.stepping) contacts_.insert(contacts_.end(), body_contacts_[e.slot].begin(), body_contacts_[e.slot].end());
    // Soft bodies against each other, once every body has solved its own forces and rigid contacts.
    soft_contacts_.run(contact_entries_, h);
    // A particle the pass moved is not held by implicit Euler's filter in the next solve (record_contacts):
    // the pass pushes it after the solve, into a plane the filter holds only in velocity.
    for (const SoftContactPass::Entry& e : contact_entries_) {
        SoftBody& b = *e.body;
        if (!e.stepping || b.def.method != SoftMethod::ImplicitEuler || b.fem || b.hold_contacts ||
            b.soft_touched.size() != b.p.size() || b.contact_normal.size() != b.p.size())
            continue;
        for (std::size_t i = 0; i < b.p.size(); ++i)
            if (b.soft_touched[i]) b.contact_normal[i].setZero();
    }
}

void SoftSystem::solve_bodies_in_region(Real h) {
    collect_stepping_slots();
    for_bodies(stage_slots_, [&](std::uint32_t s) {
        SoftBody& b = bodies_[s];
        Particles& p = b.p;
        p.x.swap(p.x_next);  // work on the predicted positions
        // Attached particles onto their targets again: a coupling layer may have refined the frames.
        follow_attachments(b, h, settings_.sleep_velocity);
        ParticleCollision* collision = collision_[s].empty() ? nullptr : &collision_[s];
        soft_stages_of(b).solve_constraints(b, h, collision);
        restore_attachment_velocities(b);
        std::vector<ParticleContact>& contacts = body_contacts_[s];
        contacts.clear();
        if (collision) collision->finish(b, s, h, contacts);
        record_contacts(b, contacts);
        p.v_solved = p.v;
        p.x.swap(p.x_next);  // positions stay x_n until IntegratePositions
    });
}

const ParticleCollision* SoftSystem::collision(std::uint32_t slot) const {
    if (slot >= bodies_.size() || slot >= collision_.size() || !slots_.alive(slot) || !bodies_[slot].stepping)
        return nullptr;
    return &collision_[slot];
}

void SoftSystem::change_predicted_velocity(std::uint32_t slot, std::uint32_t i, const Vec3& dv, Real h) {
    SoftBody& b = bodies_[slot];
    if (b.p.inv_mass[i] == 0) return;  // pinned or attached: its target decides
    const SoftMethodStages& m = soft_stages_of(b);
    if (m.shift_prediction) {
        m.shift_prediction(b, i, dv, h);
        return;
    }
    b.p.x_next[i] += h * dv;
    b.p.v[i] += dv;
}

void SoftSystem::record_contacts(SoftBody& b, const std::vector<ParticleContact>& contacts) {
    // Only implicit Euler reads them: its constraint filter (Baraff & Witkin 1998 §5.3) holds each
    // particle's normal velocity in the next step's solve, instead of leaving it to the projection after
    // the solve, whose position pushes the links learn of a step late. FEM bodies and bodies a two-way
    // coupling layer asks for (hold_contacts: its ties read them too) hold every contact. Other bodies
    // hold their contacts with colliders at rest (static ones, or a kinematic body not moving):
    // - measured (float, h = 1/60): a 33 x 33 tablecloth over a table kept particles along the table's
    //   side in a period-two flutter at 0.4 m/s for good (held: 2-4 mm/s, 1e-7 J); an implicit pressure
    //   ball rolled 0.8 m across the ground in 10 s (held: at rest, 3e-10 J); cloth-drop's largest
    //   stretch fell from 1.236 to 1.036 and the pressure ball's volume from 0.978 to 1.004
    //   (`sinew bench cloth`, k = 1e4, CG 100);
    // - against a moving collider they keep the projection: held, the cloth of `cloth-on-arm` (draped
    //   over a kinematic arm turning at 1.2 rad/s) kept only 10 particles in contact and was thrown off
    //   the arm within 3 s at 1/60 while it stays on at 1/480 (not understood yet); a dynamic collider's
    //   reaction is a coupling layer's, taken from the contact pass;
    // - so does a particle this step's soft-soft pass moved (solve_velocities drops it after the pass):
    //   the pass pushes it after the solve, into a plane the filter holds only in velocity (a folded
    //   cloth's lower layer sank 6 mm into the ground under the upper one and kept moving at 0.2 m/s).
    if (b.def.method != SoftMethod::ImplicitEuler) {
        b.contact_normal.clear();
        return;
    }
    const bool every_collider = b.fem || b.hold_contacts;
    const std::size_t n = b.p.size();
    b.contact_normal.assign(n, Vec3::Zero());
    b.contact_speed.assign(n, Real(0));
    b.contact_owner.assign(n, kNoOwner);
    for (const ParticleContact& c : contacts) {
        const Collider& col = colliders_[c.collider];
        if (!every_collider && (col.dynamic || !(col.v.isZero() && col.w.isZero()))) continue;
        b.contact_normal[c.particle] = c.normal;
        b.contact_speed[c.particle] = c.normal.dot(col.point_velocity(c.point));
        b.contact_owner[c.particle] = col.owner;
    }
}

void SoftSystem::integrate_positions(Real h) {
    region_.run(tasks_for_stage(), [&] { integrate_positions_in_region(h); });
}

void SoftSystem::integrate_positions_in_region(Real h) {
    const Real fast = Real(kBlowUpSpeed * kBlowUpSpeed);
    collect_stepping_slots();
    if (first_bad_.size() < bodies_.size()) first_bad_.resize(bodies_.size());
    for_bodies(stage_slots_, [&](std::uint32_t s) {
        SoftBody& b = bodies_[s];
        Particles& p = b.p;
        const std::size_t n = p.size();
        // One pass over the particles, split among the workers for a large body: a velocity change made
        // after the solve (a coupling layer's impulse) moves this step's positions, as it would have had
        // it been part of the solve; the first particle whose position is not finite or whose speed is
        // beyond kBlowUpSpeed is found (the least index over the blocks: the same on any worker count);
        // the step's external forces are cleared.
        std::atomic<std::size_t> first_bad{n};
        for_ranges(b.region, n, 1024, [&](std::size_t begin, std::size_t end) {
            std::size_t bad = n;
            for (std::size_t i = begin; i < end; ++i) {
                if (p.inv_mass[i] != 0) p.x_next[i] += h * (p.v[i] - p.v_solved[i]);
                if (bad == n && (!p.x_next[i].allFinite() || !(p.v[i].squaredNorm() < fast))) bad = i;
                p.f[i].setZero();
            }
            std::size_t seen = first_bad.load(std::memory_order_relaxed);
            while (bad < seen && !first_bad.compare_exchange_weak(seen, bad, std::memory_order_relaxed)) {
            }
        });
        first_bad_[s] = first_bad.load(std::memory_order_relaxed);
    });
    // In slot order: a fault's place in faults() does not depend on which worker found it.
    for (std::uint32_t s : stage_slots_) {
        SoftBody& b = bodies_[s];
        contain_non_finite(s, h, first_bad_[s]);
        b.p.x.swap(b.p.x_next);
        b.stepping = false;
        update_sleep(b, h);
    }
}

void SoftSystem::contain_non_finite(std::uint32_t s, Real h, std::size_t bad) {
    SoftBody& b = bodies_[s];
    Particles& p = b.p;
    if (bad >= p.size()) return;
    StepFault f;
    f.system = StepFault::System::Soft;
    f.index = s;
    f.generation = slots_.generation(s);
    f.what = (p.x_next[bad].allFinite()
                  ? "speed of particle " + std::to_string(bad) + ", " + to_text(p.v[bad].stableNorm()) +
                        " m/s, is not finite or beyond " + to_text(kBlowUpSpeed)
                  : "position of particle " + std::to_string(bad) + " is not finite") +
             " (" + soft_method_name(b.def.method) + ")";
    f.hint = stability_hint(b, h);
    faults_.push_back(std::move(f));
    // Back where the step found it (x is still x_n here), at rest; what the method carries from step to
    // step (Verlet's previous positions, forces) starts again from there.
    p.x_next = p.x;
    p.x_prev = p.x;
    for (std::size_t i = 0; i < p.size(); ++i) {
        p.v[i].setZero();
        p.v_solved[i].setZero();
        p.f[i].setZero();
    }
    // Nothing of the blown-up solve carries over: implicit Euler's warm start (its last dv), the contact
    // arrays the solve filled, the FEM rotations' warm start. The body sits out the step's other sub-steps.
    b.implicit_cache.reset();
    for (std::vector<Vec3>* a : {&b.contact_normal, &b.contact_tie_impulse, &b.attachment_impulse})
        for (Vec3& x : *a) x.setZero();
    std::fill(b.contact_dvn.begin(), b.contact_dvn.end(), Real(0));
    b.soft_planes.clear();
    b.soft_touched.clear();
    if (b.fem)
        for (Quat& q : b.fem->polar)
            if (!q.coeffs().allFinite()) q = Quat::Identity();
    faulted_[s] = 1;
}

void SoftSystem::update_sleep(SoftBody& b, Real h) {
    if (!settings_.sleeping || !b.def.allow_sleep || b.sleeps_with_proxy || b.kept_awake) {
        b.sleep_timer = 0;
        b.kept_awake = false;
        return;
    }
    const Real limit2 = settings_.sleep_velocity * settings_.sleep_velocity;
    bool slow = true;
    for (std::size_t i = 0; i < b.p.size() && slow; ++i) slow = b.p.v[i].squaredNorm() <= limit2;
    b.sleep_timer = slow ? b.sleep_timer + h : Real(0);
    if (b.sleep_timer >= settings_.sleep_time) {
        // Kept while it sleeps: the per-step checks that may wake it (a collider near it) then cost
        // nothing per particle.
        b.sleep_box = particle_bounds(b);
        b.awake = false;
        for (Vec3& v : b.p.v) v.setZero();
    }
}

}  // namespace sinew
