// Free rotation against closed forms, under every rigid solver: the exact orientation update (a body
// spinning at 50 rad/s turns by 50 rad in a second, where the first-order update falls 5% short) and the
// gyroscopic effect (a box spun about its intermediate axis flips over, the Dzhanibekov effect, while its
// angular momentum in the world stays put; without the term it never flips).
#include <catch2/catch.hpp>

#include <cmath>

#include "engine/core/pipeline.hpp"
#include "rigid/joint_set.hpp"
#include "rigid/rigid_system.hpp"

using namespace sinew;

namespace {

struct FreeBody {
    RigidSystem rigid;
    Pipeline pipeline;
    BodyId id;
    FreeBody(RigidSolverKind kind, bool gyroscopic, const Vec3& half_extents, const Vec3& w) : rigid(settings(kind, gyroscopic)) {
        pipeline.add_system(&rigid);
        BodyDef d;
        d.shape = make_box(half_extents);
        d.mass = 2;
        d.angular_velocity = w;
        id = rigid.create_body(d);
    }
    static RigidSettings settings(RigidSolverKind kind, bool gyroscopic) {
        RigidSettings s;
        s.solver = kind;
        s.gravity = Vec3::Zero();
        s.sleeping = false;
        s.gyroscopic = gyroscopic;
        return s;
    }
    /// Angular momentum in the world, I_world w (the centre of mass does not move).
    Vec3 angular_momentum() const {
        const Quat q = rigid.transform(id).q;
        const Mat3 r = q.toRotationMatrix();
        const Vec3 he = rigid.shape(id).half_extents;
        const Real m = rigid.mass(id);
        // Box inertia about its centre, body axes: m/3 (b^2 + c^2), ...
        const Vec3 i_body(m / 3 * (he.y() * he.y() + he.z() * he.z()), m / 3 * (he.x() * he.x() + he.z() * he.z()),
                          m / 3 * (he.x() * he.x() + he.y() * he.y()));
        return r * i_body.asDiagonal() * r.transpose() * rigid.angular_velocity(id);
    }
};

const RigidSolverKind kAllSolvers[] = {RigidSolverKind::SoftStep, RigidSolverKind::SplitImpulse,
                                       RigidSolverKind::Baumgarte, RigidSolverKind::Newton};

}  // namespace

TEST_CASE("a body spinning at 50 rad/s turns by exactly 50 rad in a second under every solver", "[rigid][rotation]") {
    for (RigidSolverKind kind : kAllSolvers) {
        CAPTURE(rigid_solver_name(kind));
        // A cube: isotropic inertia, so the gyroscopic term is zero and the spin stays about z.
        FreeBody b(kind, true, Vec3(Real(0.5), Real(0.5), Real(0.5)), Vec3(0, 0, 50));
        for (int i = 0; i < 60; ++i) b.pipeline.step(Real(1) / 60);
        const Quat expected(Eigen::AngleAxis<Real>(50, Vec3::UnitZ()));
        const Quat q = b.rigid.transform(b.id).q;
        // Angle between the two orientations: 2 acos |q . expected|. The first-order update would be
        // 2.3 rad off (50 (1 - atan(a)/a), a = 50/120); what is left is float rounding over 60 updates
        // of 0.83 rad each (~1e-5 rad), so 1e-3 rad is a wide margin that still tells the two apart.
        const Real error = 2 * std::acos(std::min(Real(1), std::abs(q.dot(expected))));
        CHECK(error < Real(1e-3));
        CHECK(b.rigid.angular_velocity(b.id).z() == Approx(50).epsilon(1e-5));
    }
}

TEST_CASE("a box spun about its intermediate axis flips over and keeps its angular momentum (Dzhanibekov)",
          "[rigid][rotation]") {
    // Half extents 0.6 x 0.3 x 0.1 m: principal moments ∝ 0.10, 0.37, 0.45, so y is the intermediate
    // axis. Spun at 10 rad/s about y with a 1% disturbance, the disturbance grows at
    // Ω sqrt((I_y - I_x)(I_z - I_y) / (I_x I_z)) = 6.9 /s: the body turns over within about a second and a
    // half, and keeps tumbling.
    const Vec3 he(Real(0.6), Real(0.3), Real(0.1));
    const Vec3 w0(Real(0.1), 10, Real(0.1));
    for (RigidSolverKind kind : kAllSolvers) {
        CAPTURE(rigid_solver_name(kind));
        FreeBody b(kind, true, he, w0);
        const Vec3 l0 = b.angular_momentum();
        Real lowest = 1, worst_l = 0;
        for (int i = 0; i < 180; ++i) {  // 3 s
            b.pipeline.step(Real(1) / 60);
            // The body's y axis against the angular momentum's direction: +1 at the start, -1 flipped.
            const Vec3 y_axis = b.rigid.transform(b.id).q * Vec3::UnitY();
            lowest = std::min(lowest, y_axis.dot(l0.normalized()));
            worst_l = std::max(worst_l, (b.angular_momentum() - l0).norm() / l0.norm());
        }
        CHECK(lowest < Real(-0.9));  // turned over
        // The free motion keeps L by construction (rigid/rigid_integration.cpp), so only float rounding
        // moves it: measured 2e-4 under the soft step (5 sub-steps), 3e-5 under the others. 1% is the
        // bound issue 14 sets; Catto's implicit step drifts 4-20% here.
        CHECK(worst_l < Real(0.01));
    }
}

TEST_CASE("a thin bar tumbling keeps its small spin about its long axis and its kinetic energy under every solver",
          "[rigid][rotation]") {
    // A 2 kg bar of 1 m x 6 cm x 6 cm (inertias 140:1, symmetric about x) tumbling at 3 rad/s with
    // 0.01 rad/s about its long axis: a symmetric top, I_x dw_x/dt = (I_y - I_z) w_y w_z = 0, so w_x stays
    // 0.01 rad/s and the kinetic energy stays. Turned about w held fixed over each step, the bar's axis
    // drifted off its precession and the kept momentum spun it up about x exponentially (96 rad/s after
    // 4 s under the soft step, 356 rad/s under the others; energy x7 and x90). Measured with the mid-step
    // turn (rigid/rigid_integration.cpp): w_x 0.0100 rad/s, energy within 2e-5. Bounds: w_x within 10%
    // and the energy within 0.1%.
    const Vec3 he(Real(0.5), Real(0.03), Real(0.03));
    const Vec3 w0(Real(0.01), 3, 1);
    for (RigidSolverKind kind : kAllSolvers) {
        CAPTURE(rigid_solver_name(kind));
        FreeBody b(kind, true, he, w0);
        const auto energy = [&] {
            const Vec3 l = b.angular_momentum();
            return Real(0.5) * l.dot(b.rigid.angular_velocity(b.id));
        };
        const Real e0 = energy();
        for (int i = 0; i < 240; ++i) b.pipeline.step(Real(1) / 60);  // 4 s
        const Vec3 w_body = b.rigid.transform(b.id).q.conjugate() * b.rigid.angular_velocity(b.id);
        CHECK(w_body.x() == Approx(0.01).epsilon(0.1));
        CHECK(energy() == Approx(e0).epsilon(1e-3));
    }
}

TEST_CASE("a kicked loop of ball-jointed thin bars takes no spin about the bars' long axes under every solver",
          "[rigid][rotation][joints]") {
    // Four 1 kg bars of 1 m x 6 cm x 6 cm (inertias 140:1, symmetric about their long axes) joined end to
    // end by ball joints into a square hanging from a post, the bottom bar kicked sideways at 2 m/s,
    // collisions off. Every joint force acts at a bar's end, on its long axis, and gravity at its centre,
    // so nothing turns a bar about its long axis: that spin stays 0 and the energy never rises above the
    // start. Impulses computed at one orientation and read in the frame of another gained a long-axis
    // part the small inertia amplified: the soft step spun the bars up to 3,700 rad/s within 3 s (the
    // joints opening by 0.42 m), split impulses to 830 rad/s within 10 s (energy from -18 J to +327 J).
    // Measured over 10 s (float): at most 0.023 rad/s (soft step), 0.002 (the others), and the energy never
    // above its start. Bounds: 0.1 rad/s, 0.1 J (5% of the kick's 2 J); the joints within 5 mm under the
    // soft step (measured 1.0 mm), within 5 cm under the others (split impulses 8.9 mm, Baumgarte 29 mm,
    // Newton 32 mm: their joints are looser, the known limit hard-chain shows, docs/rigid-solvers.md).
    for (RigidSolverKind kind : kAllSolvers) {
        CAPTURE(rigid_solver_name(kind));
        RigidSettings set;
        set.solver = kind;
        set.sleeping = false;
        RigidSystem rigid(set);
        Pipeline pipeline;
        pipeline.add_system(&rigid);
        const auto add = [&](BodyType type, const Shape& shape, const Vec3& at) {
            BodyDef d;
            d.type = type;
            d.shape = shape;
            d.pose.p = at;
            if (type == BodyType::Dynamic) d.mass = 1;
            d.filter.group = -1;  // collisions off: only the joints act
            return rigid.create_body(d);
        };
        const BodyId post = add(BodyType::Static, make_sphere(Real(0.02)), Vec3(0, Real(0.3), 0));
        const Vec3 corner[4] = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, -1, 0), Vec3(0, -1, 0)};
        BodyId bar[4];
        Vec3 long_axis[4];
        for (int k = 0; k < 4; ++k) {
            const Vec3 a = corner[k], b = corner[(k + 1) % 4];
            const bool along_x = std::abs(b.x() - a.x()) > Real(0.5);
            long_axis[k] = along_x ? Vec3::UnitX() : Vec3::UnitY();
            bar[k] = add(BodyType::Dynamic, make_box(along_x ? Vec3(Real(0.5), Real(0.03), Real(0.03)) : Vec3(Real(0.03), Real(0.5), Real(0.03))),
                         (a + b) / 2);
        }
        std::vector<JointId> joints;
        const auto join = [&](BodyId x, BodyId y, const Vec3& at) {
            JointDef jd;
            jd.type = JointType::Ball;
            jd.body_a = x;
            jd.body_b = y;
            jd.local_anchor_a = at - rigid.transform(x).p;
            jd.local_anchor_b = at - rigid.transform(y).p;
            joints.push_back(rigid.create_joint(jd));
        };
        join(post, bar[0], corner[0]);
        for (int k = 0; k < 4; ++k) join(bar[k], bar[(k + 1) % 4], corner[(k + 1) % 4]);
        rigid.set_velocity(bar[2], Vec3(0, 0, 2), Vec3::Zero());
        const auto energy = [&] {
            Real e = 0;
            for (int k = 0; k < 4; ++k) {
                const Quat q = rigid.transform(bar[k]).q;
                const Vec3 w = q.conjugate() * rigid.angular_velocity(bar[k]);
                const Vec3 he = rigid.shape(bar[k]).half_extents;
                const Vec3 i(he.y() * he.y() + he.z() * he.z(), he.x() * he.x() + he.z() * he.z(), he.x() * he.x() + he.y() * he.y());
                e += Real(0.5) * rigid.linear_velocity(bar[k]).squaredNorm() + Real(0.5) / 3 * (i.array() * w.array() * w.array()).sum() +
                     Real(9.81) * rigid.transform(bar[k]).p.y();
            }
            return e;
        };
        const Real e0 = energy();
        Real spin = 0, highest = e0, opened = 0;
        for (int step = 0; step < 600; ++step) {
            pipeline.step(Real(1) / 60);
            for (int k = 0; k < 4; ++k)
                spin = std::max(spin, std::abs(rigid.angular_velocity(bar[k]).dot(rigid.transform(bar[k]).q * long_axis[k])));
            highest = std::max(highest, energy());
            for (JointId j : joints) opened = std::max(opened, rigid.joints().position_error(j, rigid));
        }
        CHECK(spin < Real(0.1));
        CHECK(highest - e0 < Real(0.1));
        CHECK(opened < (kind == RigidSolverKind::SoftStep ? Real(0.005) : Real(0.05)));
    }
}

TEST_CASE("without the gyroscopic term the same box never flips", "[rigid][rotation]") {
    // What the term is for: with w changed only by torques, the body turns steadily about w0 and its y
    // axis stays within a few degrees of the spin axis (w0 is 0.8 degrees off y).
    FreeBody b(RigidSolverKind::SoftStep, false, Vec3(Real(0.6), Real(0.3), Real(0.1)), Vec3(Real(0.1), 10, Real(0.1)));
    Real lowest = 1;
    for (int i = 0; i < 180; ++i) {
        b.pipeline.step(Real(1) / 60);
        lowest = std::min(lowest, Real((b.rigid.transform(b.id).q * Vec3::UnitY()).y()));
    }
    CHECK(lowest > Real(0.99));
}
