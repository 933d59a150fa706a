// Sequences of C API calls decoded from bytes: see fuzz_input.hpp. Each call's arguments come from the
// bytes too, mostly from a table of values that break physics code (zero, denormals, 1e30, FLT_MAX,
// infinities, NaN, the sizes issue 18 found) and otherwise raw float bits, so every refusal path and
// the step behind each acceptance are reached. Worlds stay small: a few dozen bodies, a few small soft
// bodies, a few dozen steps.
#include <cfloat>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "engine/api/sinew.h"
#include "tests/fuzz/fuzz_input.hpp"

namespace sinew::fuzz {

namespace {

constexpr int kMaxOps = 96;
constexpr int kMaxBodies = 48;
constexpr int kMaxSoft = 4;
constexpr int kMaxSteps = 40;

class Bytes {
public:
    Bytes(const std::uint8_t* d, std::size_t n) : d_(d), n_(n) {}
    bool empty() const { return i_ >= n_; }
    std::uint8_t u8() { return i_ < n_ ? d_[i_++] : 0; }
    int pick(int n) { return n > 0 ? int(u8()) % n : 0; }
    std::uint32_t bits() {
        std::uint32_t b = 0;
        for (int k = 0; k < 4; ++k) b |= std::uint32_t(u8()) << (8 * k);
        return b;
    }
    float raw() {
        const std::uint32_t b = bits();
        float f;
        static_assert(sizeof f == sizeof b, "float is 32 bits");
        __builtin_memcpy(&f, &b, sizeof f);
        return f;
    }
    /// A value for any float argument: mostly from the table, sometimes raw bits.
    float value() {
        static const float kTable[] = {0.0f, -0.0f, 1.0f, -1.0f, 0.5f, 2.0f, 10.0f, -10.0f, 100.0f, 1000.0f, 1e4f,
                                       1e5f, 1e-3f, 3e-4f, 5e-4f, 1e-7f, 1e-38f, 1e-45f, 1e30f, -1e30f, 4e4f,
                                       FLT_MAX, -FLT_MAX, std::numeric_limits<float>::infinity(),
                                       -std::numeric_limits<float>::infinity(), std::numeric_limits<float>::quiet_NaN(),
                                       0.1f, 0.25f, 3.14159f, 0.01f, 60.0f, 1.0f / 60.0f};
        constexpr int n = int(sizeof kTable / sizeof kTable[0]);
        const std::uint8_t b = u8();
        return b < 224 ? kTable[b % n] : raw();
    }
    /// A value for sizes and positions that mostly makes sense (so the step behind an acceptance runs).
    float sane() {
        const std::uint8_t b = u8();
        return b < 200 ? float(b % 40) * 0.125f - 1.0f : value();
    }
    sinew_vec3 vec() { return {value(), value(), value()}; }
    sinew_vec3 sane_vec() { return {sane(), sane(), sane()}; }

private:
    const std::uint8_t* d_;
    std::size_t n_;
    std::size_t i_ = 0;
};

/// Drops a destroyed handle from the session's list.
template <class Id>
void forget(std::vector<Id>& ids, const Id& gone) {
    for (std::size_t i = 0; i < ids.size(); ++i)
        if (ids[i].index == gone.index && ids[i].generation == gone.generation) {
            ids.erase(ids.begin() + std::ptrdiff_t(i));
            return;
        }
}

bool finite(const sinew_vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

struct Session {
    sinew_world_id world{};
    std::vector<sinew_body_id> bodies;
    std::vector<sinew_soft_body_id> soft;
    std::vector<sinew_joint_id> joints;
    std::string finding;

    /// Records an internal error (a bug by the API's own contract) as the finding.
    sinew_status watch(sinew_status s, const char* call) {
        if (s == SINEW_ERROR_INTERNAL && finding.empty())
            finding = std::string(call) + " returned SINEW_ERROR_INTERNAL: " + sinew_last_error();
        return s;
    }
    sinew_body_id body(Bytes& in) {
        if (bodies.empty() || in.pick(16) == 0) return sinew_body_id{world.index, in.u8(), in.u8()};  // stale or foreign
        return bodies[std::size_t(in.pick(int(bodies.size())))];
    }
    sinew_soft_body_id soft_body(Bytes& in) {
        if (soft.empty() || in.pick(16) == 0) return sinew_soft_body_id{world.index, in.u8(), in.u8()};
        return soft[std::size_t(in.pick(int(soft.size())))];
    }
    /// After a step: an OK step leaves every body and particle finite.
    void check_state(sinew_status s, int step) {
        if (s != SINEW_OK || !finding.empty()) return;
        sinew_body_id ids[kMaxBodies + 8];
        sinew_transform xf[kMaxBodies + 8];
        int count = 0;
        watch(sinew_world_get_transforms(world, ids, xf, kMaxBodies + 8, &count), "sinew_world_get_transforms");
        for (int i = 0; i < count; ++i) {
            const sinew_quat& q = xf[i].q;
            if (!finite(xf[i].p) || !std::isfinite(q.x) || !std::isfinite(q.y) || !std::isfinite(q.z) ||
                !std::isfinite(q.w) || std::fabs(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w - 1.0f) > 1e-3f) {
                finding = "step " + std::to_string(step) + " returned SINEW_OK with body " + std::to_string(ids[i].index) +
                          " not finite or not a unit rotation";
                return;
            }
        }
        std::vector<sinew_vec3> p;
        for (const sinew_soft_body_id& b : soft) {
            int n = 0;
            if (sinew_soft_particle_count(b, &n) != SINEW_OK) continue;
            p.resize(std::size_t(n));
            int got = 0;
            watch(sinew_soft_get_positions(b, p.data(), n, &got), "sinew_soft_get_positions");
            for (int i = 0; i < got; ++i)
                if (!finite(p[std::size_t(i)])) {
                    finding = "step " + std::to_string(step) + " returned SINEW_OK with soft body " +
                              std::to_string(b.index) + " particle " + std::to_string(i) + " not finite";
                    return;
                }
        }
    }
};

sinew_soft_def soft_def(Bytes& in) {
    sinew_soft_def d = sinew_soft_def_default();
    d.method = sinew_soft_method(in.pick(6));  // 5: out of the enum
    d.iterations = 1 + in.pick(12);
    if (in.pick(2)) d.drag = in.value();
    if (in.pick(2)) d.thickness = in.value();
    if (in.pick(3) == 0) d.pressure = in.value();
    if (in.pick(2)) d.links.stretch = in.value();
    if (in.pick(3) == 0) d.links.shear = in.value();
    if (in.pick(3) == 0) d.links.bend = in.value();
    if (in.pick(3) == 0) d.links.damping = in.value();
    if (in.pick(3) == 0) d.links.fraction = in.value();
    if (in.pick(2)) d.total_mass = in.value();
    if (in.pick(3) == 0) d.velocity = in.vec();
    if (in.pick(4) == 0) d.gravity_scale = in.value();
    d.long_range_attachments = in.pick(2);
    return d;
}

}  // namespace

std::string check_capi_input(const std::uint8_t* data, std::size_t size) {
    Bytes in(data, size);
    Session s;
    sinew_world_def wd = sinew_world_def_default();
    if (in.pick(2)) wd.gravity = in.vec();
    if (in.pick(3) == 0) wd.time_step = in.value();
    if (in.pick(4) == 0) wd.max_steps_per_frame = in.pick(24) - 4;
    wd.solver = sinew_solver(in.pick(5));
    wd.velocity_iterations = 1 + in.pick(12);
    wd.enable_sleep = in.pick(2);
    if (s.watch(sinew_world_create(&wd, &s.world), "sinew_world_create") != SINEW_OK) return s.finding;
    const int max_per_frame = wd.max_steps_per_frame;
    int steps = 0;
    for (int op = 0; op < kMaxOps && !in.empty() && s.finding.empty(); ++op) {
        switch (in.pick(24)) {
            case 0:
            case 1: {  // a rigid body
                if (int(s.bodies.size()) >= kMaxBodies) break;
                sinew_body_def d = sinew_body_def_default();
                d.type = sinew_body_type(in.pick(4));
                d.shape.type = sinew_shape_type(in.pick(4));
                d.transform.p = in.sane_vec();
                if (in.pick(4) == 0) d.transform.q = {in.value(), in.value(), in.value(), in.value()};
                if (in.pick(2)) d.shape.half_extents = {in.sane(), in.sane(), in.sane()};
                if (in.pick(2)) d.shape.radius = in.sane();
                if (in.pick(3) == 0) d.shape.half_height = in.value();
                if (in.pick(3) == 0) d.mass = in.value();
                if (in.pick(3) == 0) d.density = in.value();
                if (in.pick(3) == 0) d.linear_velocity = in.vec();
                if (in.pick(3) == 0) d.angular_velocity = in.vec();
                if (in.pick(4) == 0) d.friction = in.value();
                if (in.pick(4) == 0) d.restitution = in.value();
                if (in.pick(4) == 0) d.linear_damping = in.value();
                if (in.pick(4) == 0) d.angular_damping = in.value();
                // Every fifth body a sensor, from the count rather than the input, so the committed
                // corpus decodes as it did before sensors came.
                d.is_sensor = s.bodies.size() % 5 == 4 ? 1 : 0;
                sinew_body_id id;
                if (s.watch(sinew_body_create(s.world, &d, &id), "sinew_body_create") == SINEW_OK) s.bodies.push_back(id);
                break;
            }
            case 2: {
                const sinew_body_id b = s.body(in);
                if (s.watch(sinew_body_destroy(b), "sinew_body_destroy") == SINEW_OK) forget(s.bodies, b);
                break;
            }
            case 3: s.watch(sinew_body_set_velocity(s.body(in), in.vec(), in.vec()), "sinew_body_set_velocity"); break;
            case 4: s.watch(sinew_body_apply_force(s.body(in), in.vec(), in.sane_vec()), "sinew_body_apply_force"); break;
            case 5: s.watch(sinew_body_apply_impulse(s.body(in), in.vec(), in.sane_vec()), "sinew_body_apply_impulse"); break;
            case 6: {
                sinew_transform t{in.sane_vec(), {0, 0, 0, 1}};
                if (in.pick(3) == 0) t.q = {in.value(), in.value(), in.value(), in.value()};
                s.watch(sinew_body_set_transform(s.body(in), &t), "sinew_body_set_transform");
                break;
            }
            case 7:
            case 8: {  // a joint
                sinew_joint_def d = sinew_joint_def_default();
                d.type = sinew_joint_type(in.pick(6));
                d.body_a = s.body(in);
                d.body_b = s.body(in);
                d.local_anchor_a = in.pick(2) ? in.sane_vec() : in.vec();
                d.local_anchor_b = in.sane_vec();
                if (in.pick(2)) d.local_axis_a = in.vec();
                d.collide_connected = in.pick(2);
                d.enable_limit = in.pick(2);
                d.lower = in.value();
                d.upper = in.value();
                d.enable_motor = in.pick(2);
                d.motor_speed = in.value();
                d.max_motor_force = in.value();
                if (in.pick(2)) d.length = in.value();
                if (in.pick(3) == 0) d.frequency = in.value();
                if (in.pick(3) == 0) d.damping_ratio = in.value();
                if (in.pick(3) == 0) d.break_force = in.value();
                sinew_joint_id id;
                if (s.watch(sinew_joint_create(s.world, &d, &id), "sinew_joint_create") == SINEW_OK) s.joints.push_back(id);
                break;
            }
            case 9:
                if (!s.joints.empty())
                    s.watch(sinew_joint_destroy(s.joints[std::size_t(in.pick(int(s.joints.size())))]), "sinew_joint_destroy");
                break;
            case 10:
                if (!s.joints.empty())
                    s.watch(sinew_joint_set_motor(s.joints[std::size_t(in.pick(int(s.joints.size())))], in.pick(3),
                                                  in.value(), in.value()),
                            "sinew_joint_set_motor");
                break;
            case 11:
            case 12:
            case 13: {  // steps
                if (steps >= kMaxSteps) break;
                sinew_status st;
                if (in.pick(2)) {
                    st = s.watch(sinew_world_step_fixed(s.world), "sinew_world_step_fixed");
                    ++steps;
                } else {
                    int taken = 0;
                    float alpha = 0;
                    const float dt = in.pick(2) ? float(in.pick(4)) / 60.0f : in.value();
                    st = s.watch(sinew_world_step(s.world, dt, &taken, &alpha), "sinew_world_step");
                    steps += taken;
                    if (taken > max_per_frame && s.finding.empty()) s.finding = "sinew_world_step took more steps than max_steps_per_frame allows";
                }
                s.check_state(st, steps);
                break;
            }
            case 14: {  // soft bodies
                if (int(s.soft.size()) >= kMaxSoft) break;
                const sinew_soft_def d = soft_def(in);
                sinew_soft_body_id id;
                sinew_status st = SINEW_ERROR_INVALID_ARGUMENT;
                switch (in.pick(4)) {
                    case 0: {
                        sinew_cloth_def c = sinew_cloth_def_default();
                        c.nx = in.pick(10) - 1;
                        c.ny = 2 + in.pick(8);
                        c.origin = in.sane_vec();
                        if (in.pick(2)) c.edge_u = in.sane_vec();
                        if (in.pick(3) == 0) c.edge_v = in.vec();
                        c.shear = in.pick(2);
                        c.bend = in.pick(2);
                        c.pinned_corners = in.pick(20);
                        st = sinew_soft_create_cloth(s.world, &d, &c, &id);
                        break;
                    }
                    case 1: st = sinew_soft_create_rope(s.world, &d, in.sane_vec(), in.sane_vec(), in.pick(20) - 1, &id); break;
                    case 2: st = sinew_soft_create_icosphere(s.world, &d, in.sane_vec(), in.sane(), in.pick(4) - 1, &id); break;
                    default: {
                        sinew_fem_material m = sinew_fem_material_default();
                        if (in.pick(2)) m.young = in.value();
                        if (in.pick(2)) m.poisson = in.value();
                        if (in.pick(3) == 0) m.density = in.value();
                        if (in.pick(3) == 0) m.yield = in.value();
                        if (in.pick(3) == 0) m.creep = in.value();
                        if (in.pick(3) == 0) m.max_plastic = in.value();
                        if (in.pick(3) == 0) m.stiffness_damping = in.value();
                        m.rotation = sinew_fem_rotation(in.pick(4));
                        st = sinew_soft_create_tet_box(s.world, &d, &m, in.sane_vec(), in.sane_vec(), in.pick(4), 1 + in.pick(3),
                                                       1 + in.pick(3), in.pick(8), &id);
                        break;
                    }
                }
                if (s.watch(st, "sinew_soft_create_*") == SINEW_OK) s.soft.push_back(id);
                break;
            }
            case 15: {
                const sinew_soft_body_id b = s.soft_body(in);
                const int particle = in.pick(40) - 2;
                switch (in.pick(5)) {
                    case 0: s.watch(sinew_soft_set_pinned(b, particle, in.pick(3)), "sinew_soft_set_pinned"); break;
                    case 1: s.watch(sinew_soft_attach(b, particle, s.body(in), in.sane_vec()), "sinew_soft_attach"); break;
                    case 2: s.watch(sinew_soft_detach(b, particle), "sinew_soft_detach"); break;
                    case 3: s.watch(sinew_soft_set_particle_position(b, particle, in.vec()), "sinew_soft_set_particle_position"); break;
                    default: s.watch(sinew_soft_apply_particle_force(b, particle, in.vec()), "sinew_soft_apply_particle_force"); break;
                }
                break;
            }
            case 16: {
                const sinew_soft_body_id b = s.soft_body(in);
                if (s.watch(sinew_soft_destroy(b), "sinew_soft_destroy") == SINEW_OK) forget(s.soft, b);
                break;
            }
            case 17: s.watch(sinew_world_set_solver(s.world, sinew_solver(in.pick(6)), in.pick(14) - 1), "sinew_world_set_solver"); break;
            case 18: s.watch(sinew_world_set_gravity(s.world, in.vec()), "sinew_world_set_gravity"); break;
            case 19: {
                s.watch(sinew_world_set_coupling(s.world, sinew_coupling(in.pick(7)), in.value()), "sinew_world_set_coupling");
                if (!s.soft.empty() && in.pick(2))
                    s.watch(sinew_world_set_pair_coupling(s.world, s.soft_body(in), in.pick(2) ? s.body(in) : sinew_body_id{0, 0, 0},
                                                          sinew_coupling(in.pick(7))),
                            "sinew_world_set_pair_coupling");
                break;
            }
            case 20: {
                sinew_ray_hit hit;
                int found = 0;
                s.watch(sinew_world_ray_cast(s.world, in.vec(), in.vec(), &hit, &found), "sinew_world_ray_cast");
                sinew_body_id ids[8];
                int count = 0;
                s.watch(sinew_world_overlap_aabb(s.world, in.sane_vec(), in.vec(), ids, 8, &count), "sinew_world_overlap_aabb");
                sinew_shape_def shape{};
                shape.type = sinew_shape_type(in.pick(4));
                shape.radius = in.sane();
                shape.half_height = in.sane();
                shape.half_extents = in.sane_vec();
                const sinew_transform t{in.sane_vec(), {0, 0, 0, 1}};
                s.watch(sinew_world_overlap_shape(s.world, &shape, &t, ids, 8, &count), "sinew_world_overlap_shape");
                // The same shape swept and measured, from values already read (the corpus decodes as before).
                const sinew_filter all = sinew_filter_default();
                sinew_shape_cast_hit cast;
                s.watch(sinew_world_cast_shape(s.world, &shape, &t, shape.half_extents, all, &cast, &found),
                        "sinew_world_cast_shape");
                sinew_ray_hit hits[4];
                s.watch(sinew_world_ray_cast_all(s.world, t.p, shape.half_extents, all, hits, 4, &count), "sinew_world_ray_cast_all");
                if (!s.bodies.empty()) {
                    sinew_closest_points cp;
                    s.watch(sinew_world_closest_points(s.world, &shape, &t, s.bodies.back(), shape.radius, &cp, &found),
                            "sinew_world_closest_points");
                }
                break;
            }
            case 21: s.watch(sinew_body_set_material(s.body(in), in.value(), in.value()), "sinew_body_set_material"); break;
            case 22: {
                sinew_events ev;
                s.watch(sinew_world_get_events(s.world, &ev), "sinew_world_get_events");
                for (std::size_t k = 0; k < s.bodies.size(); ++k) {
                    const sinew_body_id& b = s.bodies[k];
                    sinew_sensor_event o[4];
                    int count = 0;
                    s.watch(sinew_sensor_get_overlaps(b, o, 4, &count), "sinew_sensor_get_overlaps");
                    // Type and enabled changes, chosen from the state rather than the input (the corpus
                    // decodes as before): every seventh body toggled, every eleventh given another type.
                    const std::size_t turn = k + std::size_t(steps);
                    if (turn % 7 == 0) {
                        int on = 1;
                        s.watch(sinew_body_is_enabled(b, &on), "sinew_body_is_enabled");
                        s.watch(sinew_body_set_enabled(b, on ? 0 : 1), "sinew_body_set_enabled");
                    }
                    if (turn % 11 == 0)
                        s.watch(sinew_body_set_type(b, sinew_body_type(turn % 3)), "sinew_body_set_type");
                }
                break;
            }
            default: {
                // Filters: any bits and groups, on live, stale and foreign handles.
                const int k = in.pick(4);
                if (k < 2) {
                    const sinew_filter f{in.bits(), in.bits(), std::int32_t(in.bits())};
                    if (k == 0) s.watch(sinew_body_set_filter(s.body(in), f), "sinew_body_set_filter");
                    else s.watch(sinew_soft_set_filter(s.soft_body(in), f), "sinew_soft_set_filter");
                    break;
                }
                if (k == 2) {  // a moving platform's target, anywhere, in any step
                    sinew_transform t{in.pick(2) ? in.sane_vec() : in.vec(), {in.value(), in.value(), in.value(), in.value()}};
                    if (in.pick(2)) t.q = {0, 0, 0, 1};
                    s.watch(sinew_body_set_target_transform(s.body(in), &t, in.pick(2) ? 1.0f / 60 : in.value()),
                            "sinew_body_set_target_transform");
                    break;
                }
                sinew_vec3 f, t;
                if (!s.joints.empty())
                    s.watch(sinew_joint_get_reaction(s.joints[std::size_t(in.pick(int(s.joints.size())))], &f, &t),
                            "sinew_joint_get_reaction");
                sinew_vec3 v, w;
                s.watch(sinew_body_get_velocity(s.body(in), &v, &w), "sinew_body_get_velocity");
                break;
            }
        }
    }
    s.watch(sinew_world_destroy(s.world), "sinew_world_destroy");
    return s.finding;
}

}  // namespace sinew::fuzz
