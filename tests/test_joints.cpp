// Joints (rigid/joint_set.hpp): physical outcomes against closed forms — pendulum periods, a hanging
// chain's joint error, limits, motors (target speed, and torque-bounded acceleration), a spring's
// frequency and static stretch, a weld's relative pose, breaking — run with the default sequential-
// impulse solver (split impulses) and, where the physics allows, soft step and the Newton solver; plus
// validation of bad definitions and the joints' life cycle with their bodies.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "engine/world/scene.hpp"
#include "engine/world/world.hpp"
#include "rigid/joint_set.hpp"

using namespace sinew;

namespace {

struct SolverCase {
    const char* name;
    RigidSolverKind kind;
};
const SolverCase kSplit{"sequential impulse, split impulses", RigidSolverKind::SplitImpulse};
const SolverCase kSoftStep{"sequential impulse, soft step", RigidSolverKind::SoftStep};
const SolverCase kNewton{"newton impulses", RigidSolverKind::Newton};
const SolverCase kAll[] = {kSplit, kSoftStep, kNewton};

WorldSettings settings_for(const SolverCase& c, Real h, const Vec3& gravity) {
    WorldSettings ws;
    ws.time_step = h;
    ws.rigid.solver = c.kind;
    ws.rigid.gravity = gravity;
    ws.rigid.sleeping = false;  // the tests watch bodies that come to rest
    return ws;
}

const Vec3 kGravity(0, Real(-9.81), 0);

BodyId add_body(RigidSystem& rs, BodyType type, const Shape& shape, const Vec3& position, Real mass = 0) {
    BodyDef d;
    d.type = type;
    d.shape = shape;
    d.pose.p = position;
    if (type == BodyType::Dynamic) d.mass = mass;
    return rs.create_body(d);
}

/// A square loop of four 1 kg bars of 1 m x 6 cm x 6 cm (inertias 140:1, symmetric about their long
/// axes) joined end to end by ball joints at the corners (0,0), (1,0), (1,-1), (0,-1) of the x-y plane, hung
/// by corner (0,0) from a post clear of the bars (0.3 m above it, through the joint's anchor). With
/// `collide` false the bars meet nothing.
struct BarLoop {
    BodyId bar[4];
    Vec3 long_axis[4];  ///< each bar's long axis in its own frame
    std::vector<JointId> joints;
};
BarLoop make_bar_loop(RigidSystem& rs, bool collide) {
    BarLoop loop;
    const BodyId post = add_body(rs, BodyType::Static, make_sphere(Real(0.02)), Vec3(0, Real(0.3), 0));
    const Vec3 corner[4] = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, -1, 0), Vec3(0, -1, 0)};
    for (int k = 0; k < 4; ++k) {
        const Vec3 a = corner[k], b = corner[(k + 1) % 4];
        const bool along_x = std::abs(b.x() - a.x()) > Real(0.5);
        loop.long_axis[k] = along_x ? Vec3::UnitX() : Vec3::UnitY();
        BodyDef d;
        d.shape = make_box(along_x ? Vec3(Real(0.5), Real(0.03), Real(0.03)) : Vec3(Real(0.03), Real(0.5), Real(0.03)));
        d.pose.p = (a + b) / 2;
        d.mass = 1;
        if (!collide) d.filter.group = -1;
        loop.bar[k] = rs.create_body(d);
    }
    const auto join = [&](BodyId x, BodyId y, const Vec3& at) {
        JointDef jd;
        jd.type = JointType::Ball;
        jd.body_a = x;
        jd.body_b = y;
        jd.local_anchor_a = at - rs.transform(x).p;
        jd.local_anchor_b = at - rs.transform(y).p;
        loop.joints.push_back(rs.create_joint(jd));
    };
    join(post, loop.bar[0], corner[0]);
    for (int k = 0; k < 4; ++k) join(loop.bar[k], loop.bar[(k + 1) % 4], corner[(k + 1) % 4]);
    return loop;
}

/// Times (s) at which x(t) crosses zero upwards, linearly interpolated between samples.
struct CrossingTimer {
    double last_t = 0, last_x = 0;
    bool started = false;
    std::vector<double> crossings;
    void sample(double t, double x) {
        if (started && last_x < 0 && x >= 0) crossings.push_back(last_t + (t - last_t) * (-last_x) / (x - last_x));
        last_t = t;
        last_x = x;
        started = true;
    }
    /// Mean period over all whole periods recorded.
    double period() const {
        REQUIRE(crossings.size() >= 2);
        return (crossings.back() - crossings.front()) / double(crossings.size() - 1);
    }
};

const double kPiD = 3.14159265358979323846;

}  // namespace

// ---- pendulums ----------------------------------------------------------------------------------------

TEST_CASE("a small-amplitude pendulum on a ball joint or a hinge swings with the physical period", "[joints]") {
    // A sphere of radius r = 0.05 m and mass 1 kg hangs L = 1 m below a static pivot, released from rest
    // 5 degrees off vertical. It is a physical pendulum (the anchor is fixed in the sphere, so the sphere
    // turns as it swings): T0 = 2 pi sqrt(I_pivot / (m g L)), I_pivot = 2/5 m r^2 + m L^2, and the
    // finite amplitude lengthens it by theta0^2 / 16 (0.05 %).
    // h = 1/240: semi-implicit Euler's period error is O((omega h)^2) = (3.1 / 240)^2 ~ 2e-4. Each step
    // the point block is solved exactly in one iteration for one moving body (K^-1 is its exact effective
    // mass), so the default iteration counts converge; Baumgarte only removes the O(h^2 v^2 / L) drift of
    // the anchor, which does not change the period measurably. Crossings are interpolated between
    // samples, so timing error is far below h. Budget: 1 % (what was asked); the measured deviation is
    // about 1e-5 for all three solvers.
    const Real r = Real(0.05), L = 1, m = 1;
    const double theta0 = 5 * kPiD / 180;
    const double g = 9.81;
    const double i_pivot = 0.4 * m * r * r + m * L * L;
    const double expected = 2 * kPiD * std::sqrt(i_pivot / (m * g * L)) * (1 + theta0 * theta0 / 16);
    const Real h = Real(1) / 240;

    for (const SolverCase& sc : kAll) {
        for (JointType type : {JointType::Ball, JointType::Hinge}) {
            INFO(sc.name << ", " << joint_type_name(type) << " joint");
            World world(settings_for(sc, h, kGravity));
            RigidSystem& rs = world.rigid();
            const BodyId pivot = add_body(rs, BodyType::Static, make_sphere(Real(0.02)), Vec3::Zero());
            const Vec3 bob_pos(Real(L * std::sin(theta0)), Real(-L * std::cos(theta0)), 0);
            const BodyId bob = add_body(rs, BodyType::Dynamic, make_sphere(r), bob_pos, m);
            JointDef jd;
            jd.type = type;
            jd.body_a = pivot;
            jd.body_b = bob;
            jd.local_anchor_a = Vec3::Zero();
            jd.local_anchor_b = -bob_pos;  // the pivot, in the (unrotated) bob's frame
            jd.local_axis_a = Vec3::UnitZ();
            const JointId j = rs.create_joint(jd);
            CrossingTimer timer;
            Real max_error = 0;
            const int steps = int(4.5 * expected / h);  // four whole periods and a bit
            for (int i = 1; i <= steps; ++i) {
                world.step();
                timer.sample(i * double(h), double(rs.transform(bob).p.x()));
                max_error = std::max(max_error, rs.joints().position_error(j, rs));
            }
            CHECK(timer.crossings.size() >= 4);
            CHECK(timer.period() == Approx(expected).epsilon(0.01));
            // The anchor stays on the pivot: the drift per step is ~ (h v)^2 / (2 L) ~ 1e-7 m before
            // correction; 1 mm is generous for all three solvers.
            CHECK(max_error < Real(1e-3));
        }
    }
}

// ---- chain --------------------------------------------------------------------------------------------

TEST_CASE("a 20-link chain released horizontally settles with every joint within 1 mm", "[joints]") {
    // Box links 0.3 m long (1 kg each) joined end to end by ball joints, the first pinned to a static
    // body, released straight out along x and damped (linear and angular damping 1/s) so the 6 m chain
    // comes to rest within the 15 s simulated. Default settings otherwise (h = 1/60, 10 iterations,
    // warm starting).
    // - Sequential impulses with split impulses: warm starting converges to the exact support impulses
    //   at rest, and the position projection removes the residual error, so it ends far below 1 mm.
    // - Soft step (default sub-steps: velocity_iterations / 2 = 5): its joints are springs of
    //   2 x contact_hertz = 120 Hz, so joint k sags by the weight below it over k = m_eff omega^2: at
    //   most 19 * 9.81 / (2 pi 120)^2 * 2 = 0.66 mm (two 1 kg links share each interior joint's row
    //   mass), under the 1 mm asked for. Also with 8 sub-steps (a softer, better resolved spring).
    const int n = 20;
    const Real link = Real(0.3), half = link / 2;
    struct ChainCase {
        SolverCase solver;
        int substeps;
    };
    for (const ChainCase& cc : {ChainCase{kSplit, 0}, ChainCase{kSoftStep, 0}, ChainCase{kSoftStep, 8}}) {
        INFO(cc.solver.name << ", substeps = " << cc.substeps << " (0 = default)");
        WorldSettings ws = settings_for(cc.solver, Real(1) / 60, kGravity);
        ws.rigid.substeps = cc.substeps;
        World world(ws);
        RigidSystem& rs = world.rigid();
        const BodyId anchor = add_body(rs, BodyType::Static, make_box(Vec3::Constant(Real(0.05))), Vec3(0, 0, 0));
        std::vector<JointId> joints;
        BodyId prev = anchor;
        for (int i = 0; i < n; ++i) {
            BodyDef d;
            d.shape = make_box(Vec3(half, Real(0.04), Real(0.04)));
            d.pose.p = Vec3((Real(i) + Real(0.5)) * link, 0, 0);
            d.mass = 1;
            d.linear_damping = 1;
            d.angular_damping = 1;
            const BodyId cur = rs.create_body(d);
            JointDef jd;
            jd.type = JointType::Ball;
            jd.body_a = prev;
            jd.body_b = cur;
            jd.local_anchor_a = i == 0 ? Vec3::Zero() : Vec3(half, 0, 0);
            jd.local_anchor_b = Vec3(-half, 0, 0);
            joints.push_back(rs.create_joint(jd));
            prev = cur;
        }
        Real max_during = 0, max_late = 0;
        const int steps = 15 * 60;
        for (int s = 0; s < steps; ++s) {
            world.step();
            for (JointId j : joints) {
                const Real e = rs.joints().position_error(j, rs);
                max_during = std::max(max_during, e);
                if (s >= steps - 60) max_late = std::max(max_late, e);  // the last second
            }
        }
        REQUIRE(rs.all_finite());
        INFO("max error while swinging " << max_during << " m, in the last second " << max_late << " m");
        CHECK(max_late < Real(1e-3));
        // While it swings and whips, the error stays bounded (a centimetre or two at most).
        CHECK(max_during < Real(0.03));
        // Settled: hanging straight down, the last link's far end ~6 m below the pivot.
        const Vec3 end = rs.transform(prev).apply(Vec3(half, 0, 0));
        CHECK(end.y() == Approx(-n * link).margin(0.02));
        CHECK(std::abs(end.x()) < Real(0.02));
        CHECK(rs.kinetic_energy() < 1e-3);
    }
}

// ---- hinge limit and motor ----------------------------------------------------------------------------

TEST_CASE("a hinge limit stops a falling arm at the limit angle", "[joints]") {
    // A 1 m arm (box, 2 kg) hinged at one end to a static body about z, released horizontal: angle 0 at
    // creation, falling towards negative angles. Limit [-0.5, 0.5] rad. The limit row is speculative (it
    // allows approaching the limit by the remaining gap each step), so the arm should not pass the limit
    // by more than the position correction's residual: 0.01 rad (0.6 degrees).
    for (const SolverCase& sc : kAll) {
        INFO(sc.name);
        World world(settings_for(sc, Real(1) / 60, kGravity));
        RigidSystem& rs = world.rigid();
        const BodyId base = add_body(rs, BodyType::Static, make_box(Vec3::Constant(Real(0.05))), Vec3::Zero());
        const BodyId arm = add_body(rs, BodyType::Dynamic, make_box(Vec3(Real(0.5), Real(0.05), Real(0.05))),
                                    Vec3(Real(0.6), 0, 0), 2);
        JointDef jd;
        jd.type = JointType::Hinge;
        jd.body_a = base;
        jd.body_b = arm;
        jd.local_anchor_b = Vec3(Real(-0.6), 0, 0);
        jd.local_axis_a = Vec3::UnitZ();
        jd.enable_limit = true;
        jd.lower = Real(-0.5);
        jd.upper = Real(0.5);
        const JointId j = rs.create_joint(jd);
        Real min_angle = 0;
        for (int s = 0; s < 180; ++s) {
            world.step();
            min_angle = std::min(min_angle, rs.joints().coordinate(j, rs));
        }
        CHECK(min_angle > Real(-0.5 - 0.01));
        CHECK(rs.joints().coordinate(j, rs) == Approx(-0.5).margin(0.01));  // resting on the limit
        CHECK(rs.joints().position_error(j, rs) < Real(1e-3));
        CHECK(rs.joints().angular_error(j, rs) < Real(1e-3));
    }
}

TEST_CASE("a hinge motor reaches its speed, or accelerates at torque / inertia when saturated", "[joints]") {
    // A 1 m x 1 m x 0.2 m plate of 2 kg hinged at its centre of mass about z, no gravity: I_zz =
    // m (1^2 + 1^2) / 12 = 1/3 kg m^2, and the point block carries no torque about the centre.
    const Real m = 2, i_zz = m * 2 / 12;
    for (const SolverCase& sc : kAll) {
        INFO(sc.name);
        const Real h = Real(1) / 60;
        World world(settings_for(sc, h, Vec3::Zero()));
        RigidSystem& rs = world.rigid();
        const BodyId base = add_body(rs, BodyType::Static, make_box(Vec3::Constant(Real(0.05))), Vec3(0, 0, -2));
        const BodyId plate = add_body(rs, BodyType::Dynamic, make_box(Vec3(Real(0.5), Real(0.5), Real(0.1))),
                                      Vec3::Zero(), m);
        JointDef jd;
        jd.type = JointType::Hinge;
        jd.body_a = base;
        jd.body_b = plate;
        jd.local_anchor_a = Vec3(0, 0, 2);
        jd.local_axis_a = Vec3::UnitZ();
        jd.enable_motor = true;
        jd.motor_speed = 3;
        jd.max_motor_force = 100;  // 100 N m reaches 3 rad/s in one step: needs 3 I / h = 60 N m
        const JointId j = rs.create_joint(jd);
        world.step();
        // Unsaturated: the motor row solves C-dot = speed exactly (one body, exact effective mass).
        CHECK(rs.angular_velocity(plate).z() == Approx(3).epsilon(1e-3));
        for (int s = 0; s < 30; ++s) world.step();
        CHECK(rs.angular_velocity(plate).z() == Approx(3).epsilon(1e-3));
        CHECK(rs.joints().coordinate(j, rs) != Approx(0).margin(0.1));  // it does turn

        // Saturated: 0.5 N m towards 100 rad/s. From rest, each step adds exactly tau h / I, so after
        // 1 s: omega = tau t / I = 1.5 rad/s (0.1 % for rounding and the off-axis rows).
        rs.set_velocity(plate, Vec3::Zero(), Vec3::Zero());
        rs.joints().set_motor(j, true, 100, Real(0.5));
        for (int s = 0; s < 60; ++s) world.step();
        CHECK(rs.angular_velocity(plate).z() == Approx(0.5 * 1.0 / i_zz).epsilon(1e-3));
        CHECK(rs.joints().reaction_torque(j).z() == Approx(0.5).epsilon(1e-3));
        // The body stays on the axis while it spins.
        CHECK(rs.joints().position_error(j, rs) < Real(1e-4));
        CHECK(rs.joints().angular_error(j, rs) < Real(1e-3));
    }
}

// ---- slider -------------------------------------------------------------------------------------------

TEST_CASE("a slider keeps a box on its axis and stops it at its limits", "[joints]") {
    // A 1 kg box slides along x on a slider to a static body, under gravity (the perpendicular rows
    // carry its weight), launched at 3 m/s towards the upper limit 0.5 m, later at -3 m/s towards the
    // lower limit -0.25 m. Speculative limit rows stop it at the limit: 1 mm of overshoot allowed.
    for (const SolverCase& sc : kAll) {
        INFO(sc.name);
        World world(settings_for(sc, Real(1) / 60, kGravity));
        RigidSystem& rs = world.rigid();
        const BodyId base = add_body(rs, BodyType::Static, make_box(Vec3::Constant(Real(0.05))), Vec3(0, 5, 0));
        const BodyId box = add_body(rs, BodyType::Dynamic, make_box(Vec3::Constant(Real(0.1))), Vec3::Zero(), 1);
        JointDef jd;
        jd.type = JointType::Slider;
        jd.body_a = base;
        jd.body_b = box;
        jd.local_anchor_a = Vec3(0, -5, 0);
        jd.local_axis_a = Vec3::UnitX();
        jd.enable_limit = true;
        jd.lower = Real(-0.25);
        jd.upper = Real(0.5);
        const JointId j = rs.create_joint(jd);
        rs.set_velocity(box, Vec3(3, 0, 0), Vec3::Zero());
        Real max_t = 0;
        for (int s = 0; s < 60; ++s) {
            world.step();
            max_t = std::max(max_t, rs.joints().coordinate(j, rs));
        }
        CHECK(max_t < Real(0.5 + 1e-3));
        CHECK(rs.joints().coordinate(j, rs) == Approx(0.5).margin(1e-3));
        CHECK(std::abs(rs.linear_velocity(box).x()) < Real(1e-3));  // stopped, no bounce
        CHECK(rs.joints().position_error(j, rs) < Real(1e-3));      // held on the axis against gravity
        CHECK(rs.joints().angular_error(j, rs) < Real(1e-3));
        rs.set_velocity(box, Vec3(-3, 0, 0), Vec3::Zero());
        Real min_t = 1;
        for (int s = 0; s < 60; ++s) {
            world.step();
            min_t = std::min(min_t, rs.joints().coordinate(j, rs));
        }
        CHECK(min_t > Real(-0.25 - 1e-3));
        CHECK(rs.joints().coordinate(j, rs) == Approx(-0.25).margin(1e-3));
        // It holds the weight: 9.81 N upwards on the box.
        CHECK(rs.joints().reaction_force(j).y() == Approx(9.81).epsilon(0.01));
    }
}

TEST_CASE("a slider motor reaches its speed, or accelerates at force / mass when saturated", "[joints]") {
    const Real m = 2;
    for (const SolverCase& sc : kAll) {
        INFO(sc.name);
        World world(settings_for(sc, Real(1) / 60, Vec3::Zero()));
        RigidSystem& rs = world.rigid();
        const BodyId base = add_body(rs, BodyType::Static, make_box(Vec3::Constant(Real(0.05))), Vec3(0, 2, 0));
        const BodyId box = add_body(rs, BodyType::Dynamic, make_box(Vec3::Constant(Real(0.2))), Vec3::Zero(), m);
        JointDef jd;
        jd.type = JointType::Slider;
        jd.body_a = base;
        jd.body_b = box;
        jd.local_anchor_a = Vec3(0, -2, 0);
        jd.local_axis_a = Vec3(1, 0, 0);
        jd.enable_motor = true;
        jd.motor_speed = 2;
        jd.max_motor_force = 1000;  // 2 m/s in one step needs m v / h = 240 N
        const JointId j = rs.create_joint(jd);
        world.step();
        CHECK(rs.linear_velocity(box).x() == Approx(2).epsilon(1e-3));
        for (int s = 0; s < 30; ++s) world.step();
        CHECK(rs.linear_velocity(box).x() == Approx(2).epsilon(1e-3));
        CHECK(rs.joints().coordinate(j, rs) == Approx(2 * 31.0 / 60).epsilon(1e-2));

        // Saturated: 1 N towards 50 m/s: a = F / m = 0.5 m/s^2, so 0.5 m/s after 1 s from rest.
        rs.set_velocity(box, Vec3::Zero(), Vec3::Zero());
        rs.joints().set_motor(j, true, 50, 1);
        for (int s = 0; s < 60; ++s) world.step();
        CHECK(rs.linear_velocity(box).x() == Approx(1.0 / m).epsilon(1e-3));
        CHECK(rs.joints().reaction_force(j).x() == Approx(1).epsilon(1e-3));
        CHECK(rs.joints().position_error(j, rs) < Real(1e-4));
    }
}

// ---- distance -----------------------------------------------------------------------------------------

TEST_CASE("a soft distance joint oscillates at its frequency and stretches by m g / k", "[joints]") {
    // A 1 kg sphere on a 1 Hz spring of rest length 1 m to a static body, anchors at the centres, so the
    // row's effective mass is the sphere's mass and omega = 2 pi rad/s exactly. Without gravity, started
    // 0.1 m stretched and undamped: Catto's soft constraint is implicit Euler, which damps the amplitude
    // (~30 % per period at h = 1/60) and lengthens the period by about (omega h)^2 / 3 = 0.37 % (measured
    // 0.36 %; 0.02 % with soft step's 4 sub-steps); 1 % allowed.
    // With gravity and critical damping it settles at the static stretch g / omega^2 = 0.2485 m.
    const Real h = Real(1) / 60;
    for (const SolverCase& sc : kAll) {
        INFO(sc.name);
        {
            World world(settings_for(sc, h, Vec3::Zero()));
            RigidSystem& rs = world.rigid();
            const BodyId base = add_body(rs, BodyType::Static, make_sphere(Real(0.05)), Vec3::Zero());
            const BodyId bob = add_body(rs, BodyType::Dynamic, make_sphere(Real(0.1)), Vec3(Real(1.1), 0, 0), 1);
            JointDef jd;
            jd.type = JointType::Distance;
            jd.body_a = base;
            jd.body_b = bob;
            jd.length = 1;
            jd.frequency = 1;
            jd.damping_ratio = 0;
            const JointId j = rs.create_joint(jd);
            CHECK(rs.joints().def(j).length == Approx(1));
            CrossingTimer timer;
            for (int s = 1; s <= 4 * 60 + 30; ++s) {
                world.step();
                // Stretch, sampled with the sign flipped so the first crossing is upwards after the
                // release from +0.1 m.
                timer.sample(s * double(h), -double(rs.joints().coordinate(j, rs) - 1));
            }
            CHECK(timer.crossings.size() >= 4);
            CHECK(timer.period() == Approx(1.0).epsilon(0.01));
        }
        {
            World world(settings_for(sc, h, kGravity));
            RigidSystem& rs = world.rigid();
            const BodyId base = add_body(rs, BodyType::Static, make_sphere(Real(0.05)), Vec3::Zero());
            const BodyId bob = add_body(rs, BodyType::Dynamic, make_sphere(Real(0.1)), Vec3(0, -1, 0), 1);
            JointDef jd;
            jd.type = JointType::Distance;
            jd.body_a = base;
            jd.body_b = bob;  // length < 0: the distance at creation, 1 m
            jd.frequency = 1;
            jd.damping_ratio = 1;
            const JointId j = rs.create_joint(jd);
            for (int s = 0; s < 5 * 60; ++s) world.step();
            const double stretch = 9.81 / (4 * kPiD * kPiD);
            CHECK(rs.joints().coordinate(j, rs) - 1 == Approx(stretch).epsilon(0.02));
            CHECK(rs.joints().reaction_force(j).y() == Approx(9.81).epsilon(0.02));
        }
    }
}

TEST_CASE("a rigid distance joint keeps its length while the body swings", "[joints]") {
    // A 1 kg sphere on a 1 m rod released horizontal swings through the bottom at v = sqrt(2 g L) =
    // 4.4 m/s. Each step the velocity row keeps the chord's length rate at zero, so the body drifts
    // outwards by (h v)^2 / (2 L) = 2.7 mm per step at the bottom. Split impulses project that out after
    // each step and soft step's 120 Hz joint stretches by (m v^2/L + m g) / (m omega^2) = 0.05 mm:
    // both stay under 1 mm. The Newton solver removes it with a Baumgarte bias, 20 % per step, so its
    // error settles near drift / beta = 13.6 mm: bounded by 1.2 x that.
    const Real h = Real(1) / 60, L = 1;
    const double v_max = std::sqrt(2 * 9.81 * L);
    const double drift = (h * v_max) * (h * v_max) / (2 * L);
    for (const SolverCase& sc : kAll) {
        INFO(sc.name);
        World world(settings_for(sc, h, kGravity));
        RigidSystem& rs = world.rigid();
        const BodyId base = add_body(rs, BodyType::Static, make_sphere(Real(0.05)), Vec3::Zero());
        const BodyId bob = add_body(rs, BodyType::Dynamic, make_sphere(Real(0.1)), Vec3(L, 0, 0), 1);
        JointDef jd;
        jd.type = JointType::Distance;
        jd.body_a = base;
        jd.body_b = bob;
        const JointId j = rs.create_joint(jd);
        Real worst = 0;
        for (int s = 0; s < 120; ++s) {
            world.step();
            worst = std::max(worst, rs.joints().position_error(j, rs));
        }
        INFO("worst length error " << worst << " m");
        const double bound = sc.kind == RigidSolverKind::Newton ? 1.2 * drift / 0.2 : 1e-3;
        CHECK(worst < bound);
        CHECK(worst > 0);  // it is measured, not trivially zero
    }
}

// ---- fixed ----------------------------------------------------------------------------------------------

TEST_CASE("a fixed joint keeps two bodies' relative pose while they tumble", "[joints]") {
    // Zero gravity: a long box A (1 x 0.2 x 0.2 m, 1 kg) welded to a cube B (0.2 m, 0.5 kg) at its end.
    // Only A is given a velocity; the weld must drag B along in the first step and then keep the pair
    // tumbling as one body. Relative pose checked against the pose at creation: the linearised rows
    // leave an error of order (h |w|)^2 ~ 1e-3 per step, which the projection (split impulses), the
    // soft rows or the Baumgarte bias (Newton) remove; 1 mm and 5 mrad bound it (measured: at most
    // 0.4 mm and 0.8 mrad).
    for (const SolverCase& sc : kAll) {
        INFO(sc.name);
        World world(settings_for(sc, Real(1) / 60, Vec3::Zero()));
        RigidSystem& rs = world.rigid();
        const BodyId a = add_body(rs, BodyType::Dynamic, make_box(Vec3(Real(0.5), Real(0.1), Real(0.1))), Vec3::Zero(), 1);
        const BodyId b = add_body(rs, BodyType::Dynamic, make_box(Vec3::Constant(Real(0.1))), Vec3(Real(0.6), 0, 0),
                                  Real(0.5));
        JointDef jd;
        jd.type = JointType::Fixed;
        jd.body_a = a;
        jd.body_b = b;
        jd.local_anchor_a = Vec3(Real(0.5), 0, 0);
        jd.local_anchor_b = Vec3(Real(-0.1), 0, 0);
        const JointId j = rs.create_joint(jd);
        rs.set_velocity(a, Vec3(Real(0.5), 0, 0), Vec3(1, 2, Real(0.5)));
        const Transform rel0 = rs.transform(a).inverse() * rs.transform(b);
        Real worst_p = 0, worst_q = 0;
        for (int s = 0; s < 180; ++s) {
            world.step();
            const Transform rel = rs.transform(a).inverse() * rs.transform(b);
            worst_p = std::max(worst_p, Real((rel.p - rel0.p).norm()));
            worst_q = std::max(worst_q, Real(rel.q.angularDistance(rel0.q)));
        }
        INFO("worst position " << worst_p << " m, worst angle " << worst_q << " rad");
        CHECK(worst_p < Real(1e-3));  // including the first step's drag-along
        CHECK(worst_q < Real(5e-3));
        // After the transient, the weld holds tight.
        CHECK(rs.joints().position_error(j, rs) < Real(1e-3));
        CHECK(rs.joints().angular_error(j, rs) < Real(0.01));
        // The pair moves as one body: B's velocity is A's rigid-body velocity at B's centre.
        const Vec3 wa = rs.angular_velocity(a);
        const Vec3 vb_rigid = rs.linear_velocity(a) + wa.cross(rs.state().x[b.index] - rs.state().x[a.index]);
        CHECK((rs.angular_velocity(b) - wa).norm() < Real(0.02));
        CHECK((rs.linear_velocity(b) - vb_rigid).norm() < Real(0.02));
    }
}

// ---- breaking ---------------------------------------------------------------------------------------------

TEST_CASE("a breakable joint breaks under a load above its threshold and not below", "[joints]") {
    // A 2 kg sphere hanging at rest on a ball joint: the joint force is its weight W = 19.62 N.
    const Real m = 2;
    const Real weight = m * Real(9.81);
    for (const SolverCase& sc : kAll) {
        for (Real factor : {Real(0.8), Real(1.2)}) {
            INFO(sc.name << ", break_force = " << factor << " W");
            World world(settings_for(sc, Real(1) / 60, kGravity));
            RigidSystem& rs = world.rigid();
            const BodyId base = add_body(rs, BodyType::Static, make_sphere(Real(0.05)), Vec3::Zero());
            const BodyId bob = add_body(rs, BodyType::Dynamic, make_sphere(Real(0.1)), Vec3(0, -1, 0), m);
            JointDef jd;
            jd.type = JointType::Ball;
            jd.body_a = base;
            jd.body_b = bob;
            jd.local_anchor_b = Vec3(0, 1, 0);
            jd.break_force = factor * weight;
            const JointId j = rs.create_joint(jd);
            world.step();
            if (factor > 1) {
                REQUIRE(rs.joints().valid(j));
                CHECK(rs.broken_joints().empty());
                CHECK(rs.joints().reaction_force(j).y() == Approx(weight).epsilon(1e-3));
                for (int s = 0; s < 60; ++s) world.step();
                CHECK(rs.joints().valid(j));
                CHECK(rs.transform(bob).p.y() == Approx(-1).margin(1e-3));
            } else {
                CHECK_FALSE(rs.joints().valid(j));
                REQUIRE(rs.broken_joints().size() == 1);
                CHECK(rs.broken_joints()[0] == j);
                CHECK(rs.joints().count() == 0);
                for (int s = 0; s < 30; ++s) world.step();
                CHECK(rs.broken_joints().empty());  // cleared at the start of each step
                CHECK(rs.linear_velocity(bob).y() < Real(-4));  // falling freely (g t ~ 5 m/s)
            }
        }
    }
}

// ---- validation and life cycle ---------------------------------------------------------------------------

TEST_CASE("invalid joint definitions throw RigidError and create nothing", "[joints]") {
    RigidSystem rs;
    const BodyId ground = add_body(rs, BodyType::Static, make_box(Vec3::Constant(1)), Vec3(0, -1, 0));
    const BodyId a = add_body(rs, BodyType::Dynamic, make_sphere(Real(0.5)), Vec3(0, 1, 0), 1);
    const BodyId b = add_body(rs, BodyType::Dynamic, make_sphere(Real(0.5)), Vec3(2, 1, 0), 1);
    const BodyId gone = add_body(rs, BodyType::Dynamic, make_sphere(Real(0.5)), Vec3(4, 1, 0), 1);
    rs.destroy_body(gone);
    const BodyId wall = add_body(rs, BodyType::Static, make_box(Vec3::Constant(1)), Vec3(9, 0, 0));
    JointDef ok;
    ok.type = JointType::Hinge;
    ok.body_a = a;
    ok.body_b = b;
    const Real nan = std::numeric_limits<Real>::quiet_NaN();

    struct Bad {
        const char* what;
        JointDef def;
        const char* fragment;
    };
    std::vector<Bad> cases;
    auto add = [&](const char* what, const char* fragment, auto edit) {
        JointDef d = ok;
        edit(d);
        cases.push_back({what, d, fragment});
    };
    add("same body twice", "same body", [&](JointDef& d) { d.body_b = a; });
    add("stale body id", "stale", [&](JointDef& d) { d.body_b = gone; });
    add("null body id", "null", [&](JointDef& d) { d.body_a = BodyId{}; });
    add("two static bodies", "dynamic", [&](JointDef& d) { d.body_a = ground; d.body_b = wall; });
    add("NaN anchor", "local_anchor_a", [&](JointDef& d) { d.local_anchor_a = Vec3(0, nan, 0); });
    add("zero axis", "local_axis_a", [&](JointDef& d) { d.local_axis_a = Vec3::Zero(); });
    add("lower > upper", "greater than upper", [&](JointDef& d) { d.enable_limit = true; d.lower = 1; d.upper = -1; });
    add("hinge limit beyond pi", "[-pi, pi]", [&](JointDef& d) { d.enable_limit = true; d.upper = 4; });
    add("negative motor force", "max_motor_force", [&](JointDef& d) { d.max_motor_force = -1; });
    add("negative frequency", "frequency", [&](JointDef& d) { d.type = JointType::Distance; d.frequency = -1; });
    add("negative damping", "damping_ratio", [&](JointDef& d) { d.type = JointType::Distance; d.damping_ratio = -1; });
    add("negative break force", "break_force", [&](JointDef& d) { d.break_force = -5; });
    add("zero-length distance", "rest length", [&](JointDef& d) { d.type = JointType::Distance; d.length = 0; });
    add("coincident anchors, automatic length", "rest length", [&](JointDef& d) {
        d.type = JointType::Distance;
        d.local_anchor_b = Vec3(-2, 0, 0);  // b's origin is 2 m along x from a's
    });
    for (const Bad& c : cases) {
        INFO(c.what);
        CHECK_THROWS_AS(rs.create_joint(c.def), RigidError);
        CHECK_THROWS_WITH(rs.create_joint(c.def), Catch::Contains(c.fragment));
        CHECK(rs.joints().count() == 0);
    }
    // The base definition itself is fine, and a stale joint id is rejected.
    const JointId j = rs.create_joint(ok);
    CHECK(rs.joints().count() == 1);
    rs.destroy_joint(j);
    CHECK(rs.joints().count() == 0);
    CHECK_THROWS_AS(rs.destroy_joint(j), RigidError);
    CHECK_THROWS_AS(rs.joints().def(j), RigidError);
    CHECK_THROWS_AS(rs.joints().set_motor(JointId{}, true, 1, 1), RigidError);
}

TEST_CASE("destroying a body removes its joints, joints filter contacts unless collide_connected", "[joints]") {
    WorldSettings ws;
    ws.rigid.gravity = Vec3::Zero();
    World world(ws);
    RigidSystem& rs = world.rigid();
    // Three overlapping spheres in a row, joined 0-1 and 1-2.
    BodyId s[3];
    for (int i = 0; i < 3; ++i) s[i] = add_body(rs, BodyType::Dynamic, make_sphere(Real(0.5)), Vec3(Real(0.8) * i, 0, 0), 1);
    JointDef jd;
    jd.type = JointType::Ball;
    jd.body_a = s[0];
    jd.body_b = s[1];
    jd.local_anchor_a = Vec3(Real(0.4), 0, 0);
    jd.local_anchor_b = Vec3(Real(-0.4), 0, 0);
    const JointId j01 = rs.create_joint(jd);
    jd.body_a = s[1];
    jd.body_b = s[2];
    jd.collide_connected = true;
    const JointId j12 = rs.create_joint(jd);
    world.step();
    // Pair 0-1 is filtered; pair 1-2 collides (it asked to); 0-2 do not touch.
    bool contact01 = false, contact12 = false;
    for (const ContactManifold& c : rs.contacts()) {
        const auto pair = std::minmax(c.body_a, c.body_b);
        if (pair == std::minmax(s[0].index, s[1].index)) contact01 = true;
        if (pair == std::minmax(s[1].index, s[2].index)) contact12 = true;
    }
    CHECK_FALSE(contact01);
    CHECK(contact12);

    rs.destroy_body(s[2]);
    CHECK(rs.joints().count() == 1);
    CHECK(rs.joints().valid(j01));
    CHECK_FALSE(rs.joints().valid(j12));
    rs.destroy_body(s[0]);
    CHECK(rs.joints().count() == 0);
    CHECK_FALSE(rs.joints().valid(j01));
    world.step();  // nothing dangling
    CHECK(rs.all_finite());
}

TEST_CASE("a chain of joints sleeps as one island and wakes as one", "[joints]") {
    // A short hanging chain at rest falls asleep with its island; waking one end wakes the other end,
    // which it only touches through joints.
    WorldSettings ws;
    World world(ws);
    RigidSystem& rs = world.rigid();
    const BodyId anchor = add_body(rs, BodyType::Static, make_sphere(Real(0.05)), Vec3::Zero());
    BodyId prev = anchor;
    std::vector<BodyId> links;
    for (int i = 0; i < 3; ++i) {
        const BodyId cur = add_body(rs, BodyType::Dynamic, make_sphere(Real(0.1)), Vec3(0, Real(-0.5) * (i + 1), 0), 1);
        JointDef jd;
        jd.body_a = prev;
        jd.body_b = cur;
        jd.local_anchor_a = i == 0 ? Vec3::Zero() : Vec3(0, Real(-0.25), 0);
        jd.local_anchor_b = Vec3(0, Real(0.25), 0);
        rs.create_joint(jd);
        links.push_back(cur);
        prev = cur;
    }
    for (int s = 0; s < 120; ++s) world.step();
    for (BodyId b : links) CHECK_FALSE(rs.awake(b));
    rs.wake(links.front());
    for (BodyId b : links) CHECK(rs.awake(b));
}

// ---- scene files ---------------------------------------------------------------------------------------

TEST_CASE("scene files describe joints: the joints scene loads, builds and runs", "[joints][scene]") {
    const SceneDesc scene = parse_scene_file(std::string(SINEW_SOURCE_DIR) + "/tests/data/scenes/good/joints.json");
    REQUIRE(scene.joints.size() == 9);
    auto body = [&](std::size_t i) { return scene.bodies[i].name; };
    const SceneJoint& chain1 = scene.joints[1];
    CHECK(chain1.def.type == JointType::Ball);
    CHECK(body(chain1.body_a) == "link0");
    CHECK(body(chain1.body_b) == "link1");
    // anchor_b left out: the world point of anchor_a in B's frame (link1's left end).
    CHECK((chain1.def.local_anchor_b - Vec3(Real(-0.15), 0, 0)).norm() < Real(1e-5));
    const JointDef& door = scene.joints[3].def;
    CHECK(door.type == JointType::Hinge);
    CHECK(door.local_axis_a == Vec3(0, 1, 0));
    CHECK(door.enable_limit);
    CHECK(door.lower == Approx(-1.5));
    CHECK(door.upper == Approx(1.5));
    CHECK(door.enable_motor);
    CHECK(door.motor_speed == Approx(0.5));
    CHECK(door.max_motor_force == Approx(20));
    CHECK_FALSE(door.collide_connected);
    const JointDef& slider = scene.joints[4].def;
    CHECK(slider.type == JointType::Slider);
    CHECK(slider.collide_connected);
    const JointDef& spring = scene.joints[5].def;
    CHECK(spring.type == JointType::Distance);
    CHECK(spring.length == Approx(1));
    CHECK(spring.frequency == Approx(2));
    CHECK(spring.damping_ratio == Approx(0.3));
    CHECK(scene.joints[7].def.type == JointType::Fixed);
    const JointDef& hook = scene.joints[8].def;
    CHECK(hook.break_force == Approx(20));
    CHECK(hook.length < 0);  // resolved at creation

    std::vector<BodyId> ids;
    std::unique_ptr<World> world = build_world(scene, &ids);
    RigidSystem& rs = world->rigid();
    CHECK(rs.joints().count() == 9);
    // The hook (3 kg, 29.4 N) hangs on a joint that breaks above 20 N: it goes in the first step.
    world->step();
    CHECK(rs.broken_joints().size() == 1);
    CHECK(rs.joints().count() == 8);
    for (int s = 0; s < 299; ++s) world->step();
    CHECK(rs.all_finite());
    // The chain hangs from the beam: link0's anchor is still at the beam's.
    const Vec3 pin = rs.transform(ids[2]).apply(Vec3(Real(-0.15), 0, 0));
    CHECK((pin - Vec3(-5, Real(3.8), 0)).norm() < Real(0.01));
    // The door's motor (0.5 rad/s, 20 N m) has turned it about y against its upper limit, 1.5 rad, by
    // now (5 s): the frame is static and unrotated, so the door's rotation is the hinge angle.
    const Quat door_q = rs.transform(ids[6]).q;
    CHECK(2 * std::atan2(door_q.y(), door_q.w()) == Approx(1.5).margin(0.01));
    // The carriage stays on its rail within the slider limits; the weight stays welded to the arm.
    const Real x = rs.transform(ids[7]).p.x() - 1;
    CHECK(x >= Real(-0.5 - 1e-3));
    CHECK(x <= Real(0.5 + 1e-3));
    const Vec3 weld = rs.transform(ids[9]).apply(Vec3(Real(0.4), 0, 0)) - rs.transform(ids[10]).apply(Vec3(Real(-0.1), 0, 0));
    CHECK(weld.norm() < Real(1e-3));
}

TEST_CASE("bad joints in a scene file are reported at their JSON path", "[joints][scene]") {
    const std::string head = R"({"format": "sinew-scene", "version": 1, "bodies": [
        {"name": "wall", "type": "static", "shape": {"type": "box", "half_extents": [1, 1, 1]}},
        {"name": "floor", "type": "static", "shape": {"type": "box", "half_extents": [1, 1, 1]}, "position": [0, -3, 0]},
        {"name": "a", "shape": {"type": "sphere", "radius": 0.5}, "position": [3, 0, 0]},
        {"name": "b", "shape": {"type": "sphere", "radius": 0.5}, "position": [5, 0, 0]}], "joints": [)";
    struct Case {
        const char* joint;
        const char* path;
        const char* fragment;
    };
    const Case cases[] = {
        {R"({"type": "ball", "body_a": "a", "body_b": "c"})", "/joints/0/body_b", "unknown body \"c\""},
        {R"({"type": "ball", "body_a": "a"})", "/joints/0/body_b", "missing required key"},
        {R"({"type": "ball", "body_a": "a", "body_b": "a"})", "/joints/0/body_b", "must differ"},
        {R"({"type": "ball", "body_a": "wall", "body_b": "floor"})", "/joints/0", "at least one dynamic"},
        {R"({"type": "weld", "body_a": "a", "body_b": "b"})", "/joints/0/type", "unknown type \"weld\""},
        {R"({"type": "ball", "body_a": "a", "body_b": "b", "axis": [0, 0, 1]})", "/joints/0/axis", "unknown key"},
        {R"({"type": "hinge", "body_a": "a", "body_b": "b"})", "/joints/0/axis", "missing required key"},
        {R"({"type": "hinge", "body_a": "a", "body_b": "b", "axis": [0, 0, 0]})", "/joints/0/axis", "non-zero"},
        {R"({"type": "hinge", "body_a": "a", "body_b": "b", "axis": [0, 0, 1], "limit": {"lower": 1, "upper": -1}})",
         "/joints/0/limit", "must be <= upper"},
        {R"({"type": "hinge", "body_a": "a", "body_b": "b", "axis": [0, 0, 1], "limit": {"lower": -4, "upper": 1}})",
         "/joints/0/limit/lower", ">= -pi"},
        {R"({"type": "slider", "body_a": "a", "body_b": "b", "axis": [1, 0, 0], "motor": {"speed": 1}})",
         "/joints/0/motor/max_force", "missing required key"},
        {R"({"type": "slider", "body_a": "a", "body_b": "b", "axis": [1, 0, 0], "motor": {"speed": 1, "max_force": -2}})",
         "/joints/0/motor/max_force", "max_force must be >= 0"},
        {R"({"type": "distance", "body_a": "a", "body_b": "b", "frequency": -1})", "/joints/0/frequency",
         "frequency must be >= 0"},
        {R"({"type": "distance", "body_a": "a", "body_b": "b", "length": 0})", "/joints/0/length", "length must be > 0"},
        {R"({"type": "distance", "body_a": "a", "body_b": "b", "anchor_b": [-2, 0, 0]})", "/joints/0", "anchors coincide"},
        {R"({"type": "ball", "body_a": "a", "body_b": "b", "anchor_a": [0, "nan", 0]})", "/joints/0/anchor_a/1", "NaN"},
        {R"({"type": "ball", "body_a": "a", "body_b": "b", "break_force": -1})", "/joints/0/break_force", ">= 0"},
    };
    for (const Case& c : cases) {
        INFO(c.joint);
        try {
            parse_scene_string(head + c.joint + "]}", "joints-test.json");
            FAIL("no error");
        } catch (const SceneError& e) {
            INFO(e.what());
            CHECK(e.json_path == c.path);
            CHECK_THAT(e.problem, Catch::Contains(c.fragment));
        }
    }
    // And a good one between a static and a dynamic body builds.
    const SceneDesc ok = parse_scene_string(head + R"({"type": "ball", "body_a": "wall", "body_b": "a"}]})", "ok.json");
    CHECK(build_world(ok)->rigid().joints().count() == 1);
}

// Issue 18: a hinge motor of 1e5 N m spinning a 1 kg arm at 50 rad/s into the ground and its own post drove
// the default solver to NaN within 20 steps while every step went on as if nothing had happened (and
// `sinew run` then printed finite: true with a zero quaternion). The blow-up itself is a documented limit
// of the soft step (docs/rigid-solvers.md, "a motor far beyond its body's inertia"); what is asserted is
// that the step names the arm and puts it back, and that the world stays finite and steps on.
TEST_CASE("a hinge motor far beyond its arm's inertia blows up, the step names the arm and contains it",
          "[joints][errors]") {
    const std::string scene = R"({"format": "sinew-scene", "version": 1, "name": "motor-arm",
      "bodies": [
        {"name": "ground", "type": "static", "shape": {"type": "box", "half_extents": [10, 0.5, 10]}, "position": [0, -0.5, 0]},
        {"name": "post", "type": "static", "shape": {"type": "box", "half_extents": [0.1, 0.5, 0.1]}, "position": [0, 0.5, 0]},
        {"name": "arm", "shape": {"type": "box", "half_extents": [0.5, 0.05, 0.05]}, "position": [0.5, 1.0, 0], "mass": 1}],
      "joints": [{"type": "hinge", "body_a": "post", "body_b": "arm", "anchor_a": [0, 0.5, 0], "axis": [0, 0, 1],
                  "motor": {"speed": -50, "max_force": 1e5}}]})";
    std::vector<BodyId> ids;
    const std::unique_ptr<World> world = build_world(parse_scene_string(scene, "motor-arm.json"), &ids);
    const BodyId arm = ids[2];
    int faults = 0;
    for (int k = 0; k < 120; ++k) {
        const Transform before = world->rigid().transform(arm);
        world->step();
        REQUIRE(world->rigid().all_finite());
        if (world->faults().empty()) continue;
        ++faults;
        REQUIRE(world->faults().size() == 1);
        const StepFault& f = world->faults()[0];
        INFO(f.what);
        CHECK(f.system == StepFault::System::Rigid);
        CHECK(f.index == arm.index);
        CHECK(f.generation == arm.generation);
        CHECK(f.step == std::uint64_t(k));
        CHECK_THAT(f.hint, Catch::Contains("motor"));
        // Back where the step found it, at rest.
        CHECK(world->rigid().transform(arm).p == before.p);
        CHECK(world->rigid().linear_velocity(arm) == Vec3::Zero());
        CHECK(world->rigid().angular_velocity(arm) == Vec3::Zero());
    }
    CHECK(faults >= 1);
}

TEST_CASE("soft step: a pendulum held by two ball joints at one pivot swings as with one, and a closed loop of links holds", "[joints][chain]") {
    // The soft step solves its joints' point blocks together (rigid/joint_point_solve.hpp). Two joints
    // at one point make that system singular (a ridge of 1e-9 keeps it factorable): the doubled pendulum
    // must swing as the single one does, within 1 mm after 2 s (measured 5e-6 m). A square loop of four
    // 1 kg bars hanging by one corner, released from rest, swings closed: measured 2.7 mm at most over 3 s
    // (3.5 mm with the sweeps alone); 5 mm. Kicked out of its plane at 2 m/s the thin bars spin up about
    // their long axes (to 3,700 rad/s) and the loop opens by 0.4 m, with or without the exact solve, under
    // split impulses too, though a free bar tumbling no longer does (docs/rigid-solvers.md, known limits).
    const Real h = Real(1) / 60;
    Vec3 ends[2];
    for (int doubled = 0; doubled < 2; ++doubled) {
        World world(settings_for(kSoftStep, h, kGravity));
        RigidSystem& rs = world.rigid();
        const BodyId pivot = add_body(rs, BodyType::Static, make_sphere(Real(0.02)), Vec3::Zero());
        const BodyId bob = add_body(rs, BodyType::Dynamic, make_box(Vec3(Real(0.5), Real(0.05), Real(0.05))),
                                    Vec3(Real(0.5), 0, 0), 1);
        // A second pendulum on its own pivot beside it, in the same solve.
        const BodyId other = add_body(rs, BodyType::Dynamic, make_sphere(Real(0.05)), Vec3(0, 0, 3), 1);
        for (int k = 0; k <= doubled; ++k) {
            JointDef jd;
            jd.type = JointType::Ball;
            jd.body_a = pivot;
            jd.body_b = bob;
            jd.local_anchor_b = Vec3(Real(-0.5), 0, 0);
            rs.create_joint(jd);
        }
        JointDef jd;
        jd.type = JointType::Ball;
        jd.body_a = pivot;
        jd.body_b = other;
        jd.local_anchor_a = Vec3(0, 0, 2);
        jd.local_anchor_b = Vec3(0, 0, -1);
        rs.create_joint(jd);
        for (int i = 0; i < 120; ++i) world.step();
        REQUIRE(world.faults().empty());
        ends[doubled] = rs.transform(bob).apply(Vec3(Real(0.5), 0, 0));
    }
    INFO("single " << ends[0].transpose() << ", doubled " << ends[1].transpose());
    CHECK((ends[0] - ends[1]).norm() < Real(1e-3));

    World world(settings_for(kSoftStep, h, kGravity));
    RigidSystem& rs = world.rigid();
    // Hung by corner (0,0), the loop swings down in its plane.
    const BarLoop loop = make_bar_loop(rs, true);
    Real worst = 0;
    for (int i = 0; i < 180; ++i) {
        world.step();
        for (JointId j : loop.joints) worst = std::max(worst, rs.joints().position_error(j, rs));
    }
    REQUIRE(world.faults().empty());
    CHECK(worst < Real(5e-3));
}

TEST_CASE("a kicked loop of ball-jointed thin bars takes no spin about the bars' long axes under every solver",
          "[joints][rotation]") {
    // make_bar_loop's loop, collisions off, the bottom bar kicked sideways at 2 m/s. Every joint force acts
    // at a bar's end, on its long axis, and gravity at its centre, so nothing turns a bar about its long
    // axis: that spin stays 0 and the energy never rises above the start. Impulses computed at one
    // orientation and read in the frame of another gained a long-axis part the small inertia amplified:
    // the soft step spun the bars up to 3,700 rad/s within 3 s (the joints opening by 0.42 m), split
    // impulses to 830 rad/s within 10 s (energy from -18 J to +327 J). Measured over 10 s (float): at most
    // 0.023 rad/s (soft step), 0.002 (the others), and the energy never above its start. Bounds: 0.1 rad/s,
    // 0.1 J (5% of the kick's 2 J); the joints within 5 mm under the soft step (measured 1.0 mm), within
    // 5 cm under the others (split impulses 8.9 mm, Baumgarte 29 mm, Newton 32 mm: their joints are looser,
    // the known limit hard-chain shows, docs/rigid-solvers.md).
    for (RigidSolverKind kind : {RigidSolverKind::SoftStep, RigidSolverKind::SplitImpulse, RigidSolverKind::Baumgarte,
                                 RigidSolverKind::Newton}) {
        CAPTURE(rigid_solver_name(kind));
        World world(settings_for(SolverCase{rigid_solver_name(kind), kind}, Real(1) / 60, kGravity));
        RigidSystem& rs = world.rigid();
        const BarLoop loop = make_bar_loop(rs, false);
        rs.set_velocity(loop.bar[2], Vec3(0, 0, 2), Vec3::Zero());
        const auto energy = [&] {
            Real e = 0;
            for (BodyId bar : loop.bar) {
                const Quat q = rs.transform(bar).q;
                const Vec3 w = q.conjugate() * rs.angular_velocity(bar);
                const Vec3 he = rs.shape(bar).half_extents;
                const Vec3 i(he.y() * he.y() + he.z() * he.z(), he.x() * he.x() + he.z() * he.z(), he.x() * he.x() + he.y() * he.y());
                e += Real(0.5) * rs.linear_velocity(bar).squaredNorm() + Real(0.5) / 3 * (i.array() * w.array() * w.array()).sum() -
                     kGravity.y() * rs.transform(bar).p.y();
            }
            return e;
        };
        const Real e0 = energy();
        Real spin = 0, highest = e0, opened = 0;
        for (int step = 0; step < 600; ++step) {
            world.step();
            for (int k = 0; k < 4; ++k)
                spin = std::max(spin, std::abs(rs.angular_velocity(loop.bar[k]).dot(rs.transform(loop.bar[k]).q * loop.long_axis[k])));
            highest = std::max(highest, energy());
            for (JointId j : loop.joints) opened = std::max(opened, rs.joints().position_error(j, rs));
        }
        REQUIRE(world.faults().empty());
        CHECK(spin < Real(0.1));
        CHECK(highest - e0 < Real(0.1));
        CHECK(opened < (kind == RigidSolverKind::SoftStep ? Real(0.005) : Real(0.05)));
    }
}

TEST_CASE("soft step: a door on two hinges reports reactions that carry its weight, with no spurious force along the hinge line", "[joints]") {
    // Two hinges on one axis are redundant: the exact point solve has no stiffness along the line through
    // both anchors, where the relative velocity is rounding noise; its ridge is at Real's resolution so
    // that noise cannot become a large impulse that the reaction forces (and a breakable joint) would
    // see. A 20 kg door (1 m x 2 m) hung on hinges at y = +-0.8 m of its edge, turning at 1 rad/s about
    // them: the hinges' vertical reactions sum to its weight (196 N) within 2% (statics: the vertical
    // split between them is indeterminate, their sum is not; measured 196.2 N), neither exceeds 2
    // weights (measured 115 N: the weight's half and the couple that holds the door's overhang, 61 N),
    // and the door's centre stays 0.5 m from the axis within 1 mm (measured 7e-6 m).
    World world(settings_for(kSoftStep, Real(1) / 60, kGravity));
    RigidSystem& rs = world.rigid();
    const BodyId frame = add_body(rs, BodyType::Static, make_box(Vec3::Constant(Real(0.05))), Vec3(0, 0, 0));
    const BodyId door = add_body(rs, BodyType::Dynamic, make_box(Vec3(Real(0.5), 1, Real(0.025))), Vec3(Real(0.5), 0, 0), 20);
    JointId hinge[2];
    for (int k = 0; k < 2; ++k) {
        JointDef jd;
        jd.type = JointType::Hinge;
        jd.body_a = frame;
        jd.body_b = door;
        const Vec3 at(0, k ? Real(0.8) : Real(-0.8), 0);
        jd.local_anchor_a = at;
        jd.local_anchor_b = at - Vec3(Real(0.5), 0, 0);
        jd.local_axis_a = Vec3::UnitY();
        hinge[k] = rs.create_joint(jd);
    }
    rs.set_velocity(door, Vec3(0, 0, Real(-0.5)), Vec3(0, 1, 0));  // turning about the hinge line
    Real worst_force = 0, worst_offset = 0;
    double lift = 0;
    const int steps = 120;
    for (int i = 0; i < steps; ++i) {
        world.step();
        const Vec3 f0 = rs.joints().reaction_force(hinge[0]), f1 = rs.joints().reaction_force(hinge[1]);
        worst_force = std::max({worst_force, f0.norm(), f1.norm()});
        lift += double(f0.y() + f1.y());
        const Vec3 c = rs.transform(door).p;
        worst_offset = std::max(worst_offset, std::abs(std::hypot(c.x(), c.z()) - Real(0.5)));
    }
    REQUIRE(world.faults().empty());
    CHECK(lift / steps == Approx(20 * 9.81).epsilon(0.02));
    CHECK(worst_force < 2 * 20 * Real(9.81));
    CHECK(worst_offset < Real(1e-3));
}

TEST_CASE("a 20-link chain with a 100:1 end mass stays together under the soft step (within 1 cm), split impulses and Newton", "[joints][chain]") {
    // demos/scenes/hard-chain.json: 1 kg links (0.5 m), a 100 kg end cube, one chain hanging at rest and
    // one released from horizontal, 5 s. Largest distance between a joint's two anchor points over the
    // run. Soft step: 3.4 mm since its joints' point blocks are solved together and exactly after the
    // sweeps, at 150 Hz (rigid/joint_point_solve.hpp; swept alone at 120 Hz they stretched 14.5 mm under
    // the swing's 3,000 N); the issue asks for 1 cm. Split impulses and Newton bound the joint's mass ratio to stay
    // together (before: metres, coming apart): 43 and 158 mm in float and double; 0.25 m. Baumgarte is
    // not asserted: with the same bound it holds in float (134 mm) and comes apart in double (7 m), at
    // the edge of its stability (docs/rigid-solvers.md, known limits).
    const SceneDesc scene = parse_scene_file(std::string(SINEW_SOURCE_DIR) + "/demos/scenes/hard-chain.json");
    for (RigidSolverKind kind : {RigidSolverKind::SoftStep, RigidSolverKind::SplitImpulse, RigidSolverKind::Newton}) {
        SceneDesc s = scene;
        s.settings.rigid.solver = kind;
        std::vector<BodyId> ids;
        auto world = build_world(s, &ids);
        double worst = 0;
        for (int i = 0; i < s.steps; ++i) {
            world->step();
            for (const SceneJoint& j : s.joints) {
                const Vec3 a = world->rigid().transform(ids[j.body_a]).apply(j.def.local_anchor_a);
                const Vec3 b = world->rigid().transform(ids[j.body_b]).apply(j.def.local_anchor_b);
                worst = std::max(worst, double((a - b).norm()));
            }
        }
        INFO(rigid_solver_name(kind));
        CHECK(world->faults().empty());
        CHECK(worst < (kind == RigidSolverKind::SoftStep ? 0.01 : 0.25));
    }
}
