// A hanging cloth reaches static equilibrium under the implicit integrators (Baraff & Witkin 1998, Liu et
// al. 2013; docs/theory.md#euler and #fast-mass-spring): a 1 m square of
// 10 x 10 nodes with structural and shear springs, pinned at its two top corners, under gravity. After
// settling, the forces balance at every free node, and implicit Euler (Baraff-Witkin) and fast mass-spring
// (Liu 2013) both agree with the static equilibrium f(x) = 0 solved by Newton's method in this file.
//
// The cloth hangs in the vertical x-y plane with gravity in that plane: every force then lies in the plane
// and the motion stays planar exactly (the z components are computed as 0), so the reference is the 2-D
// equilibrium. That also avoids the out-of-plane null space of a flat spring net, whose Jacobian there is
// the lateral stiffness k (1 - L/|d|) alone (singular for unstretched springs).
#include <catch2/catch.hpp>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <vector>

#include "soft/soft_builders.hpp"
#include "soft/soft_integrators.hpp"
#include "soft/soft_system.hpp"
#include "soft/solver_caches.hpp"

using namespace sinew;

namespace {

constexpr int kNodes = 10;           // per side
constexpr double kSize = 1;          // m
constexpr double kMass = 1;          // kg in total
constexpr double kGravity = 9.81;

ClothGridDesc cloth_desc(double stiffness) {
    ClothGridDesc d;
    d.nx = d.ny = kNodes;
    d.origin = Vec3(0, 0, 0);
    d.edge_u = Vec3(Real(kSize), 0, 0);
    d.edge_v = Vec3(0, Real(-kSize), 0);
    d.total_mass = Real(kMass);
    d.shear = true;
    d.bend = false;
    d.material.stretch = d.material.shear = Real(stiffness);
    d.material.damping = Real(0.5);  // N s/m: implicit Euler uses it; fast mass-spring ignores it
    return d;
}

SoftBodyDef cloth_def(SoftMethod method, double stiffness) {
    SoftBodyDef base;
    base.method = method;
    const ClothGridDesc d = cloth_desc(stiffness);
    SoftBodyDef def = make_cloth_grid(d, base);
    def.pinned = {cloth_node(d, 0, 0), cloth_node(d, kNodes - 1, 0)};
    return def;
}

// Net force (springs without damping, plus gravity) on every particle at positions x, in double.
std::vector<Eigen::Vector2d> net_forces(const SoftBody& b, const std::vector<Eigen::Vector2d>& x) {
    std::vector<Eigen::Vector2d> f(x.size());
    for (std::size_t i = 0; i < x.size(); ++i) f[i] = Eigen::Vector2d(0, -double(b.p.mass[i]) * kGravity);
    for (const Link& l : b.links) {
        const Eigen::Vector2d d = x[l.a] - x[l.b];
        const double len = d.norm();
        const Eigen::Vector2d fa = -double(l.stiffness) * (len - double(l.rest)) * d / len;
        f[l.a] += fa;
        f[l.b] -= fa;
    }
    return f;
}

std::vector<Eigen::Vector2d> planar(const SoftBody& b) {
    std::vector<Eigen::Vector2d> x(b.p.size());
    for (std::size_t i = 0; i < x.size(); ++i) x[i] = Eigen::Vector2d(b.p.x[i].x(), b.p.x[i].y());
    return x;
}

// Static equilibrium by Newton's method on the free nodes' in-plane coordinates: dense LU of the exact
// stiffness matrix, backtracking on |f| so that the first steps from the rest shape cannot overshoot.
std::vector<Eigen::Vector2d> newton_equilibrium(const SoftBody& b, int& iterations, double& residual) {
    const std::size_t n = b.p.size();
    std::vector<int> dof(n, -1);
    int nf = 0;
    for (std::size_t i = 0; i < n; ++i)
        if (b.p.inv_mass[i] != 0) dof[i] = 2 * nf++;
    std::vector<Eigen::Vector2d> x = planar(b);
    auto gather = [&](const std::vector<Eigen::Vector2d>& f) {
        Eigen::VectorXd g(2 * nf);
        for (std::size_t i = 0; i < n; ++i)
            if (dof[i] >= 0) g.segment<2>(dof[i]) = f[i];
        return g;
    };
    Eigen::VectorXd g = gather(net_forces(b, x));
    for (iterations = 0; iterations < 100 && g.norm() > 1e-12; ++iterations) {
        // K = -df/dx (positive definite near a stable equilibrium).
        Eigen::MatrixXd k = Eigen::MatrixXd::Zero(2 * nf, 2 * nf);
        for (const Link& l : b.links) {
            const Eigen::Vector2d d = x[l.a] - x[l.b];
            const double len = d.norm();
            const Eigen::Vector2d e = d / len;
            const Eigen::Matrix2d kb = double(l.stiffness) * ((1 - double(l.rest) / len) *
                                                                  (Eigen::Matrix2d::Identity() - e * e.transpose()) +
                                                              e * e.transpose());
            const int da = dof[l.a], db = dof[l.b];
            if (da >= 0) k.block<2, 2>(da, da) += kb;
            if (db >= 0) k.block<2, 2>(db, db) += kb;
            if (da >= 0 && db >= 0) {
                k.block<2, 2>(da, db) -= kb;
                k.block<2, 2>(db, da) -= kb;
            }
        }
        const Eigen::VectorXd dx = k.lu().solve(g);  // f(x + dx) ≈ f - K dx = 0
        double t = 1;
        for (int tries = 0; tries < 30; ++tries, t *= 0.5) {
            std::vector<Eigen::Vector2d> trial = x;
            for (std::size_t i = 0; i < n; ++i)
                if (dof[i] >= 0) trial[i] += t * dx.segment<2>(dof[i]);
            const Eigen::VectorXd g_trial = gather(net_forces(b, trial));
            if (g_trial.norm() < g.norm()) {
                x = trial;
                g = g_trial;
                break;
            }
        }
        if (t < 1e-8) break;  // no decrease left: at round-off
    }
    residual = g.norm();
    return x;
}

double max_distance(const std::vector<Eigen::Vector2d>& a, const std::vector<Eigen::Vector2d>& b) {
    double worst = 0;
    for (std::size_t i = 0; i < a.size(); ++i) worst = std::max(worst, (a[i] - b[i]).norm());
    return worst;
}

struct Settled {
    std::vector<Eigen::Vector2d> x;
    double max_z = 0;
    double kinetic = 0;
    double worst_force = 0;  // N, over free nodes
    int cg_iterations_max = 0;
    bool cg_converged = true;
};

Settled settle(SoftMethod method, double stiffness, int iterations, Real drag, int steps) {
    SoftSystem sys;
    SoftBodyDef def = cloth_def(method, stiffness);
    def.iterations = iterations;
    def.drag = drag;
    SoftBody& b = sys.body(sys.create_body(def));
    b.gravity = Vec3(0, Real(-kGravity), 0);
    const Real h = Real(1.0 / 60);
    Settled s;
    for (int n = 0; n < steps; ++n) {
        if (method == SoftMethod::ImplicitEuler) {
            step_implicit_euler(b, h);
            s.cg_iterations_max = std::max(s.cg_iterations_max, b.implicit_cache->cg_iterations);
            s.cg_converged = s.cg_converged && b.implicit_cache->cg_converged;
        } else {
            step_fast_mass_spring(b, h);
        }
    }
    s.x = planar(b);
    for (const Vec3& x : b.p.x) s.max_z = std::max(s.max_z, double(std::abs(x.z())));
    s.kinetic = double(b.kinetic_energy());
    const std::vector<Eigen::Vector2d> f = net_forces(b, s.x);
    for (std::size_t i = 0; i < f.size(); ++i)
        if (b.p.inv_mass[i] != 0) s.worst_force = std::max(s.worst_force, f[i].norm());
    return s;
}

}  // namespace

TEST_CASE("a hanging cloth settles to the static equilibrium under implicit Euler and fast mass-spring",
          "[soft][integrators][cloth]") {
    // k = 100 N/m: the cloth sags by centimetres (a real test of the 1% agreement); k = 1000 N/m: a stiffer
    // cloth, where a small position bias shows up as a large force imbalance.
    const double stiffness = GENERATE(100.0, 1000.0);
    SoftSystem sys;
    const SoftBody& rest = sys.body(sys.create_body(cloth_def(SoftMethod::ImplicitEuler, stiffness)));
    int newton_iterations = 0;
    double newton_residual = 0;
    const std::vector<Eigen::Vector2d> x_eq = newton_equilibrium(rest, newton_iterations, newton_residual);
    const double sag = max_distance(x_eq, planar(rest));
    INFO("k = " << stiffness << " N/m; Newton: " << newton_iterations << " iterations, residual " << newton_residual
                << " N, largest node displacement from the rest shape " << sag << " m");
    // The reference is converged: the net force is at double round-off of the 9.81 N weight.
    REQUIRE(newton_residual < 1e-9);
    if (stiffness == 100) CHECK(sag > 0.05);  // far from the rest shape: the 1 cm comparison means something

    const double node_weight = kMass / (kNodes * kNodes) * kGravity;  // 0.098 N
    struct Case {
        SoftMethod method;
        int iterations;  // CG cap (implicit) or local/global iterations (fast-ms)
    };
    for (const Case c : {Case{SoftMethod::ImplicitEuler, 500}, Case{SoftMethod::FastMassSpring, 10}}) {
        // 10 s at h = 1/60 with a drag of 1/s (plus the links' k_d under implicit Euler, and both methods'
        // numerical damping) removes the swing: the kinetic energy ends below 1e-9 J.
        const Settled s = settle(c.method, stiffness, c.iterations, Real(1), 600);
        INFO(soft_method_name(c.method) << ": distance to Newton " << max_distance(s.x, x_eq) << " m, worst net force "
                                        << s.worst_force << " N, kinetic energy " << s.kinetic
                                        << " J, CG iterations <= " << s.cg_iterations_max);
        CHECK(s.max_z == 0);  // planar, as argued above
        CHECK(s.cg_converged);
        CHECK(s.kinetic < 1e-9);
        // Forces balance at every free node to 1% of a node's weight. Float positions (ulp 6e-8 m) limit
        // the balance to about k ulp per link, 8 links: 5e-4 N at k = 1000, half the tolerance.
        CHECK(s.worst_force <= 0.01 * node_weight);
        // The 1% of the patch size (measured: ~1e-7 m for both methods).
        CHECK(max_distance(s.x, x_eq) <= 0.01 * kSize);
    }
}
