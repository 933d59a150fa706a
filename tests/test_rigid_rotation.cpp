// Free rotation against closed forms, under every rigid solver: the exact orientation update (a body
// spinning at 50 rad/s turns by 50 rad in a second, where the first-order update falls 5% short) and the
// gyroscopic effect (a box spun about its intermediate axis flips over, the Dzhanibekov effect, while its
// angular momentum in the world stays put; without the term it never flips).
#include <catch2/catch.hpp>

#include <cmath>

#include "engine/core/pipeline.hpp"
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
