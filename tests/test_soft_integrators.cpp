// Mass-spring integrators (soft/soft_integrators.hpp) where theory says exactly what happens: one undamped
// spring of stiffness k holding a particle of mass m to a pinned particle (ω = sqrt(k/m)), moving along the
// spring so the force is linear, -k u with u the stretch. With the energy norm A = sqrt(v² + ω² u²):
//  - explicit Euler multiplies A by sqrt(1 + ω²h²) every step, at any h;
//  - semi-implicit Euler is stable iff ω h < 2: it conserves Q = v² + ω²u² - h ω² u v, so below the limit
//    A stays within 1/sqrt(1 - ωh/2) of its start, above it A grows by the larger root of
//    z² - (2 - ω²h²) z + 1 = 0 per step; its period is 2π/θ with cos θ = 1 - ω²h²/2;
//  - backward (implicit) Euler multiplies the energy by 1/(1 + ω²h²) every step; the λ = ½ blend (the
//    trapezoidal / implicit midpoint rule) keeps it;
// plus momentum conservation of a free spring, fast mass-spring converging to the implicit Euler step (and
// factoring its matrix only when it must), the drag shared by all four integrators, Volino's isotropic
// blend damping a whirling spring, and implicit Euler on a crumpled cloth whose exact Jacobian is
// indefinite. Equations: Baraff & Witkin 1998, Volino & Magnenat-Thalmann 2000, Liu et al. 2013;
// docs/theory.md#euler, #mass-spring-forces, #fast-mass-spring. Bodies are built by hand (no builder), no
// gravity unless stated.
#include <catch2/catch.hpp>

#include <Eigen/Dense>
#include <Eigen/OrderingMethods>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include "engine/core/thread_pool.hpp"

#include "soft/soft_body.hpp"
#include "soft/ldlt_schedule.hpp"
#include "soft/soft_integrators.hpp"
#include "soft/solver_caches.hpp"

using namespace sinew;

namespace {

void step(SoftBody& b, Real h) {
    switch (b.def.method) {
        case SoftMethod::ExplicitEuler: step_explicit_euler(b, h); break;
        case SoftMethod::SemiImplicitEuler: step_semi_implicit_euler(b, h); break;
        case SoftMethod::ImplicitEuler: step_implicit_euler(b, h); break;
        case SoftMethod::FastMassSpring: step_fast_mass_spring(b, h); break;
        default: FAIL("not a spring method");
    }
}

// Particle 0 pinned at the origin; particle 1 (mass m) at rest + stretch on the x axis, velocity v0.
SoftBody single_spring(SoftMethod method, double k, double m, double rest, double stretch,
                       const Vec3& v0 = Vec3::Zero()) {
    SoftBody b;
    b.def.method = method;
    b.p.add(Vec3::Zero(), 1);
    b.p.inv_mass[0] = 0;
    b.p.add(Vec3(Real(rest + stretch), 0, 0), Real(m));
    b.p.v[1] = v0;
    Link l;
    l.a = 1;
    l.b = 0;
    l.rest = Real(rest);
    l.stiffness = Real(k);
    l.damping = 0;
    b.links.push_back(l);
    b.gravity = Vec3::Zero();
    return b;
}

// Energy norm sqrt(v² + ω² u²) of the single spring (in double from the Real state).
double amplitude(const SoftBody& b, double omega) {
    const double u = double((b.p.x[1] - b.p.x[0]).norm()) - double(b.links[0].rest);
    const double v = double(b.p.v[1].x());
    return std::sqrt(v * v + omega * omega * u * u);
}

}  // namespace

TEST_CASE("semi-implicit Euler on one spring diverges just above h = 2/omega and stays bounded just below",
          "[soft][integrators]") {
    const double k = 100, m = 1, omega = std::sqrt(k / m);  // ω = 10 rad/s, critical h = 0.2 s
    const double h_crit = 2 / omega;

    SECTION("h = 1.01 * 2/omega grows at the predicted rate") {
        const double h = 1.01 * h_crit;
        // Start small (1e-5 m) so that 30 steps of growth (~1.33^30 ≈ 5e3) stay far below the rest length and
        // the spring stays linear (u > -L).
        SoftBody b = single_spring(SoftMethod::SemiImplicitEuler, k, m, 1, 1e-5);
        const double a0 = amplitude(b, omega);
        std::vector<double> a;
        for (int n = 0; n < 30; ++n) {
            step(b, Real(h));
            a.push_back(amplitude(b, omega));
        }
        const double t = 2 - omega * omega * h * h;
        const double rate_theory = (std::abs(t) + std::sqrt(t * t - 4)) / 2;  // 1.3266
        // After 20 steps the decaying root's share is below 1/1.33^40 ≈ 1e-5, so steps 20..30 grow by the
        // dominant root alone; 1% covers float rounding (the state is ~1e-3 m there, 1e-4 relative).
        const double rate = std::pow(a[29] / a[19], 0.1);
        CHECK(rate == Approx(rate_theory).epsilon(0.01));
        CHECK(a[29] / a0 > 100);  // diverges (theory: ~1e3 within 30 steps)
    }

    SECTION("h = 0.99 * 2/omega stays within the bound of the conserved quadratic") {
        const double h = 0.99 * h_crit;
        SoftBody b = single_spring(SoftMethod::SemiImplicitEuler, k, m, 1, 1e-2);
        const double a0 = amplitude(b, omega);
        // Starting at rest, Q = A0², and Q >= (1 - ωh/2) A² bounds A by A0 / sqrt(1 - ωh/2) = 10 A0 at ωh = 1.98.
        const double bound = a0 / std::sqrt(1 - omega * h / 2);
        double a_max = 0;
        for (int n = 0; n < 20000; ++n) {
            step(b, Real(h));
            a_max = std::max(a_max, amplitude(b, omega));
        }
        // 1% over the bound: float rounding of a state of ~0.1 m over 2e4 steps (a random walk of 1e-7 steps)
        // and of u computed from positions near 1 m (1e-7 / 1e-2 of the amplitude).
        CHECK(a_max <= 1.01 * bound);
        CHECK(a_max > 0.5 * bound);  // and it does reach large excursions: bounded, not damped
    }
}

TEST_CASE("explicit Euler on one spring grows by sqrt(1 + omega^2 h^2) per step at any h", "[soft][integrators]") {
    const double k = 100, m = 1, omega = 10;
    struct Case {
        double omega_h;
        int steps;
    };
    for (const Case c : {Case{0.05, 400}, Case{0.5, 40}, Case{2.0, 10}}) {
        const double h = c.omega_h / omega;
        const double rate_theory = std::sqrt(1 + c.omega_h * c.omega_h);
        // Start so the final amplitude is ~0.1 m (linear spring, float resolution 1e-7/0.1 at the end).
        const double growth = std::pow(rate_theory, c.steps);
        SoftBody b = single_spring(SoftMethod::ExplicitEuler, k, m, 1, 0.1 / growth);
        const double a0 = amplitude(b, omega);
        for (int n = 0; n < c.steps; ++n) step(b, Real(h));
        const double rate = std::pow(amplitude(b, omega) / a0, 1.0 / c.steps);
        INFO("omega h = " << c.omega_h);
        // The growth is exact at every step (E' = (1 + ω²h²) E for the linear spring), so the only error is
        // float rounding: ~1e-5 relative in the amplitude ratio, spread over the steps; 1% of the excess
        // rate - 1 (1.25e-5 absolute at ωh = 0.05) is above it and far below the excess itself.
        CHECK(std::abs(rate - rate_theory) <= 0.01 * (rate_theory - 1));
    }
}

TEST_CASE("implicit Euler at h = 1/30 and k = 1e5 is stable and multiplies its energy by 1/(1 + omega^2 h^2) per step",
          "[soft][integrators]") {
    const double k = 1e5, m = 1, omega = std::sqrt(k / m), h = 1.0 / 30;  // ωh = 10.5: 1 + ω²h² = 112
    const double loss = 1 / (1 + omega * omega * h * h);
    // Rest length 0.1 m so float positions resolve the stretch finely (ulp 7.5e-9 m) as it decays.
    SoftBody b = single_spring(SoftMethod::ImplicitEuler, k, m, 0.1, 0.05);
    b.def.iterations = 50;
    const double a0 = amplitude(b, omega);
    double e_prev = a0 * a0;
    // The energy a position error of 4 ulps of the 0.1 m link carries: the level at which rounding, not the
    // integrator, sets the state once it has decayed.
    const double e_floor = std::pow(omega * 4 * 7.5e-9, 2);
    for (int n = 0; n < 300; ++n) {
        step(b, Real(h));
        REQUIRE(b.implicit_cache->cg_converged);
        const double a = amplitude(b, omega);
        const double e = a * a;
        if (n < 3) {
            // One free particle: the block-Jacobi preconditioner is the exact inverse and CG is exact, and the
            // force is linear, so one Newton step is backward Euler. 1%: float rounding of the stretch, which
            // falls from 0.05 to 4e-5 m in three steps (7.5e-9 m resolution: < 2e-4 relative, 4e-4 in E).
            INFO("step " << n);
            CHECK(e / e_prev == Approx(loss).epsilon(0.01));
        }
        CHECK(e <= e_prev + e_floor);  // never grows
        CHECK(a <= a0);                // bounded
        e_prev = e;
    }
    CHECK(b.p.x[0] == Vec3::Zero());  // the pin did not move
    CHECK(b.p.v[0] == Vec3::Zero());
}

TEST_CASE("implicit Euler with lambda = 1/2 (trapezoidal / implicit midpoint) conserves a linear spring's energy",
          "[soft][integrators]") {
    const double k = 1e5, m = 1, omega = std::sqrt(k / m), h = 1.0 / 30;
    SoftBody b = single_spring(SoftMethod::ImplicitEuler, k, m, 0.1, 0.05);
    b.def.implicit_lambda = Real(0.5);
    const double a0 = amplitude(b, omega);
    for (int n = 0; n < 300; ++n) {
        step(b, Real(h));
        // The trapezoidal rule's amplification on a linear oscillator is a rotation in the energy norm (the
        // Cayley transform of a skew matrix): A is exactly constant. 1e-3: float rounding over 300 steps
        // (positions near 0.1 m resolve the 0.05 m stretch to 1.5e-7).
        REQUIRE(amplitude(b, omega) == Approx(a0).epsilon(1e-3));
    }
}

TEST_CASE("semi-implicit Euler matches the spring's analytic period within 1% at small h", "[soft][integrators]") {
    const double k = 100, m = 1, omega = std::sqrt(k / m), h = 1e-3;  // ωh = 0.01
    const double period = 2 * 3.14159265358979323846 / omega;
    SoftBody b = single_spring(SoftMethod::SemiImplicitEuler, k, m, 1, 0.1);
    // Upward zero crossings of the stretch u, interpolated linearly within the step.
    std::vector<double> crossings;
    double u_prev = 0.1;
    for (int n = 1; n <= 7000 && crossings.size() < 11; ++n) {
        step(b, Real(h));
        const double u = double(b.p.x[1].x()) - 1;
        if (u_prev < 0 && u >= 0) crossings.push_back(h * (n - 1 + u_prev / (u_prev - u)));
        u_prev = u;
    }
    REQUIRE(crossings.size() == 11);
    const double measured = (crossings.back() - crossings.front()) / 10;
    // The 1%. Theory: the discrete period 2π h / acos(1 - ω²h²/2) is within (ωh)²/24 = 4e-6 of
    // 2π/ω, and linear interpolation of the crossings adds < h/10 periods' worth (1.6e-4); both well inside.
    CHECK(measured == Approx(period).epsilon(0.01));
}

TEST_CASE("explicit and semi-implicit Euler conserve the momentum of a free damped spring", "[soft][integrators]") {
    for (const SoftMethod method : {SoftMethod::ExplicitEuler, SoftMethod::SemiImplicitEuler}) {
        SoftBody b;
        b.def.method = method;
        b.p.add(Vec3(0, 0, 0), 1);
        b.p.add(Vec3(Real(1.2), Real(0.3), Real(-0.1)), 3);
        b.p.v[0] = Vec3(1, 2, 0);
        b.p.v[1] = Vec3(Real(-0.5), Real(0.1), Real(0.3));
        Link l;
        l.a = 0;
        l.b = 1;
        l.rest = 1;
        l.stiffness = 50;
        l.damping = Real(0.5);
        b.links.push_back(l);
        b.gravity = Vec3::Zero();
        const double h = 0.01;  // ω = sqrt(k / m_reduced) = 8.2 rad/s: ωh = 0.08
        auto momentum = [&] {
            return (b.p.mass[0] * b.p.v[0] + b.p.mass[1] * b.p.v[1]).cast<double>().eval();
        };
        auto centre = [&] { return ((b.p.mass[0] * b.p.x[0] + b.p.mass[1] * b.p.x[1]) / 4).cast<double>().eval(); };
        const Eigen::Vector3d p0 = momentum(), c0 = centre();
        const int steps = 200;
        for (int n = 0; n < steps; ++n) step(b, Real(h));
        INFO(soft_method_name(method));
        // The link forces are equal and opposite, so momentum is exact up to float rounding of the velocity
        // updates (~1e-7 relative per step, a random walk over 200 steps): 1e-5 of the momentum scale
        // Σ m |v| = 3.8 kg m/s.
        CHECK((momentum() - p0).norm() <= 1e-5 * 3.8);
        // Both methods move the centre of mass uniformly: x_cm(t) = x_cm(0) + t P/M. Tolerance: float
        // positions (1e-7 m) accumulated over the steps, 1e-5 m.
        CHECK((centre() - (c0 + steps * h * p0 / 4)).norm() <= 1e-5);
    }
}

namespace {

// Backward Euler converged by Newton's method (double): M (x - y)/h² = f_springs(x) over the free particles
// (pinned ones fixed), y = x_n + h v_n + h² g. The reference "implicit Euler step" for fast mass-spring.
std::vector<Eigen::Vector3d> backward_euler_newton(const SoftBody& b, double h) {
    const std::size_t n = b.p.size();
    std::vector<int> dof(n, -1);
    int nf = 0;
    for (std::size_t i = 0; i < n; ++i)
        if (b.p.inv_mass[i] != 0) dof[i] = 3 * nf++;
    std::vector<Eigen::Vector3d> x(n), y(n);
    for (std::size_t i = 0; i < n; ++i) {
        y[i] = b.p.x[i].cast<double>();
        if (dof[i] >= 0) y[i] += h * b.p.v[i].cast<double>() + h * h * b.gravity.cast<double>();
        x[i] = y[i];
    }
    for (int it = 0; it < 100; ++it) {
        Eigen::VectorXd g = Eigen::VectorXd::Zero(3 * nf);
        Eigen::MatrixXd jac = Eigen::MatrixXd::Zero(3 * nf, 3 * nf);
        for (std::size_t i = 0; i < n; ++i)
            if (dof[i] >= 0) {
                const double s = double(b.p.mass[i]) / (h * h);
                g.segment<3>(dof[i]) = s * (x[i] - y[i]);
                jac.block<3, 3>(dof[i], dof[i]) += s * Eigen::Matrix3d::Identity();
            }
        for (const Link& l : b.links) {
            const Eigen::Vector3d d = x[l.a] - x[l.b];
            const double len = d.norm(), k = l.stiffness, rest = l.rest;
            const Eigen::Vector3d e = d / len;
            const Eigen::Vector3d grad = k * (len - rest) * e;  // -f_a
            const Eigen::Matrix3d kb = k * ((1 - rest / len) * (Eigen::Matrix3d::Identity() - e * e.transpose()) +
                                            e * e.transpose());
            const int da = dof[l.a], db = dof[l.b];
            if (da >= 0) g.segment<3>(da) += grad, jac.block<3, 3>(da, da) += kb;
            if (db >= 0) g.segment<3>(db) -= grad, jac.block<3, 3>(db, db) += kb;
            if (da >= 0 && db >= 0) jac.block<3, 3>(da, db) -= kb, jac.block<3, 3>(db, da) -= kb;
        }
        const Eigen::VectorXd step = jac.lu().solve(g);
        for (std::size_t i = 0; i < n; ++i)
            if (dof[i] >= 0) x[i] -= step.segment<3>(dof[i]);
        if (step.norm() < 1e-14) break;
    }
    return x;
}

double max_distance(const SoftBody& b, const std::vector<Eigen::Vector3d>& x) {
    double worst = 0;
    for (std::size_t i = 0; i < b.p.size(); ++i) worst = std::max(worst, (b.p.x[i].cast<double>() - x[i]).norm());
    return worst;
}

}  // namespace

TEST_CASE("fast mass-spring: one iteration solves a single spring's implicit Euler step exactly",
          "[soft][integrators]") {
    // A swinging, stretched spring (velocity across it), so the step is nonlinear: k = 1000, m = 1
    // (ωh = 1.05 at h = 1/30), 10% stretch, 2 m/s sideways, no gravity. Backward Euler's solution
    // satisfies m (x - y)/h² ∥ x (the spring force is along x), so x lies on the ray through y: the first
    // local step from the initial guess x_n + h v_n (= y here) already finds the exact direction and the
    // first global step the exact solution. Later iterations must stay there.
    const double k = 1000, m = 1, rest = 1, h = 1.0 / 30;
    SoftBody b0 = single_spring(SoftMethod::FastMassSpring, k, m, rest, 0.1, Vec3(0, 2, 0));
    const std::vector<Eigen::Vector3d> x_ref = backward_euler_newton(b0, h);
    for (const int iterations : {1, 2, 10}) {
        SoftBody b = single_spring(SoftMethod::FastMassSpring, k, m, rest, 0.1, Vec3(0, 2, 0));
        b.def.iterations = iterations;
        step(b, Real(h));
        INFO("iterations = " << iterations);
        // Float resolution: the 1 m coordinates carry 1e-7 m; 1e-6 m is ten of those.
        CHECK(max_distance(b, x_ref) <= 1e-6);
        // Velocity is the position change over h (float: 1e-7 m / (1/30 s)).
        CHECK((b.p.v[1].cast<double>() - (b.p.x[1].cast<double>() - Eigen::Vector3d(1.1, 0, 0)) / h).norm() <= 1e-5);
    }

    // Baraff-Witkin's single Newton step lands near the same point. Linearised at x_n it misses the turn of
    // the spring's direction over the step, the chord-to-arc gap ½ (h|v|)²/|x_n| = 2e-3 m (measured 3.0e-3);
    // twice that bounds it (the step itself moves the particle 0.08 m).
    SoftBody bi = single_spring(SoftMethod::ImplicitEuler, k, m, rest, 0.1, Vec3(0, 2, 0));
    bi.def.iterations = 10;
    step(bi, Real(h));
    const double chord_arc = 0.5 * std::pow(h * 2, 2) / 1.1;
    CHECK(max_distance(bi, x_ref) <= 2 * chord_arc);
}

TEST_CASE("fast mass-spring converges to the implicit Euler step as its iterations grow", "[soft][integrators]") {
    // Three springs in a chain from a pin, swinging (different velocities per particle) under gravity, so the
    // springs' directions interact and local/global needs many iterations. Reference: backward Euler by
    // Newton. k = 1000 N/m, m = 0.1 kg, h = 1/30 s: h²k/m = 11, a stiff step.
    auto make = [](int iterations) {
        SoftBody b;
        b.def.method = SoftMethod::FastMassSpring;
        b.def.iterations = iterations;
        b.p.add(Vec3::Zero(), Real(0.1));
        b.p.inv_mass[0] = 0;
        b.p.add(Vec3(Real(0.5), 0, 0), Real(0.1));
        b.p.add(Vec3(Real(1.0), Real(0.05), 0), Real(0.1));
        b.p.add(Vec3(Real(1.5), 0, Real(0.05)), Real(0.1));
        b.p.v[1] = Vec3(0, 1, 0);
        b.p.v[2] = Vec3(0, -1, Real(0.5));
        b.p.v[3] = Vec3(Real(0.3), 2, 0);
        for (std::uint32_t i = 0; i < 3; ++i) {
            Link l;
            l.a = i;
            l.b = i + 1;
            l.rest = Real(0.5);
            l.stiffness = 1000;
            b.links.push_back(l);
        }
        b.gravity = Vec3(0, Real(-9.81), 0);
        return b;
    };
    const double h = 1.0 / 30;
    const SoftBody start = make(1);
    const std::vector<Eigen::Vector3d> x_ref = backward_euler_newton(start, h);
    std::vector<double> errors;
    for (const int iterations : {1, 4, 16, 64, 256}) {
        SoftBody b = make(iterations);
        step(b, Real(h));
        errors.push_back(max_distance(b, x_ref));
    }
    for (std::size_t i = 1; i < errors.size(); ++i) {
        INFO("errors " << errors[i - 1] << " -> " << errors[i]);
        // Block coordinate descent lowers the energy every iteration; with it the distance to the minimiser
        // falls, until float resolution (1e-7 m at 1.5 m: slack 1e-6).
        CHECK(errors[i] <= errors[i - 1] + 1e-6);
    }
    CHECK(errors.front() > 5e-4);  // one iteration is far from converged here (measured 1.3e-3)
    // Converged to float resolution (1e-6 m, ten ulps at 1.5 m) after enough iterations.
    CHECK(errors.back() <= 1e-6 + 1e-4 * errors.front());
}

TEST_CASE("fast mass-spring factors once and refactors only when h or the pins or the drag change",
          "[soft][integrators]") {
    // A three-particle chain hanging from particle 0.
    SoftBody b;
    b.def.method = SoftMethod::FastMassSpring;
    for (int i = 0; i < 3; ++i) b.p.add(Vec3(0, Real(-0.5 * i), 0), Real(0.1));
    b.p.inv_mass[0] = 0;
    for (std::uint32_t i = 0; i < 2; ++i) {
        Link l;
        l.a = i;
        l.b = i + 1;
        l.rest = Real(0.5);
        l.stiffness = 1000;
        b.links.push_back(l);
    }
    b.gravity = Vec3(0, Real(-9.81), 0);
    const Real h = Real(1.0 / 60);
    for (int n = 0; n < 10; ++n) step(b, h);
    CHECK(b.fms_cache->factorizations == 1);
    CHECK(b.p.x[0] == Vec3::Zero());
    b.p.inv_mass[2] = 0;  // pin the end too
    b.p.v[2].setZero();
    const Vec3 end = b.p.x[2];
    for (int n = 0; n < 10; ++n) step(b, h);
    CHECK(b.fms_cache->factorizations == 2);
    CHECK(b.p.x[2] == end);
    step(b, h / 2);
    CHECK(b.fms_cache->factorizations == 3);
    step(b, h / 2);
    CHECK(b.fms_cache->factorizations == 3);
    b.def.drag = 1;  // the drag scales the mass term, M' = (1 + h drag) M
    step(b, h / 2);
    CHECK(b.fms_cache->factorizations == 4);
}

TEST_CASE("every spring integrator advances a free particle under gravity and drag the same way",
          "[soft][integrators]") {
    // No springs: v_{n+1} = (v_n + h g)/(1 + h drag) in all four (the drag is implicit Euler of -drag v).
    // Positions differ by method (x uses v_n or v_{n+1}), velocities must agree.
    const Real h = Real(0.01), drag = 2;
    for (const SoftMethod method : {SoftMethod::ExplicitEuler, SoftMethod::SemiImplicitEuler,
                                    SoftMethod::ImplicitEuler, SoftMethod::FastMassSpring}) {
        SoftBody b;
        b.def.method = method;
        b.def.drag = drag;
        b.p.add(Vec3(0, 1, 0), Real(0.5));
        b.p.v[0] = Vec3(1, 0, 0);
        b.gravity = Vec3(0, Real(-9.81), 0);
        Eigen::Vector3d v = b.p.v[0].cast<double>();
        for (int n = 0; n < 50; ++n) {
            step(b, h);
            v = (v + double(h) * Eigen::Vector3d(0, -9.81, 0)) / (1 + double(h) * double(drag));
        }
        INFO(soft_method_name(method));
        // Float rounding of 50 velocity updates of ~1 m/s (fast-ms reads v back from positions near 1 m over
        // h = 0.01: 1e-7/0.01 = 1e-5 m/s per step).
        CHECK((b.p.v[0].cast<double>() - v).norm() <= 1e-4);
    }
}

namespace {

// Kinetic plus spring energy (J) of a body, in double.
double total_energy(const SoftBody& b) {
    double e = 0;
    for (std::size_t i = 0; i < b.p.size(); ++i)
        if (b.p.inv_mass[i] != 0) e += 0.5 * double(b.p.mass[i]) * double(b.p.v[i].squaredNorm());
    for (const Link& l : b.links) {
        const double s = double((b.p.x[l.a] - b.p.x[l.b]).norm()) - double(l.rest);
        e += 0.5 * double(l.stiffness) * s * s;
    }
    return e;
}

}  // namespace

TEST_CASE("implicit Euler: the isotropic blend damps a swinging spring (Volino)", "[soft][integrators]") {
    // Volino & Magnenat-Thalmann (seed 003 §2.4): the isotropic derivative -k I overestimates the lateral
    // stiffness of a spring and acts as extra damping of lateral motion; the exact anisotropic one does
    // not. A particle whirling round its pin on a spring (k = 1000 N/m, m = 1 kg, 2 m/s, no gravity), the
    // spring stretched just enough for its tension to hold the circle, k s = m v²/(L + s); h = 1/30 s, so
    // 1 + ω²h² = 2.11. The swing is the angular momentum about the pin, 3 steps on, over its start.
    const double k = 1000, m = 1, h = 1.0 / 30, damp = 1 / (1 + k / m * h * h);
    const double stretch = 0.00398;
    std::vector<double> swing;
    for (const double blend : {0.0, 0.25, 0.5, 1.0}) {
        SoftBody b = single_spring(SoftMethod::ImplicitEuler, k, m, 1, stretch, Vec3(0, 2, 0));
        b.def.isotropic_blend = Real(blend);
        const double l0 = double(b.p.x[1].cross(b.p.v[1]).z());
        for (int n = 0; n < 3; ++n) step(b, Real(h));
        swing.push_back(double(b.p.x[1].cross(b.p.v[1]).z()) / l0);
    }
    // Reference: backward Euler converged by Newton at every step (what the exact Jacobian approximates).
    SoftBody be = single_spring(SoftMethod::FastMassSpring, k, m, 1, stretch, Vec3(0, 2, 0));
    const double l0 = double(be.p.x[1].cross(be.p.v[1]).z());
    for (int n = 0; n < 3; ++n) {
        const Eigen::Vector3d x = backward_euler_newton(be, h)[1];
        be.p.v[1] = ((x - be.p.x[1].cast<double>()) / h).cast<Real>();
        be.p.x[1] = x.cast<Real>();
    }
    const double swing_be = double(be.p.x[1].cross(be.p.v[1]).z()) / l0;
    INFO("swing left at blend 0, 0.25, 0.5, 1: " << swing[0] << ", " << swing[1] << ", " << swing[2] << ", "
                                                 << swing[3] << "; converged backward Euler " << swing_be);
    for (std::size_t i = 1; i < swing.size(); ++i) CHECK(swing[i] < swing[i - 1]);  // more blend, more damping
    // Exact (anisotropic) Jacobian: the swing decays only as backward Euler itself damps it (1% over 3
    // steps). 1%: one Newton step misses the turn at second order in the angle per step, h|v|/L = 0.067,
    // i.e. 0.4% per step (measured 0.4% over the three).
    CHECK(swing[0] == Approx(swing_be).epsilon(0.01));
    // Isotropic: the lateral velocity is damped as an isotropic spring's, by 1/(1 + ω²h²) = 0.47 per step,
    // the radius staying put: 0.47³ = 0.106 of the swing is left. 2%: the radius shrinks by at most the
    // 4 mm stretch (0.4%) as the whirl slows and the tension drops.
    CHECK(swing[3] == Approx(damp * damp * damp).epsilon(0.02));
}

TEST_CASE("implicit Euler stays stable on a crumpled and compressed cloth at every isotropic blend",
          "[soft][integrators]") {
    // Links compressed to half their rest length make the exact (anisotropic) Jacobian indefinite
    // (c = 1 - L/|d| = -1 lateral); the clamp keeps the system positive definite so CG converges, and the
    // step stays stable while the cloth springs open: k = 1e4 N/m, 64 particles of 1/64 kg, h = 1/30 s.
    for (const double blend : {0.0, 0.3, 1.0}) {
        SoftBody b;
        b.def.method = SoftMethod::ImplicitEuler;
        b.def.iterations = 500;
        b.def.isotropic_blend = Real(blend);
        const int n = 8;
        const double spacing = 0.1;
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) {
                // Half-size grid with a deterministic out-of-plane crumple of +-5 mm.
                const double z = 0.005 * std::sin(1.7 * i + 2.3 * j);
                b.p.add(Vec3(Real(0.5 * spacing * i), Real(0.5 * spacing * j), Real(z)), Real(1.0 / (n * n)));
            }
        auto link = [&](int a, int c, double rest) {
            Link l;
            l.a = std::uint32_t(a);
            l.b = std::uint32_t(c);
            l.rest = Real(rest);
            l.stiffness = 1e4;
            b.links.push_back(l);
        };
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) {
                const int k = j * n + i;
                if (i + 1 < n) link(k, k + 1, spacing);
                if (j + 1 < n) link(k, k + n, spacing);
                if (i + 1 < n && j + 1 < n) {
                    link(k, k + n + 1, spacing * std::sqrt(2.0));
                    link(k + 1, k + n, spacing * std::sqrt(2.0));
                }
            }
        b.gravity = Vec3::Zero();
        double e_prev = total_energy(b), worst_rise = 0;
        int cg_max = 0;
        bool converged = true, finite = true;
        for (int s = 0; s < 120; ++s) {
            step(b, Real(1.0 / 30));
            converged = converged && b.implicit_cache->cg_converged;
            cg_max = std::max(cg_max, b.implicit_cache->cg_iterations);
            const double e = total_energy(b);
            worst_rise = std::max(worst_rise, (e - e_prev) / e_prev);
            e_prev = e;
            for (const Vec3& x : b.p.x) finite = finite && is_finite(x);
        }
        INFO("blend " << blend << ": worst relative energy rise over a step " << worst_rise << ", final energy "
                      << e_prev << " J, CG iterations <= " << cg_max);
        CHECK(finite);
        CHECK(converged);
        // Backward Euler dissipates: the energy falls at every step (measured: never rises). 1e-4 relative
        // allows float rounding once it has fallen to 1e-5 J (positions resolved to 3e-8 m).
        CHECK(worst_rise <= 1e-4);
    }
}

// Issue 18, item 2: fast mass-spring's triangular solves split along the factor's elimination tree
// (soft/ldlt_schedule.hpp). On a 48 x 48 grid's matrix in its AMD order (a 2-D mesh like a cloth's), each
// schedule's parts and top rows cover every row once, and the split solve gives the one-thread solve's
// values bit for bit on any worker and part count, which solve the system to round-off.
TEST_CASE("an LDLT solve split along the elimination tree gives the one-thread solve, bit for bit", "[soft][ldlt][threads]") {
    using Sparse = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;
    const int side = 48, n = side * side;
    std::vector<Eigen::Triplet<double, int>> t;
    for (int j = 0; j < side; ++j)
        for (int i = 0; i < side; ++i) {
            const int k = j * side + i;
            t.emplace_back(k, k, 1.0);  // a mass term
            const auto couple = [&](int a, int b, double w) {
                t.emplace_back(a, a, w), t.emplace_back(b, b, w), t.emplace_back(a, b, -w), t.emplace_back(b, a, -w);
            };
            if (i + 1 < side) couple(k, k + 1, 100.0);
            if (j + 1 < side) couple(k, k + side, 100.0);
            if (i + 1 < side && j + 1 < side) couple(k, k + side + 1, 50.0), couple(k + 1, k + side, 50.0);
        }
    Sparse natural(n, n);
    natural.setFromTriplets(t.begin(), t.end());
    Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> perm;
    Eigen::AMDOrdering<int>()(natural, perm);
    Sparse a;
    a = natural.twistedBy(perm.inverse());  // new row k holds old row perm[k]
    const Eigen::SimplicialLDLT<Sparse, Eigen::Lower, Eigen::NaturalOrdering<int>> ldlt(a);
    REQUIRE(ldlt.info() == Eigen::Success);
    LdltArrays factor;
    factor.assign(ldlt.matrixL().nestedExpression(), ldlt.vectorD());

    std::vector<double> b(3 * std::size_t(n));
    for (std::size_t i = 0; i < b.size(); ++i) b[i] = std::sin(0.37 * double(i)) + 0.1 * double(i % 7);
    std::vector<double> serial = b;
    factor.solve_in_place<3>(serial.data());
    double worst_residual = 0;
    for (int c = 0; c < 3; ++c) {
        Eigen::VectorXd x(n), rhs(n);
        for (int i = 0; i < n; ++i) x[i] = serial[3 * std::size_t(i) + c], rhs[i] = b[3 * std::size_t(i) + c];
        worst_residual = std::max(worst_residual, (a.selfadjointView<Eigen::Lower>() * x - rhs).cwiseAbs().maxCoeff());
    }
    CHECK(worst_residual < 1e-9);  // |b| ~ 1, condition number ~ 1e4: round-off is ~1e-12

    for (int parts : {2, 3, 5}) {
        LdltSchedule schedule;
        schedule.build(factor, parts);
        std::vector<int> seen(std::size_t(n), 0);
        for (const int i : schedule.part_rows) ++seen[std::size_t(i)];
        for (const int i : schedule.top_rows) ++seen[std::size_t(i)];
        CHECK(std::count(seen.begin(), seen.end(), 1) == n);
        CHECK(schedule.top_share < 0.5);  // the tree is split: most rows are in the parts
        for (int workers : {1, 2, 3}) {
            INFO(parts << " parts, " << workers << " workers");
            ThreadPool pool(workers);
            ParallelRegion region;
            std::vector<double> x = b;
            region.run(&pool.task_system(), [&] { solve_in_place_parallel<3>(factor, schedule, region, x.data()); });
            CHECK(std::memcmp(x.data(), serial.data(), x.size() * sizeof(double)) == 0);
        }
    }
}
