// Coupling strategies between rigid and soft bodies (coupling/coupling_layer.hpp): what each exchanges,
// checked against conservation laws and against the contrast the strategies exist to show.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <string>

#include <Eigen/Dense>
#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>

#include "engine/world/scene.hpp"

using namespace sinew;

namespace {

std::string scene_path(const char* name) { return std::string(SINEW_SOURCE_DIR) + "/demos/scenes/" + name; }

// A 0.5 kg, 0.6 m implicit cloth (7 x 7 nodes) moving at 3 m/s in -z towards a free 2 kg box, off
// centre so the box also spins; no gravity, nothing else in the world.
std::string thrown_cloth_scene(const char* strategy, const char* method) {
    return std::string(R"({"format": "sinew-scene", "version": 1,
      "settings": {"gravity": [0, 0, 0], "sleeping": {"enabled": false}},
      "bodies": [{"name": "box", "shape": {"type": "box", "half_extents": [0.3, 0.3, 0.3]}, "mass": 2,
                  "position": [0.1, 0.05, 0], "material": {"friction": 0.4}}],
      "soft_bodies": [{"name": "cloth", "builder": "cloth", "nodes": [7, 7], "origin": [-0.3, -0.3, 0.6],
                  "edge_u": [0.6, 0, 0], "edge_v": [0, 0.6, 0], "mass": 0.5, "method": ")") + method + R"(",
                  "links": {"stretch": 2000, "shear": 200, "damping": 1}, "velocity": [0, 0, -3],
                  "material": {"friction": 0.4, "thickness": 0.02}}],
      "coupling": {"strategy": ")" + strategy + R"("}})";
}

Vec3 total_momentum(const World& w) {
    Vec3 p = Vec3::Zero();
    for (BodyId id : w.rigid().bodies()) p += w.rigid().mass(id) * w.rigid().linear_velocity(id);
    for (SoftBodyId id : w.soft().bodies()) {
        const Particles& q = w.soft().body(id).p;
        for (std::size_t i = 0; i < q.size(); ++i) p += q.mass[i] * q.v[i];
    }
    return p;
}

}  // namespace

namespace {

// Linear momentum before and after 60 steps, the cloth thrown at the box under two-way coupling with
// the given rigid solver; returns the relative change.
Real momentum_change(const char* method, RigidSolverKind solver, Real& box_speed, const char* strategy = "two-way") {
    SceneDesc d = parse_scene_string(thrown_cloth_scene(strategy, method), "thrown-cloth");
    d.settings.rigid.solver = solver;
    auto w = build_world(d);
    const Vec3 p0 = total_momentum(*w);  // 0.5 kg at 3 m/s: 1.5 N s along -z
    for (int s = 0; s < 60; ++s) w->step();
    box_speed = -w->rigid().linear_velocity(w->rigid().bodies()[0]).z();
    return (total_momentum(*w) - p0).norm() / p0.norm();
}

}  // namespace

TEST_CASE("two-way coupling conserves linear momentum when a cloth hits a free box", "[coupling]") {
    // Every impulse the layer exchanges is applied equally and oppositely (rows, the implicit solve's
    // ties, the soft contact pass's impulses sent back), and implicit Euler keeps the momentum of
    // an unconverged solve (momentum_correction), so only rounding is left: measured at most 6e-5 in float
    // over the methods and solvers; the issue's bounds are 1e-4 (float) and 1e-6 (double).
    const Real tol = sizeof(Real) == 4 ? Real(1e-4) : Real(1e-6);
    for (const char* method : {"implicit", "verlet", "fast-ms"})
        for (RigidSolverKind solver : {RigidSolverKind::SoftStep, RigidSolverKind::SplitImpulse, RigidSolverKind::Baumgarte,
                                       RigidSolverKind::Newton}) {
            INFO(method << " under " << rigid_solver_name(solver));
            Real box_speed = 0;
            CHECK(momentum_change(method, solver, box_speed) <= tol);
            CHECK(box_speed > Real(0.2));  // struck: the box took a good share of the cloth's momentum
        }
}

TEST_CASE("one-solver: the cloth swept in the rigid solver and the box it strikes keep their momentum", "[coupling]") {
    // The rows exchange equal and opposite impulses, and after each sweep a uniform shift per body puts
    // back what the unconverged springs did to its momentum (without it: 11% lost in a second).
    // Measured at most 2.5e-5 in float; bounds as for two-way.
    const Real tol = sizeof(Real) == 4 ? Real(1e-4) : Real(1e-6);
    for (const char* method : {"implicit", "semi-implicit", "fast-ms"})
        for (RigidSolverKind solver : {RigidSolverKind::SoftStep, RigidSolverKind::SplitImpulse, RigidSolverKind::Newton}) {
            INFO(method << " under " << rigid_solver_name(solver));
            Real box_speed = 0;
            CHECK(momentum_change(method, solver, box_speed, "one-solver") <= tol);
            CHECK(box_speed > Real(0.2));
        }
}

TEST_CASE("two-way coupling: unlinked particles striking a box off centre exchange angular momentum", "[coupling]") {
    // 25 free 20 g particles at 3 m/s strike a 2 kg box off its centre, frictionless, no gravity. Normal
    // impulses act on the normal through each particle on both sides, so they carry no net moment;
    // what is left comes from the soft contact pass moving positions without velocity (its projection
    // out of the box), measured 2.7e-4 (soft step) to 1.3e-3 (the others) of the 0.15 N m s.
    for (RigidSolverKind solver : {RigidSolverKind::SoftStep, RigidSolverKind::SplitImpulse}) {
        WorldSettings ws;
        ws.rigid.gravity = Vec3::Zero();
        ws.rigid.sleeping = false;
        ws.rigid.solver = solver;
        World w(ws);
        BodyDef bd;
        bd.shape = make_box(Vec3(Real(0.3), Real(0.3), Real(0.3)));
        bd.mass = 2;
        bd.pose.p = Vec3(Real(0.1), Real(0.05), 0);
        bd.material.friction = 0;
        const BodyId box = w.rigid().create_body(bd);
        SoftBodyDef sd;
        sd.method = SoftMethod::ImplicitEuler;
        sd.friction = 0;
        sd.thickness = Real(0.02);
        for (int i = 0; i < 5; ++i)
            for (int j = 0; j < 5; ++j) {
                sd.positions.push_back(Vec3(Real(-0.3 + 0.15 * i), Real(-0.3 + 0.15 * j), Real(0.6)));
                sd.masses.push_back(Real(0.02));
            }
        sd.initial_velocity = Vec3(Real(0.5), 0, -3);
        w.soft().create_body(sd);
        CouplingSettings cs;
        cs.strategy = CouplingStrategy::TwoWay;
        w.set_coupling(cs);
        const Real inertia = Real(2 * 0.36 / 6);  // cube of side 0.6: m a^2 / 6, isotropic
        const auto momenta = [&](Vec3& p, Vec3& l) {
            p = w.rigid().mass(box) * w.rigid().linear_velocity(box);
            l = inertia * w.rigid().angular_velocity(box) + w.rigid().state().x[box.index].cross(p);
            const Particles& q = w.soft().body(w.soft().bodies()[0]).p;
            for (std::size_t i = 0; i < q.size(); ++i) {
                p += q.mass[i] * q.v[i];
                l += q.x[i].cross(q.mass[i] * q.v[i]);
            }
        };
        Vec3 p0, l0, p1, l1;
        momenta(p0, l0);
        for (int s = 0; s < 60; ++s) w.step();
        momenta(p1, l1);
        INFO(rigid_solver_name(solver));
        CHECK(w.rigid().angular_velocity(box).norm() > Real(0.1));  // off centre: the box spins
        CHECK((p1 - p0).norm() <= Real(1e-4) * p0.norm());
        CHECK((l1 - l0).norm() <= Real(1e-2) * l0.norm());
    }
}

TEST_CASE("box-on-soft-block: the FEM block carries the box at the same depth under every rigid solver", "[coupling]") {
    // Statics: a 20 kg box on a clamped 1 x 0.4 x 1 m block (E = 2e5). At rest the impulses the block
    // gives the box over a step are its weight times h, and the block's top under the box sinks the
    // same under every rigid solver and at a quarter of the step (measured 2.44 mm at h = 1/60 with split
    // impulses, Baumgarte and Newton, 2.44 mm with the soft step, 2.44 mm at h/4); one-way lets the box
    // fall through. 2% on the depth, 1% on the force (the residual motion of a settling body).
    const SceneDesc scene = parse_scene_file(scene_path("box-on-soft-block.json"));
    const auto settle = [&](RigidSolverKind solver, CouplingStrategy strategy, int divide, Real& sink, Real& force) {
        SceneDesc d = scene;
        d.settings.rigid.solver = solver;
        d.settings.rigid.sleeping = false;
        d.settings.time_step /= Real(divide);
        d.coupling.settings.strategy = strategy;
        std::vector<BodyId> ids;
        auto w = build_world(d, &ids);
        const int steps = int(Real(1.5) / d.settings.time_step + Real(0.5));
        Vec3 impulse = Vec3::Zero();
        const int averaged = 15 * divide;  // the last quarter second
        for (int k = 0; k < steps; ++k) {
            w->step();
            if (k >= steps - averaged)
                for (const CouplingImpulse& c : w->coupling().impulses())
                    if (c.rigid == ids[1].index) impulse += c.impulse;
        }
        force = impulse.y() / (Real(averaged) * d.settings.time_step);
        // The block's top nodes under the box (x, z = +-0.1, y = 0.4 at rest).
        Real top = 1;
        for (const Vec3& x : w->soft().body(w->soft().bodies()[0]).p.x)
            if (std::abs(x.x()) < Real(0.15) && std::abs(x.z()) < Real(0.15) && x.y() > Real(0.3)) top = std::min(top, x.y());
        sink = Real(0.4) - top;
        return w->rigid().transform(ids[1]).p.y();
    };
    Real reference_sink = 0, force = 0;
    settle(RigidSolverKind::SplitImpulse, CouplingStrategy::TwoWay, 4, reference_sink, force);
    REQUIRE(reference_sink > Real(0.001));
    const Real weight = 20 * Real(9.81);
    for (RigidSolverKind solver : {RigidSolverKind::SoftStep, RigidSolverKind::SplitImpulse, RigidSolverKind::Baumgarte,
                                   RigidSolverKind::Newton}) {
        INFO(rigid_solver_name(solver));
        Real sink = 0;
        settle(solver, CouplingStrategy::TwoWay, 1, sink, force);
        CHECK(sink == Approx(reference_sink).epsilon(0.02));
        CHECK(force == Approx(weight).epsilon(0.01));
    }
    Real sink = 0;
    CHECK(settle(RigidSolverKind::SoftStep, CouplingStrategy::OneWay, 1, sink, force) < Real(0.25));  // on the ground
}

namespace {

// The static equilibrium of box-on-soft-block's FEM block under a rigid box of weight `weight`, solved
// directly and independently of the engine's FEM code: linear elasticity (small strain, the scene's E and
// nu), K_ab = V (lambda g_a g_b^T + mu g_b g_a^T + mu (g_a . g_b) I) per tet assembled densely, gravity
// on the engine's lumped masses, the clamped base fixed, and the top nodes under the box moved down
// together by d (a rigid, level box; they stick, as friction holds them): d is where the nodes push
// back with the box's weight (the reaction is linear in d: two solves).
double static_sink(const SceneDesc& scene, const World& w, double weight) {
    const SoftBody& b = w.soft().body(w.soft().bodies()[0]);
    const std::vector<std::uint32_t>& tets = scene.soft_bodies[0].def.tets;
    const std::vector<Vec3>& x = scene.soft_bodies[0].def.positions;
    const FemMaterial& mat = scene.soft_bodies[0].def.fem;
    const double lambda = double(mat.lame_lambda()), mu = double(mat.lame_mu());
    const int n = int(x.size()), dofs = 3 * n;
    Eigen::MatrixXd k = Eigen::MatrixXd::Zero(dofs, dofs);
    for (std::size_t t = 0; t < tets.size(); t += 4) {
        const std::uint32_t* id = &tets[t];
        Eigen::Matrix3d dm;
        for (int c = 0; c < 3; ++c) dm.col(c) = (x[id[c + 1]] - x[id[0]]).cast<double>();
        const double volume = dm.determinant() / 6;
        const Eigen::Matrix3d inv = dm.inverse();
        Eigen::Vector3d g[4];
        for (int c = 0; c < 3; ++c) g[c + 1] = inv.row(c).transpose();
        g[0] = -(g[1] + g[2] + g[3]);
        for (int a = 0; a < 4; ++a)
            for (int c = 0; c < 4; ++c)
                k.block<3, 3>(3 * int(id[a]), 3 * int(id[c])) +=
                    volume * (lambda * g[a] * g[c].transpose() + mu * g[c] * g[a].transpose() +
                              mu * g[a].dot(g[c]) * Eigen::Matrix3d::Identity());
    }
    enum { Free, Fixed, Pressed };
    std::vector<int> kind(std::size_t(dofs), Free);
    for (int i = 0; i < n; ++i) {
        const bool under_box = x[i].y() > Real(0.39) && std::abs(x[i].x()) < Real(0.2) && std::abs(x[i].z()) < Real(0.2);
        if (b.p.inv_mass[std::size_t(i)] == 0) kind[3 * i] = kind[3 * i + 1] = kind[3 * i + 2] = Fixed;
        if (under_box) kind[3 * i] = kind[3 * i + 2] = Fixed, kind[3 * i + 1] = Pressed;
    }
    Eigen::VectorXd gravity = Eigen::VectorXd::Zero(dofs);
    for (int i = 0; i < n; ++i) gravity[3 * i + 1] = -9.81 * double(b.p.mass[std::size_t(i)]);
    std::vector<int> free;
    for (int q = 0; q < dofs; ++q)
        if (kind[std::size_t(q)] == Free) free.push_back(q);
    Eigen::MatrixXd kff(free.size(), free.size());
    for (std::size_t a = 0; a < free.size(); ++a)
        for (std::size_t c = 0; c < free.size(); ++c) kff(Eigen::Index(a), Eigen::Index(c)) = k(free[a], free[c]);
    const Eigen::LDLT<Eigen::MatrixXd> solver(kff);
    const auto push_back_force = [&](double d) {  // what the pressed nodes push up with, down by d
        Eigen::VectorXd u = Eigen::VectorXd::Zero(dofs);
        for (int q = 0; q < dofs; ++q)
            if (kind[std::size_t(q)] == Pressed) u[q] = -d;
        const Eigen::VectorXd ku = k * u;
        Eigen::VectorXd rhs(free.size());
        for (std::size_t a = 0; a < free.size(); ++a) rhs[Eigen::Index(a)] = gravity[free[a]] - ku[free[a]];
        const Eigen::VectorXd uf = solver.solve(rhs);
        for (std::size_t a = 0; a < free.size(); ++a) u[free[a]] = uf[Eigen::Index(a)];
        const Eigen::VectorXd reaction = k * u - gravity;
        double up = 0;
        for (int q = 0; q < dofs; ++q)
            if (kind[std::size_t(q)] == Pressed) up -= reaction[q];
        return up;
    };
    const double at0 = push_back_force(0), slope = push_back_force(1) - at0;
    return (weight - at0) / slope;
}

}  // namespace

TEST_CASE("box-on-soft-block: the block's top under the box sinks to the converged static solve's depth", "[coupling]") {
    // The static solve (static_sink above, a rigid level box, linear elasticity) puts the four top nodes
    // under the box 2.34 mm down. Two-way coupling, settled for 1.5 s: each of them 2.33-2.35 mm down
    // under every rigid solver (means 2.338-2.349 mm, within 0.4%), within the issue's 2%: the box is a
    // rigid body inside the block's implicit solve, so it presses the stiffer nodes harder and stays
    // level. With its mass split evenly over the nodes as independent shares the deepest sank 2.44 mm and
    // the other pair 2.27 mm (a static solve with equal loads of Mg/4 reproduces those).
    const SceneDesc scene = parse_scene_file(scene_path("box-on-soft-block.json"));
    double expected = 0;
    for (RigidSolverKind solver : {RigidSolverKind::SoftStep, RigidSolverKind::SplitImpulse, RigidSolverKind::Newton}) {
        INFO(rigid_solver_name(solver));
        SceneDesc d = scene;
        d.settings.rigid.solver = solver;
        d.settings.rigid.sleeping = false;
        auto w = build_world(d);
        if (expected == 0) expected = static_sink(d, *w, 20 * 9.81);
        for (int k = 0; k < 90; ++k) w->step();
        double mean = 0, shallowest = 1, deepest = 0;
        int count = 0;
        for (const Vec3& x : w->soft().body(w->soft().bodies()[0]).p.x)
            if (std::abs(x.x()) < Real(0.15) && std::abs(x.z()) < Real(0.15) && x.y() > Real(0.3)) {
                mean += double(x.y());
                shallowest = std::min(shallowest, 0.4 - double(x.y()));
                deepest = std::max(deepest, 0.4 - double(x.y()));
                ++count;
            }
        REQUIRE(count == 4);
        mean /= count;
        CHECK(expected == Approx(0.00234).epsilon(0.01));
        CHECK(0.4 - mean == Approx(expected).epsilon(0.02));
        CHECK(shallowest == Approx(expected).epsilon(0.02));
        CHECK(deepest == Approx(expected).epsilon(0.02));
    }
}

TEST_CASE("one-way coupling leaves the rigid body's path unchanged, two-way does not", "[coupling]") {
    auto one = build_world(parse_scene_string(thrown_cloth_scene("one-way", "implicit"), "one-way"));
    auto two = build_world(parse_scene_string(thrown_cloth_scene("two-way", "implicit"), "two-way"));
    for (int s = 0; s < 60; ++s) {
        one->step();
        two->step();
    }
    const BodyId a = one->rigid().bodies()[0], b = two->rigid().bodies()[0];
    // No gravity, nothing else touches it: under one-way the box must not have moved at all, bit for bit.
    CHECK(one->rigid().linear_velocity(a) == Vec3::Zero());
    CHECK(one->rigid().angular_velocity(a) == Vec3::Zero());
    CHECK(one->rigid().transform(a).p == Vec3(Real(0.1), Real(0.05), 0));
    CHECK(two->rigid().linear_velocity(b).norm() > Real(0.2));
    CHECK(one->coupling().impulses().empty());
}

TEST_CASE("ball-on-trampoline: two-way holds the ball that falls through under one-way", "[coupling]") {
    SceneDesc scene = parse_scene_file(scene_path("ball-on-trampoline.json"));
    const auto ball_and_cloth_after = [&](CouplingStrategy s, Real seconds, Real& ball_y, Real& cloth_min_y) {
        SceneDesc d = scene;
        d.coupling.settings.strategy = s;
        std::vector<BodyId> ids;
        auto w = build_world(d, &ids);
        const int steps = int(seconds / w->settings().time_step + Real(0.5));
        for (int k = 0; k < steps; ++k) w->step();
        ball_y = w->rigid().transform(ids[1]).p.y();
        cloth_min_y = 1e9f;
        for (const Vec3& x : w->soft().body(w->soft().bodies()[0]).p.x) cloth_min_y = std::min(cloth_min_y, x.y());
    };
    // The ball (r = 0.2) reaches the cloth (y = 1) at about 0.45 s, at 4.7 m/s.
    Real ball_y, cloth_y;
    ball_and_cloth_after(CouplingStrategy::OneWay, Real(1), ball_y, cloth_y);
    CHECK(ball_y < Real(0.25));  // on the ground: the cloth did not slow it
    ball_and_cloth_after(CouplingStrategy::TwoWay, Real(0.75), ball_y, cloth_y);
    // Still in the cloth, above its lowest point, having been stopped well above the ground.
    CHECK(ball_y > cloth_y);
    CHECK(ball_y > Real(0.3));
}

namespace {

// The static rest of ball-on-trampoline's ball of mass `mass` (kg), solved directly and independently of
// the engine's solvers: the potential energy of the cloth's springs (sum k (l - L)^2 / 2), of gravity on
// its nodes and on the ball, and of a contact penalty kappa (R - |x_i - c|)^2 / 2 between each node and
// the ball's centre c = (bx, Y, bz) (R = ball radius + the cloth's thickness, the distance the coupling's
// rows keep), minimised over the free nodes and the ball's height Y (the ball held sideways where the
// run left it, as friction holds it). Levenberg-Marquardt on the springs' positive semi-definite
// Hessians (the transverse term of a compressed spring dropped, as in Choi and Ko 2002) with a line
// search, starting from the flat cloth; kappa raised 1e5, 1e6, 1e7 N/m until Y no longer moves (the
// nodes then sink into the ball by under a micrometre). `gradient` receives the final gradient's norm.
double trampoline_static_rest(const SoftBody& b, const std::vector<Vec3>& flat, double bx, double bz, double mass,
                              double radius, double& gradient) {
    using Eigen::Vector3d;
    const int n = int(flat.size());
    std::vector<Vector3d> x(flat.size());
    for (int i = 0; i < n; ++i) x[std::size_t(i)] = flat[std::size_t(i)].cast<double>();
    std::vector<int> dof(flat.size(), -1);
    int dofs = 0;
    for (int i = 0; i < n; ++i)
        if (b.p.inv_mass[std::size_t(i)] > 0) dof[std::size_t(i)] = dofs, dofs += 3;
    const int ball = dofs++;
    const double g = 9.81;
    double y = 1 + radius;  // touching the flat cloth
    const auto energy = [&](const std::vector<Vector3d>& xs, double yc, double kappa) {
        double e = mass * g * yc;
        for (const Link& l : b.links) {
            const double stretch = (xs[l.a] - xs[l.b]).norm() - double(l.rest);
            e += 0.5 * double(l.stiffness) * stretch * stretch;
        }
        for (int i = 0; i < n; ++i) {
            e += double(b.p.mass[std::size_t(i)]) * g * xs[std::size_t(i)].y();
            const double depth = radius - (xs[std::size_t(i)] - Vector3d(bx, yc, bz)).norm();
            if (depth > 0) e += 0.5 * kappa * depth * depth;
        }
        return e;
    };
    for (double kappa = 1e5; kappa < 2e7; kappa *= 10) {
        double mu = 1e-2;  // Levenberg-Marquardt's weight on the masses, in units of m / (0.01 s)^2
        for (int it = 0; it < 1000; ++it) {
            Eigen::VectorXd grad = Eigen::VectorXd::Zero(dofs);
            std::vector<Eigen::Triplet<double>> h;
            const auto add = [&](int r, int c, const Eigen::Matrix3d& m) {
                for (int a = 0; a < 3; ++a)
                    for (int e = 0; e < 3; ++e) h.emplace_back(r + a, c + e, m(a, e));
            };
            for (const Link& l : b.links) {
                const Vector3d d = x[l.a] - x[l.b];
                const double len = d.norm(), k = double(l.stiffness);
                const Vector3d u = d / len, f = k * (len - double(l.rest)) * u;
                const Eigen::Matrix3d hl = k * u * u.transpose() + k * std::max(0.0, 1 - double(l.rest) / len) *
                                                                     (Eigen::Matrix3d::Identity() - u * u.transpose());
                const int da = dof[l.a], db = dof[l.b];
                if (da >= 0) grad.segment<3>(da) += f, add(da, da, hl);
                if (db >= 0) grad.segment<3>(db) -= f, add(db, db, hl);
                if (da >= 0 && db >= 0) add(da, db, -hl), add(db, da, -hl);
            }
            grad[ball] += mass * g;
            for (int i = 0; i < n; ++i) {
                const int di = dof[std::size_t(i)];
                if (di < 0) continue;
                grad[di + 1] += double(b.p.mass[std::size_t(i)]) * g;
                const Vector3d d = x[std::size_t(i)] - Vector3d(bx, y, bz);
                const double depth = radius - d.norm();
                if (depth <= 0) continue;
                const Vector3d nn = d.normalized();
                grad.segment<3>(di) -= kappa * depth * nn;
                grad[ball] += kappa * depth * nn.y();
                add(di, di, kappa * nn * nn.transpose());
                for (int a = 0; a < 3; ++a) {
                    h.emplace_back(di + a, ball, -kappa * nn[a] * nn.y());
                    h.emplace_back(ball, di + a, -kappa * nn[a] * nn.y());
                }
                h.emplace_back(ball, ball, kappa * nn.y() * nn.y());
            }
            gradient = grad.norm();
            if (gradient < 1e-6) break;
            for (int i = 0; i < n; ++i)
                for (int a = 0; a < 3 && dof[std::size_t(i)] >= 0; ++a)
                    h.emplace_back(dof[std::size_t(i)] + a, dof[std::size_t(i)] + a, mu * double(b.p.mass[std::size_t(i)]) * 1e4);
            h.emplace_back(ball, ball, mu * mass * 1e4);
            Eigen::SparseMatrix<double> a(dofs, dofs);
            a.setFromTriplets(h.begin(), h.end());
            Eigen::VectorXd step = Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>>(a).solve(-grad);
            const double largest = step.cwiseAbs().maxCoeff();
            if (largest > 0.01) step *= 0.01 / largest;  // no step carries the ball through the cloth
            const double before = energy(x, y, kappa);
            double alpha = 1;
            bool moved = false;
            for (int tries = 0; tries < 30 && !moved; ++tries, alpha *= 0.5) {
                std::vector<Vector3d> xn = x;
                for (int i = 0; i < n; ++i)
                    if (dof[std::size_t(i)] >= 0) xn[std::size_t(i)] += alpha * step.segment<3>(dof[std::size_t(i)]);
                const double yn = y + alpha * step[ball];
                if (energy(xn, yn, kappa) < before) x = std::move(xn), y = yn, moved = true;
            }
            if (!moved) break;
            mu = alpha == 0.5 ? std::max(mu * 0.5, 1e-9) : mu * 2;  // the full step taken: trust the model more
        }
    }
    return y;
}

// The sink depth (m, below the pinned corners' plane) the static solve gives the ball of `d`'s trampoline
// where world `w` has it (its x and z held), and the ball's own in `w`.
double trampoline_static_sink(const World& w, const SceneDesc& d, BodyId ball) {
    const Vec3 at = w.rigid().transform(ball).p;
    const SoftBody& cloth = w.soft().body(w.soft().bodies()[0]);
    double gradient = 1;
    const double y = trampoline_static_rest(cloth, d.soft_bodies[0].def.positions, double(at.x()), double(at.z()),
                                            double(w.rigid().mass(ball)), 0.2 + double(cloth.def.thickness), gradient);
    REQUIRE(gradient < 1e-6);
    return 1 - (y - 0.2);
}
double trampoline_sink(const World& w, BodyId ball) { return 1 - (double(w.rigid().transform(ball).p.y()) - 0.2); }

}  // namespace

TEST_CASE("ball-on-trampoline: the ball comes to rest at the converged static solve's depth, its weight carried", "[coupling]") {
    // Two-way, 10 s: the ball settles where the cloth's springs, gravity and the contacts balance. The
    // static solve above puts it 0.2884-0.2889 m into the cloth (its bottom below the pinned corners'
    // plane, with the ball held where the run left it). Measured: soft step 0.2%, split impulses 0.4%,
    // Newton 0.5% deeper in float (0.8%, 0.4%, 0.4% in double); the issue asks for 2%. Over the last
    // second the contacts the cloth reports carry the ball's weight within 0.1%.
    const SceneDesc scene = parse_scene_file(scene_path("ball-on-trampoline.json"));
    for (RigidSolverKind solver : {RigidSolverKind::SoftStep, RigidSolverKind::SplitImpulse, RigidSolverKind::Newton}) {
        INFO(rigid_solver_name(solver));
        SceneDesc d = scene;
        d.settings.rigid.solver = solver;
        d.settings.rigid.sleeping = false;
        std::vector<BodyId> ids;
        auto w = build_world(d, &ids);
        double lift = 0;
        for (int k = 0; k < 600; ++k) {
            w->step();
            if (k < 540) continue;
            for (const CouplingImpulse& c : w->coupling().impulses()) lift += double(c.impulse.y());
        }
        const double weight = 9.81 * double(w->rigid().mass(ids[1]));
        CHECK(lift == Approx(weight).epsilon(0.01));  // 60 steps' impulses over one second
        const double static_sink_depth = trampoline_static_sink(*w, d, ids[1]);
        CHECK(static_sink_depth == Approx(0.2888).epsilon(0.002));
        CHECK(trampoline_sink(*w, ids[1]) == Approx(static_sink_depth).epsilon(0.02));
    }
}

TEST_CASE("ball-on-trampoline: a frictionless ball takes no spin from the cloth and sleeps on it", "[coupling]") {
    // Without friction a contact pushes a sphere through its centre: its spin must stay zero. The rows
    // and the implicit solve's ties take the sphere's normal where the particle is at the start of the
    // step (round_body_normal); with the normal found at the predicted positions the ball spun up to 0.4
    // rad/s in 10 s and 3.5 in 20 s, and never slept. Measured in float: 2.7e-3 rad/s at most (what is
    // left comes from the contact pass's pushes, still along the found normal), asleep within 6 s with
    // the cloth; the bound is four times that, forty times under the old spin at 10 s.
    SceneDesc d = parse_scene_file(scene_path("ball-on-trampoline.json"));
    d.bodies[1].def.material.friction = 0;
    d.soft_bodies[0].def.friction = 0;
    std::vector<BodyId> ids;
    auto w = build_world(d, &ids);
    Real spin = 0;
    for (int k = 0; k < 720; ++k) {
        w->step();
        spin = std::max(spin, w->rigid().angular_velocity(ids[1]).norm());
    }
    CHECK(spin < Real(0.01));
    CHECK_FALSE(w->rigid().awake(ids[1]));
    CHECK_FALSE(w->soft().awake(w->soft().bodies()[0]));
    // Asleep where it rests: at the static solve's depth within the issue's 2% (float 0.12% above it,
    // double 1.7% below: it fell asleep with the cloth still settling by millimetres).
    CHECK(trampoline_sink(*w, ids[1]) == Approx(trampoline_static_sink(*w, d, ids[1])).epsilon(0.02));
}

TEST_CASE("ball-on-trampoline: the ball with friction comes to rest in the cloth and sleeps under every rigid solver", "[coupling]") {
    // Issue 15: a rigid body resting on a soft body must be able to sleep. The scene as it is (friction
    // 0.5, sleeping on). The ball is tied to the particles under it inside the cloth's implicit solve
    // (soft/implicit_euler.cpp, "Rigid bodies in the solve"), sliding ties under kinetic friction until
    // they stop (coupling/coupling_layer.cpp); with independent mass shares and friction switching off
    // every other step it rocked at 1-3 cm/s and never slept. Measured: asleep, ball and cloth, after
    // 7.1 s (soft step), 10.2 s (split impulses), 9.8 s (Newton) in float, 9.6, 9.9 and 7.2 s in double
    // (the times move by seconds with any change to the contacts: the bound is 15 s). Asleep where the
    // converged static solve puts it, within the issue's 2% (measured within 1.0% in float, 0.3% in double).
    const SceneDesc scene = parse_scene_file(scene_path("ball-on-trampoline.json"));
    for (RigidSolverKind solver : {RigidSolverKind::SoftStep, RigidSolverKind::SplitImpulse, RigidSolverKind::Newton}) {
        INFO(rigid_solver_name(solver));
        SceneDesc d = scene;
        d.settings.rigid.solver = solver;
        std::vector<BodyId> ids;
        auto w = build_world(d, &ids);
        int asleep_at = -1;
        for (int k = 0; k < 900 && asleep_at < 0; ++k) {
            w->step();
            if (!w->rigid().awake(ids[1]) && !w->soft().awake(w->soft().bodies()[0])) asleep_at = k;
        }
        CHECK(asleep_at >= 0);
        const Vec3 at = w->rigid().transform(ids[1]).p;
        for (int k = 0; k < 60; ++k) w->step();
        CHECK(w->rigid().transform(ids[1]).p == at);  // stays asleep where it fell asleep
        CHECK(trampoline_sink(*w, ids[1]) == Approx(trampoline_static_sink(*w, d, ids[1])).epsilon(0.02));
    }
}

TEST_CASE("coupling settings: bad input is refused with the field named, nothing changed", "[coupling][errors]") {
    const auto load_error = [](const std::string& coupling) {
        const std::string text = R"({"format": "sinew-scene", "version": 1,
          "bodies": [{"name": "box", "shape": {"type": "box", "half_extents": [0.3, 0.3, 0.3]}}],
          "soft_bodies": [{"name": "rope", "builder": "rope", "from": [0, 2, 0], "to": [1, 2, 0], "segments": 4}],
          "coupling": )" + coupling + "}";
        try {
            parse_scene_string(text, "bad-coupling");
        } catch (const SceneError& e) {
            return e.json_path + ": " + e.problem;
        }
        return std::string("no error");
    };
    CHECK_THAT(load_error(R"({"strategy": "three-way"})"), Catch::Contains("/coupling/strategy") && Catch::Contains("three-way"));
    CHECK_THAT(load_error(R"({"gain": -1})"), Catch::Contains("/coupling/gain"));
    CHECK_THAT(load_error(R"({"exchange_iterations": 0})"), Catch::Contains("/coupling/exchange_iterations"));
    CHECK_THAT(load_error(R"({"pairs": [{"soft": "cloth", "strategy": "two-way"}]})"),
               Catch::Contains("/coupling/pairs/0/soft") && Catch::Contains("cloth"));
    CHECK_THAT(load_error(R"({"pairs": [{"soft": "rope", "rigid": "crate", "strategy": "two-way"}]})"),
               Catch::Contains("/coupling/pairs/0/rigid") && Catch::Contains("crate"));
    CHECK_THAT(load_error(R"({"pairs": [{"soft": "rope"}]})"), Catch::Contains("strategy"));
    CHECK_THAT(load_error(R"({"sub_steps": 2})"), Catch::Contains("sub_steps"));
    CHECK(load_error(R"([])") == "no error");  // files from before the section existed

    // Through the world: a pair naming a destroyed soft body.
    World w;
    SoftBodyDef def;
    def.positions = {Vec3(0, 1, 0), Vec3(1, 1, 0)};
    def.masses = {1, 1};
    const SoftBodyId gone = w.soft().create_body(def);
    w.soft().destroy_body(gone);
    CouplingSettings s;
    s.strategy = CouplingStrategy::TwoWay;
    s.pairs.push_back({gone, BodyId{}, CouplingStrategy::Hybrid});
    CHECK_THROWS_WITH(w.set_coupling(s), Catch::Contains("pair 0") && Catch::Contains("does not exist"));
    CHECK(w.coupling().settings().strategy == CouplingStrategy::OneWay);
    s.pairs.clear();
    s.gain = Real(1.5);
    CHECK_THROWS_WITH(w.set_coupling(s), Catch::Contains("gain"));
    CHECK(w.coupling().settings().strategy == CouplingStrategy::OneWay);
}

TEST_CASE("a per-pair strategy overrides the world's, and scenes save and reload it", "[coupling]") {
    SceneDesc d = parse_scene_string(R"({"format": "sinew-scene", "version": 1,
      "bodies": [{"name": "a", "shape": {"type": "sphere", "radius": 0.2}}, {"name": "b", "shape": {"type": "sphere", "radius": 0.2}, "position": [2, 0, 0]}],
      "soft_bodies": [{"name": "rope", "builder": "rope", "from": [0, 2, 0], "to": [1, 2, 0], "segments": 4}],
      "coupling": {"strategy": "hybrid", "gain": 0.5, "pairs": [{"soft": "rope", "strategy": "one-way"},
                                                                  {"soft": "rope", "rigid": "b", "strategy": "two-way"}]}})",
                                     "pairs");
    std::vector<BodyId> ids;
    auto w = build_world(d, &ids);
    const SoftBodyId rope = w->soft().bodies()[0];
    CHECK(w->coupling().strategy(rope, ids[0]) == CouplingStrategy::OneWay);  // the pair naming no rigid body
    CHECK(w->coupling().strategy(rope, ids[1]) == CouplingStrategy::TwoWay);  // the exact pair wins
    const std::string text = scene_to_json_text(*w, "pairs-saved");
    auto again = build_world(parse_scene_string(text, "pairs-saved"));
    const CouplingSettings& s = again->coupling().settings();
    CHECK(s.strategy == CouplingStrategy::Hybrid);
    CHECK(s.gain == Real(0.5));
    REQUIRE(s.pairs.size() == 2);
    CHECK(again->coupling().strategy(again->soft().bodies()[0], again->rigid().bodies()[1]) == CouplingStrategy::TwoWay);
}

TEST_CASE("every coupling scene runs under every strategy", "[coupling]") {
    // The scenes of issue 15 in demos/scenes, each under every strategy, both embeddings included, for a
    // second: finite, and the strategy the run reports is the one asked for.
    for (const char* name : {"ball-on-trampoline", "box-on-soft-block", "basketball-net", "cloth-on-arm", "rope-tow"})
        for (int k = 0; k < int(CouplingStrategy::Count); ++k) {
            const CouplingStrategy s = CouplingStrategy(k);
            INFO(name << " under " << coupling_strategy_name(s));
            SceneDesc d = parse_scene_file(scene_path((std::string(name) + ".json").c_str()));
            d.coupling.settings.strategy = s;
            auto w = build_world(d);
            for (int k = 0; k < 60; ++k) w->step();
            CHECK(w->coupling().settings().strategy == s);
            CHECK(w->rigid().all_finite());
            CHECK(w->soft().all_finite());
        }
}

TEST_CASE("interleaved coupling: wrong at a 1:1 mass ratio, agrees with two-way at 1:1000", "[coupling]") {
    // A 0.5 kg cloth at 3 m/s strikes a free box, no gravity. Interleaved, the cloth steps against the box
    // where its previous motion takes it (at rest) and stops dead; the box gets the cloth's force a step
    // later. Both strategies exchange equal and opposite impulses, so the total is kept either way; what
    // differs is how it is shared (seed 001 ch.4 §1: interleaving works best at a large mass disparity).
    const auto box_momentum = [](const char* strategy, double box_mass) {
        // Centred: a 0.5 m cloth square on the face of a 0.6 m cube, so all of it strikes the face.
        const std::string text = std::string(R"({"format": "sinew-scene", "version": 1,
          "settings": {"gravity": [0, 0, 0], "sleeping": {"enabled": false}},
          "bodies": [{"name": "box", "shape": {"type": "box", "half_extents": [0.3, 0.3, 0.3]}, "mass": )") +
                                 std::to_string(box_mass) + R"(, "material": {"friction": 0.4}}],
          "soft_bodies": [{"name": "cloth", "builder": "cloth", "nodes": [7, 7], "origin": [-0.25, -0.25, 0.6],
                      "edge_u": [0.5, 0, 0], "edge_v": [0, 0.5, 0], "mass": 0.5, "method": "implicit",
                      "links": {"stretch": 2000, "shear": 200, "damping": 1}, "velocity": [0, 0, -3],
                      "material": {"friction": 0.4, "thickness": 0.02}}],
          "coupling": {"strategy": ")" + strategy + R"("}})";
        auto w = build_world(parse_scene_string(text, "interleaved"));
        for (int s = 0; s < 60; ++s) w->step();
        const BodyId box = w->rigid().bodies()[0];
        return -double(w->rigid().mass(box) * w->rigid().linear_velocity(box).z());
    };
    const double p0 = 1.5;  // the cloth's momentum, N s
    // 1:1: two-way shares it (measured 0.92 N s to the box); interleaved gives the box all of it.
    const double two_1 = box_momentum("two-way", 0.5), inter_1 = box_momentum("interleaved", 0.5);
    CHECK(two_1 < 0.8 * p0);
    CHECK(inter_1 == Approx(p0).epsilon(1e-3));
    CHECK(std::abs(inter_1 - two_1) > 0.3 * p0);
    // 1:1000: the box takes (nearly) all of it under both. A perfectly inelastic strike leaves the cloth on
    // the box at the common velocity, with m/(M+m) = 1e-3 of the momentum, which interleaving, where the
    // cloth stops dead, gives the box as well; so they agree within twice that (the cloth still settling
    // against the box after 1 s): measured 1.4e-3 (two-way's box 1.49795 N s, the inelastic answer 1.49850).
    const double two_k = box_momentum("two-way", 500), inter_k = box_momentum("interleaved", 500);
    CHECK(std::abs(inter_k - two_k) < 2e-3 * p0);
    CHECK(two_k == Approx(p0 * 500 / 500.5).epsilon(2e-3));
}

namespace {

struct TowRun {
    bool finite = true;
    double crate_moved = 0;     ///< m, along the tow
    double max_span = 0;        ///< largest distance between the rope's two attached ends after the first step (m)
    double max_length = 0;      ///< largest length of the rope's polyline after the first step (m)
};

// demos/scenes/rope-tow.json with the crate's mass set (the rope is 0.1 kg), run for 10 s: the
// tractor drives 5 m.
TowRun tow(double crate_mass, CouplingStrategy strategy) {
    SceneDesc d = parse_scene_file(scene_path("rope-tow.json"));
    for (SceneBody& b : d.bodies)
        if (b.name == "crate") b.def.mass = Real(crate_mass);
    d.coupling.settings.strategy = strategy;
    auto w = build_world(d);
    const BodyId crate = w->rigid().bodies()[1];
    const SoftBodyId rope = w->soft().bodies()[0];
    const double x0 = w->rigid().transform(crate).p.x();
    TowRun r;
    for (int s = 0; s < 600 && r.finite; ++s) {
        w->step();
        r.finite = w->faults().empty() && w->rigid().all_finite() && w->soft().all_finite();
        const Particles& p = w->soft().body(rope).p;
        double length = 0;
        for (std::size_t i = 1; i < p.size(); ++i) length += double((p.x[i] - p.x[i - 1]).norm());
        if (s == 0) continue;
        r.max_length = std::max(r.max_length, length);
        r.max_span = std::max(r.max_span, double((p.x[0] - p.x[p.size() - 1]).norm()));
    }
    r.crate_moved = w->rigid().transform(crate).p.x() - x0;
    return r;
}

}  // namespace

TEST_CASE("rope-tow: two-way attachments tow the crate at mass ratios 1:1 to 1:1000, the rope within 2%", "[coupling]") {
    // A 2 m rope (0.1 kg, springs of 1e6 N/m per 0.1 m segment) between a kinematic tractor driving 5 m
    // at 0.5 m/s and a crate on the ground (friction 0.3). Under two-way the attached end carries the
    // crate's inertia through the rope's implicit solve, so the crate follows at every ratio. The rope's
    // length: the static pull of the 100 kg crate (294 N) stretches it 0.3%, and the stick-slip of a
    // crate on an elastic rope adds v/omega = 0.5 / sqrt(5e4 / 100) = 2.2 cm (1.1%): the converged run
    // (h/4) reaches 1.5% in both measures; h = 1/60 1.4% in the span between the ends and 1.7% in the
    // polyline's length (the slack rope's first link snapping taut) (measured); 2% is the issue's bound.
    for (double mass : {0.1, 10.0, 100.0}) {
        INFO("crate " << mass << " kg");
        const TowRun r = tow(mass, CouplingStrategy::TwoWay);
        REQUIRE(r.finite);
        CHECK(r.max_length < 1.02 * 2.0);
        CHECK(r.max_span < 1.02 * 2.0);
        CHECK(r.crate_moved > 5.0 - 0.02 * 2.0);  // it may slide ahead on a slack rope, never lag further
    }
    // One-way: nothing the rope does reaches the crate; the rope stretches behind the tractor.
    const TowRun one = tow(100, CouplingStrategy::OneWay);
    CHECK(std::abs(one.crate_moved) < 1e-3);
    CHECK(one.max_span > 2.0 + 4.5);
    // Embedding's known failure (seed 001 ch.4 §2: it cannot send the passive system's extra forces back
    // to the primary): embedded, the rope is a rigid proxy in the rigid solver, but its pull on the crate
    // goes through an attachment, not a contact or joint of the proxy, so it never reaches the crate,
    // which stays as under one-way while the rope stretches behind the tractor (its proxy, kinematic
    // since the rope is attached, does not collide with what it is tied to).
    const TowRun embedded = tow(100, CouplingStrategy::EmbedRigid);
    REQUIRE(embedded.finite);
    CHECK(std::abs(embedded.crate_moved) < 1e-3);
    CHECK(embedded.max_span > 2.0 + 4.5);
    // Hybrid and interleaved send the attachment's reaction explicitly (after the solve, or as a force
    // over the next step): they tow the heavy crate as two-way does, and diverge on the light one, where
    // the rope's stiffness over the crate's mass, h^2 k / M = 5e4 / 3600 / 10 = 1.4, passes their
    // stability limit (seed 001 ch.4 §1: interleaving is for large mass disparities).
    for (CouplingStrategy s : {CouplingStrategy::Hybrid, CouplingStrategy::Interleaved}) {
        INFO(coupling_strategy_name(s));
        const TowRun heavy = tow(100, s);
        REQUIRE(heavy.finite);
        CHECK(heavy.max_span < 1.02 * 2.0);
        CHECK(heavy.crate_moved > 5.0 - 0.02 * 2.0);
        const TowRun light = tow(10, s);
        CHECK((!light.finite || light.max_span > 4.0));
    }
}

TEST_CASE("one-solver: a cloth swept in the rigid solver hangs where implicit Euler's converged solve hangs it", "[coupling]") {
    // A 2 m, 0.5 kg cloth of 10 x 10 nodes (4000 N/m) pinned at its corners, no rigid body near: under
    // one-solver its springs are swept particle by particle inside the rigid solver's passes (block
    // Gauss-Seidel on the same linearised implicit Euler system the implicit method solves by CG, here
    // converged: 400 iterations at 1e-6). A resting state is a fixed point of the sweep (it starts from
    // the last motion), so once the swing has died out both hang alike: measured identical to 0.1 mm under
    // split impulses and the Newtonian solver; the soft step, whose four sub-steps get two sweeps each,
    // still moves at 3 cm/s after 5 s and hangs 0.5 mm higher. Bounds: 1 mm and 3 mm.
    const auto hang = [](const char* strategy, const char* solver) {
        const std::string text = std::string(R"({"format": "sinew-scene", "version": 1,
          "settings": {"sleeping": {"enabled": false}, "solver": {"kind": ")") + solver + R"("}},
          "soft_bodies": [{"name": "c", "builder": "cloth", "nodes": [10, 10], "origin": [-1, 1, -1],
             "edge_u": [2, 0, 0], "edge_v": [0, 0, 2], "shear": true, "bend": false, "mass": 0.5,
             "method": "implicit", "pinned_nodes": [[0, 0], [9, 0], [0, 9], [9, 9]],
             "links": {"stretch": 4000, "shear": 400, "damping": 2}, "solver": {"iterations": 400, "cg_tolerance": 1e-6}}],
          "coupling": {"strategy": ")" + strategy + R"("}})";
        auto w = build_world(parse_scene_string(text, "hanging-cloth"));
        for (int s = 0; s < 300; ++s) w->step();
        const Particles& p = w->soft().body(w->soft().bodies()[0]).p;
        double low = 1e9;
        for (const Vec3& x : p.x) low = std::min(low, double(x.y()));
        return low;
    };
    const double reference = hang("two-way", "split_impulse");
    CHECK(reference == Approx(0.8724).margin(2e-3));  // 13 cm of sag, as measured
    CHECK(hang("one-solver", "split_impulse") == Approx(reference).margin(1e-3));
    CHECK(hang("one-solver", "newton") == Approx(reference).margin(1e-3));
    CHECK(hang("one-solver", "soft_step") == Approx(reference).margin(3e-3));
}

TEST_CASE("one-solver: the trampoline holds the ball in the rigid solver's loop", "[coupling]") {
    // A 1 kg ball on 0.9 g particles: the particles touching it carry shares of its mass (and across the
    // normal of its point inertia) in their blocks of the sweep. With the contact rows alone the ball
    // went through to the ground under every solver. Measured after 5 s: in the cloth at 0.88-0.93 m
    // (two-way rests at 0.909), spinning at most 0.7 rad/s.
    for (RigidSolverKind solver : {RigidSolverKind::SoftStep, RigidSolverKind::SplitImpulse}) {
        INFO(rigid_solver_name(solver));
        SceneDesc d = parse_scene_file(scene_path("ball-on-trampoline.json"));
        d.coupling.settings.strategy = CouplingStrategy::OneSolver;
        d.settings.rigid.solver = solver;
        std::vector<BodyId> ids;
        auto w = build_world(d, &ids);
        for (int k = 0; k < 300; ++k) w->step();
        REQUIRE(w->rigid().all_finite());
        const double y = w->rigid().transform(ids[1]).p.y();
        CHECK(y > 0.7);
        CHECK(y < 1.2);
        CHECK(w->rigid().angular_velocity(ids[1]).norm() < 2);
    }
}

TEST_CASE("one-solver: the rope tows the heavy crate in the rigid solver's loop, the light one diverges", "[coupling]") {
    // The rope's attached end carries the crate's point inertia in its block of the sweep. At 1:1000 the
    // crate follows within the issue's 2% (measured 1.6%); at 1:1 the rope-crate mode (omega = 707 rad/s,
    // h omega = 12) converges too slowly for the solver's passes and the step diverges: the known failure
    // of one iterative solver at large stiffness over mass, which two-way's implicit solve does not have.
    const TowRun heavy = tow(100, CouplingStrategy::OneSolver);
    REQUIRE(heavy.finite);
    CHECK(heavy.max_span < 1.02 * 2.0);
    CHECK(heavy.crate_moved > 5.0 - 0.02 * 2.0);
    const TowRun light = tow(0.1, CouplingStrategy::OneSolver);
    CHECK((!light.finite || light.max_span > 4.0));
}

TEST_CASE("bodies destroyed between steps leave every strategy's layer valid", "[coupling][errors]") {
    for (CouplingStrategy s : {CouplingStrategy::TwoWay, CouplingStrategy::Hybrid, CouplingStrategy::Interleaved,
                              CouplingStrategy::OneSolver}) {
        INFO(coupling_strategy_name(s));
        SceneDesc d = parse_scene_file(scene_path("ball-on-trampoline.json"));
        d.coupling.settings.strategy = s;
        std::vector<BodyId> ids;
        auto w = build_world(d, &ids);
        for (int k = 0; k < 40; ++k) w->step();  // the ball is in the cloth: rows, ties, forces pending
        w->rigid().destroy_body(ids[1]);
        for (int k = 0; k < 5; ++k) w->step();
        w->soft().destroy_body(w->soft().bodies()[0]);
        for (int k = 0; k < 5; ++k) w->step();
        CHECK(w->rigid().all_finite());
        CHECK(w->coupling().impulses().empty());
    }
}

TEST_CASE("one-way sub-stepping: k soft steps per rigid step match the whole world at h/k", "[coupling]") {
    // cloth-on-arm: a cloth on a kinematic arm turning at a constant rate. With 4 soft sub-steps per
    // 1/60 s step the cloth meets the arm at poses interpolated over the step (slerp: exact for a
    // constant angular velocity), so it takes the same soft steps as a world stepped at 1/240 s whole:
    // only rounding separates them (measured: identical after 0.1 s, 2e-5 m after 0.5 s), while the
    // cloth stepped at 1/60 s without sub-steps ends 0.4 m away. 1e-3 m leaves room for rounding.
    const auto cloth_after = [](int substeps, int divide) {
        SceneDesc d = parse_scene_file(scene_path("cloth-on-arm.json"));
        d.coupling.settings.substeps = substeps;
        d.settings.time_step /= Real(divide);
        d.settings.rigid.sleeping = false;
        d.settings.soft.sleeping = false;
        auto w = build_world(d);
        const int steps = int(Real(0.5) / d.settings.time_step + Real(0.5));
        for (int s = 0; s < steps; ++s) w->step();
        return w->soft().body(w->soft().bodies()[0]).p.x;
    };
    const std::vector<Vec3> sub = cloth_after(4, 1), fine = cloth_after(1, 4), coarse = cloth_after(1, 1);
    Real to_fine = 0, to_coarse = 0;
    for (std::size_t i = 0; i < sub.size(); ++i) {
        to_fine = std::max(to_fine, (sub[i] - fine[i]).norm());
        to_coarse = std::max(to_coarse, (sub[i] - coarse[i]).norm());
    }
    CHECK(to_fine < Real(1e-3));
    CHECK(to_coarse > Real(0.05));

    // Sub-steps are for one-way and hybrid: with another strategy they are refused, naming the key.
    const std::string text = R"({"format": "sinew-scene", "version": 1,
      "soft_bodies": [{"name": "rope", "builder": "rope", "from": [0, 2, 0], "to": [1, 2, 0], "segments": 4}],
      "coupling": {"strategy": "two-way", "substeps": 4}})";
    CHECK_THROWS_WITH(parse_scene_string(text, "substeps"), Catch::Contains("/coupling/substeps") && Catch::Contains("one-way"));
    World w;
    CouplingSettings s;
    s.substeps = 0;
    CHECK_THROWS_WITH(w.set_coupling(s), Catch::Contains("substeps"));
    s.substeps = 3;
    s.strategy = CouplingStrategy::Interleaved;
    CHECK_THROWS_WITH(w.set_coupling(s), Catch::Contains("one-way or hybrid"));
    CHECK(w.coupling().settings().substeps == 1);
    CHECK(w.soft().substeps() == 1);
}

TEST_CASE("hybrid coupling at gain 1 exchanges momentum, at the soft system's own rate too", "[coupling]") {
    // The thrown cloth again, hybrid: the box takes the opposite of what the soft contacts gave the
    // particles, after the first sub-step at once, after the others in the next step. Measured: 9e-5 of
    // the 1.5 N s without sub-steps, 2.5e-5 with 4 (implicit cloth; Verlet 1e-6 and 2e-5); 2e-4 allowed.
    for (int substeps : {1, 4}) {
        INFO(substeps << " soft sub-steps");
        SceneDesc d = parse_scene_string(thrown_cloth_scene("hybrid", "implicit"), "hybrid");
        d.coupling.settings.substeps = substeps;
        auto w = build_world(d);
        const Vec3 p0 = total_momentum(*w);
        for (int s = 0; s < 60; ++s) w->step();
        CHECK((total_momentum(*w) - p0).norm() <= Real(2e-4) * p0.norm());
        CHECK(-w->rigid().linear_velocity(w->rigid().bodies()[0]).z() > Real(0.2));
    }
}

TEST_CASE("a rigid body resting on a soft body under two-way coupling falls asleep, and so does the soft body", "[coupling]") {
    // box-on-soft-block with sleeping on (the scene's default): once both are still, both sleep, and the
    // box stays where the block carried it. Measured in float: asleep within 0.65 s under every case here.
    // With the box's mass split into independent shares, the soft step with friction kept it trembling
    // (1e-2 m/s, 0.1 rad/s in double) and it did not sleep.
    struct Case {
        RigidSolverKind solver;
        Real friction;
    };
    for (const Case c : {Case{RigidSolverKind::SplitImpulse, Real(0.5)}, Case{RigidSolverKind::SoftStep, Real(0)},
                         Case{RigidSolverKind::SoftStep, Real(0.5)}, Case{RigidSolverKind::Newton, Real(0.5)}}) {
        INFO(rigid_solver_name(c.solver) << ", friction " << c.friction);
        SceneDesc d = parse_scene_file(scene_path("box-on-soft-block.json"));
        d.settings.rigid.solver = c.solver;
        d.bodies[1].def.material.friction = c.friction;
        std::vector<BodyId> ids;
        auto w = build_world(d, &ids);
        for (int k = 0; k < 120; ++k) w->step();
        CHECK_FALSE(w->rigid().awake(ids[1]));
        CHECK_FALSE(w->soft().awake(w->soft().bodies()[0]));
        const Real y = w->rigid().transform(ids[1]).p.y();
        CHECK(y == Approx(0.608).margin(0.002));  // the block's top at 0.4 less 2.4 mm, the particle radius, the half size
        for (int k = 0; k < 60; ++k) w->step();
        CHECK(w->rigid().transform(ids[1]).p.y() == y);
    }
}

namespace {

// The thrown-cloth scene under `strategy` with the box's mass `box_mass`, tolerance `tolerance`.
std::unique_ptr<World> thrown_cloth(const char* strategy, Real box_mass, Real tolerance, const char* method = "verlet") {
    SceneDesc d = parse_scene_string(thrown_cloth_scene(strategy, method), "thrown-cloth");
    d.bodies[0].def.mass = box_mass;
    d.coupling.settings.tolerance = tolerance;
    return build_world(d);
}

/// Largest distance over 60 steps between the box centres of two runs, and between their cloth nodes
/// (RMS over the nodes at each step).
void run_apart(World& a, World& b, Real& box_apart, Real& nodes_apart) {
    box_apart = nodes_apart = 0;
    const BodyId box_a = a.rigid().bodies()[0], box_b = b.rigid().bodies()[0];
    for (int s = 0; s < 60; ++s) {
        a.step();
        b.step();
        box_apart = std::max(box_apart, (a.rigid().state().x[box_a.index] - b.rigid().state().x[box_b.index]).norm());
        const Particles& pa = a.soft().body(a.soft().bodies()[0]).p;
        const Particles& pb = b.soft().body(b.soft().bodies()[0]).p;
        Real sum = 0;
        for (std::size_t i = 0; i < pa.size(); ++i) sum += (pa.x[i] - pb.x[i]).squaredNorm();
        nodes_apart = std::max(nodes_apart, std::sqrt(sum / Real(pa.size())));
    }
}

}  // namespace

// Issue 11 item 4, rule 4 of coupling/strategy_picker.hpp: a free soft body's push on a rigid body is its
// share of the momentum, m_s / (m_s + m_r), of their relative motion; its own nodes also move unlike
// two-way's, since one-way's contacts act after the soft solve (a quarter of its size at most). The 0.5 kg
// Verlet cloth thrown at 3 m/s at a 1000 kg box (share 5e-4): one-way's error is predicted at a quarter
// of the cloth's 0.91 m size, within a 0.3 m tolerance, and auto picks one-way; the box then moves within
// 2 mm of two-way's (5e-4 x (0.91 m + 3 m)) and the nodes within the prediction. At 2 kg (share 0.2) the
// prediction is 0.77 m: auto picks two-way, and one-way's box is indeed far off.
TEST_CASE("auto coupling: a light free cloth against a heavy box is one-way within its predicted error", "[coupling][auto]") {
    const auto pick_of = [](const World& w) {
        REQUIRE(w.coupling().picks().size() == 1);
        return w.coupling().picks()[0];
    };
    {
        auto heavy = thrown_cloth("auto", 1000, Real(0.3));
        const StrategyPick p = pick_of(*heavy);
        CHECK(p.strategy == CouplingStrategy::OneWay);
        CHECK(p.one_way_error == Approx(0.906 / 4).epsilon(0.02));  // its box: 0.6 x 0.6 m plus 2 cm all round
        auto two_way = thrown_cloth("two-way", 1000, Real(0.3));
        Real box_apart = 0, nodes_apart = 0;
        run_apart(*heavy, *two_way, box_apart, nodes_apart);
        INFO("box " << box_apart << " m, nodes " << nodes_apart << " m, predicted " << p.one_way_error << " m");
        CHECK(box_apart <= Real(5e-4 * (0.906 + 3)));
        CHECK(nodes_apart <= p.one_way_error);
        CHECK(box_apart > 0);  // the cloth does push the box under two-way
    }
    {
        auto light = thrown_cloth("auto", 2, Real(0.3));
        const StrategyPick p = pick_of(*light);
        CHECK(p.strategy == CouplingStrategy::TwoWay);
        CHECK(p.one_way_error > Real(0.5));
        auto one_way = thrown_cloth("one-way", 2, Real(0.3));
        Real box_apart = 0, nodes_apart = 0;
        run_apart(*one_way, *light, box_apart, nodes_apart);
        INFO("box " << box_apart << " m, nodes " << nodes_apart << " m");
        CHECK(box_apart > Real(0.05));  // the cloth's push, which one-way leaves out, moves the box
    }
}

TEST_CASE("auto coupling: picked again when a rigid body comes, kept in saved scenes, refused where it cannot act",
          "[coupling][auto]") {
    auto w = thrown_cloth("auto", 1000, Real(0.3));
    REQUIRE(w->coupling().picks().at(0).strategy == CouplingStrategy::OneWay);
    // A 2 kg ball in the cloth's way: at the next step's start the cloth is picked two-way.
    BodyDef ball;
    ball.shape = make_sphere(Real(0.1));
    ball.mass = 2;
    ball.pose.p = Vec3(-0.2, 0, Real(0.3));
    w->rigid().create_body(ball);
    w->step();
    const SoftBodyId cloth = w->soft().bodies()[0];
    CHECK(w->coupling().picks().at(0).strategy == CouplingStrategy::TwoWay);
    CHECK(w->coupling().strategy(cloth, w->rigid().bodies()[1]) == CouplingStrategy::TwoWay);
    CHECK(w->coupling().settings().strategy == CouplingStrategy::Auto);
    CHECK(w->coupling().effective_settings().strategy != CouplingStrategy::Auto);
    // The ball swapped for a static floor far below (as many bodies as before): one-way again.
    w->rigid().destroy_body(w->rigid().bodies()[1]);
    BodyDef floor;
    floor.type = BodyType::Static;
    floor.shape = make_box(Vec3(5, Real(0.1), 5));
    floor.pose.p = Vec3(0, -10, 0);
    w->rigid().create_body(floor);
    w->step();
    CHECK(w->coupling().picks().at(0).strategy == CouplingStrategy::OneWay);

    // Saved and loaded: still auto, with its tolerance.
    const std::string path = "auto-coupling-saved.json";
    save_scene_file(*w, path);
    const SceneDesc again = parse_scene_file(path);
    CHECK(again.coupling.settings.strategy == CouplingStrategy::Auto);
    CHECK(again.coupling.settings.tolerance == Approx(0.3));
    std::remove(path.c_str());

    // Refused: auto for one pair, auto with soft sub-steps, a tolerance out of range; nothing changes.
    CouplingSettings bad = w->coupling().settings();
    bad.pairs.push_back({cloth, BodyId{}, CouplingStrategy::Auto});
    CHECK_THROWS_WITH(w->set_coupling(bad), Catch::Contains("world strategy"));
    bad = w->coupling().settings();
    bad.substeps = 4;
    CHECK_THROWS_WITH(w->set_coupling(bad), Catch::Contains("auto"));
    bad = w->coupling().settings();
    bad.tolerance = 0;
    CHECK_THROWS_WITH(w->set_coupling(bad), Catch::Contains("tolerance"));
    CHECK(w->coupling().settings().tolerance == Approx(0.3));
    CHECK_THROWS_WITH(parse_scene_string(thrown_cloth_scene("auto", "implicit").insert(
                                             thrown_cloth_scene("auto", "implicit").size() - 2, ", \"tolerance\": -1"),
                                         "bad-tolerance"),
                      Catch::Contains("tolerance"));
}

// Rule 2: volumetric soft bodies one on another under gravity are embedded; one beside them is not, and
// meets their proxies two-way.
TEST_CASE("auto coupling: stacked FEM cubes are embedded, a cube beside them is not", "[coupling][auto]") {
    const auto cube = [](const char* name, Real x, Real y) {
        return std::string(R"({"name": ")") + name + R"(", "builder": "tet-box", "min_corner": [)" + std::to_string(x) +
               ", " + std::to_string(y) + R"(, 0], "size": [0.3, 0.3, 0.3], "cells": [2, 2, 2], "method": "implicit",
               "fem": {"young": 2e5, "poisson": 0.3, "density": 400}})";
    };
    const std::string text = R"({"format": "sinew-scene", "version": 1,
      "bodies": [{"name": "ground", "type": "static", "shape": {"type": "box", "half_extents": [3, 0.5, 3]}, "position": [0, -0.5, 0]}],
      "soft_bodies": [)" + cube("bottom", 0, 0) + ", " + cube("top", 0, Real(0.31)) + ", " + cube("beside", Real(0.6), 0) +
                             R"(], "coupling": {"strategy": "auto"}})";
    auto w = build_world(parse_scene_string(text, "stacked-cubes"));
    const std::vector<StrategyPick>& picks = w->coupling().picks();
    REQUIRE(picks.size() == 3);
    CHECK(picks[0].strategy == CouplingStrategy::EmbedRigid);
    CHECK(picks[1].strategy == CouplingStrategy::EmbedRigid);
    // Beside them: the embedded cubes are dynamic rigid bodies it could meet, and lying on the ground it
    // could stop them: two-way.
    CHECK(picks[2].strategy == CouplingStrategy::TwoWay);
    CHECK_THAT(picks[2].reason, Catch::Contains("proxy of soft body"));
    CHECK(w->coupling().embedding().count() == 2);
    for (int s = 0; s < 120; ++s) w->step();
    // Embedded, the top cube stands on the bottom one (it stays within 2 cm of where it was put).
    const Particles& top = w->soft().body(w->soft().bodies()[1]).p;
    Real lowest = top.x[0].y();
    for (const Vec3& x : top.x) lowest = std::min(lowest, x.y());
    CHECK(lowest > Real(0.29));
}
