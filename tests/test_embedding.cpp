// Embedding soft bodies into the rigid solver (strategy embed-rigid; coupling/rigid_embedding.hpp): the
// proxy's quantities against the sums over its nodes, impulses through the proxy against the nodes'
// momenta, and what embedding exists for: stacking, and joints on soft bodies.
#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <string>

#include "coupling/fem_embedding.hpp"
#include "coupling/rigid_proxy.hpp"
#include "soft/fem_elements.hpp"
#include "soft/soft_builders.hpp"
#include "soft/tet_mesh.hpp"
#include "rigid/joint_set.hpp"
#include "engine/world/scene.hpp"

using namespace sinew;

namespace {

std::string scene_path(const char* name) { return std::string(SINEW_SOURCE_DIR) + "/demos/scenes/" + name; }

/// Round-off of a sum of n terms in Real, relative: sqrt(n) ulps is typical, n the bound.
double round_off(std::size_t n) { return double(n) * std::numeric_limits<Real>::epsilon(); }

Vec3 node_momentum(const Particles& p) {
    Eigen::Vector3d m = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < p.size(); ++i) m += double(p.mass[i]) * p.v[i].cast<double>();
    return m.cast<Real>();
}

Vec3 node_com(const Particles& p) {
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    double m = 0;
    for (std::size_t i = 0; i < p.size(); ++i) {
        c += double(p.mass[i]) * p.x[i].cast<double>();
        m += p.mass[i];
    }
    return (c / m).cast<Real>();
}

Vec3 node_angular_momentum(const Particles& p, const Vec3& about) {
    Eigen::Vector3d l = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < p.size(); ++i)
        l += double(p.mass[i]) * (p.x[i] - about).cast<double>().cross(p.v[i].cast<double>());
    return l.cast<Real>();
}

/// A scene with one FEM cube (0.2 m, 2 x 2 x 2 cells) at `corner`, embedded, and a static frame.
std::string cube_scene(const Vec3& corner, const char* gravity, double young) {
    return std::string(R"({"format": "sinew-scene", "version": 1,
      "settings": {"gravity": )") + gravity + R"(, "sleeping": {"enabled": false}},
      "bodies": [{"name": "frame", "type": "static", "shape": {"type": "box", "half_extents": [0.05, 0.05, 0.05]},
                  "position": [0, 2, 0]}],
      "soft_bodies": [{"name": "cube", "builder": "tet-box", "min_corner": [)" +
           std::to_string(corner.x()) + ", " + std::to_string(corner.y()) + ", " + std::to_string(corner.z()) +
           R"(], "size": [0.2, 0.2, 0.2], "cells": [2, 2, 2], "method": "implicit",
                  "solver": {"iterations": 100, "cg_tolerance": 0.0001},
                  "fem": {"young": )" + std::to_string(young) + R"(, "poisson": 0.3, "density": 500, "rotation": "polar"},
                  "material": {"friction": 0.5, "thickness": 0.005}}],
      "coupling": {"strategy": "embed-rigid"}})";
}

}  // namespace

TEST_CASE("a rigid proxy's quantities are the sums over its nodes", "[embedding]") {
    // 50 nodes scattered over a 1 m box with masses 0.1 .. 1.1 kg and velocities up to 1 m/s (a fixed
    // linear congruential sequence): mass, centre of mass, Steiner inertia, momentum and angular
    // momentum against the textbook sums in double; the rotation against a known turn of the rest shape.
    std::uint32_t seed = 12345;
    const auto uniform = [&seed]() {
        seed = seed * 1664525u + 1013904223u;
        return Real(seed >> 8) / Real(1u << 24);
    };
    const std::size_t n = 50;
    std::vector<Vec3> rest(n), x(n), v(n);
    std::vector<Real> mass(n);
    for (std::size_t i = 0; i < n; ++i) {
        rest[i] = Vec3(uniform(), uniform(), uniform()) - Vec3::Constant(Real(0.5));
        v[i] = Vec3(uniform(), uniform(), uniform()) * 2 - Vec3::Ones();
        mass[i] = Real(0.1) + uniform();
    }
    const Mat3 turn = Eigen::AngleAxis<Real>(Real(0.7), Vec3(1, 2, 3).normalized()).toRotationMatrix();
    for (std::size_t i = 0; i < n; ++i) x[i] = turn * rest[i] + Vec3(1, 2, 3);
    const RigidProxyState st = measure_rigid_proxy(x, v, mass, rest);

    double m = 0;
    Eigen::Vector3d c = Eigen::Vector3d::Zero(), p = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < n; ++i) {
        m += mass[i];
        c += double(mass[i]) * x[i].cast<double>();
        p += double(mass[i]) * v[i].cast<double>();
    }
    c /= m;
    Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();
    Eigen::Vector3d l = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < n; ++i) {
        const Eigen::Vector3d r = x[i].cast<double>() - c;
        inertia += double(mass[i]) * (r.dot(r) * Eigen::Matrix3d::Identity() - r * r.transpose());
        l += double(mass[i]) * r.cross(v[i].cast<double>());
    }
    // The inputs are rounded to Real; the sums then differ by the round-off of n terms.
    const double tol = 4 * round_off(n);
    CHECK(std::abs(st.mass - m) <= tol * m);
    CHECK((st.com.cast<double>() - c).norm() <= tol * c.norm());
    CHECK((st.inertia.cast<double>() - inertia).norm() <= tol * inertia.norm());
    CHECK((st.momentum.cast<double>() - p).norm() <= tol * p.norm());
    CHECK((st.v.cast<double>() - p / m).norm() <= tol * p.norm() / m);
    CHECK((st.angular_momentum.cast<double>() - l).norm() <= tol * l.norm());
    CHECK((st.inertia.cast<double>() * st.w.cast<double>() - l).norm() <= 10 * tol * l.norm());
    CHECK_FALSE(st.regularised);
    // The rest shape turned by a known rotation: the polar decomposition finds it to round-off.
    CHECK((st.rotation - turn).norm() <= Real(100) * std::numeric_limits<Real>::epsilon());
}

TEST_CASE("an impulse on an embedded body's proxy changes its nodes' momenta by exactly that impulse", "[embedding]") {
    // A free FEM cube, no gravity, no contact. An impulse J at a point off the centre of mass, given to
    // the proxy between steps, reaches the nodes as the rigid field Δv + Δω × r: their total momentum
    // changes by J and their angular momentum about the centre of mass by r × J. One step later the
    // cube's own elastic forces, which conserve both (up to the stiffness-warped elements' ghost torque,
    // second order in the step's deformation), have acted too: round-off of a few hundred terms in Real.
    auto w = build_world(parse_scene_string(cube_scene(Vec3(-0.1, 0.5, -0.1), "[0, 0, 0]", 1e5), "impulse"));
    const SoftBodyId cube = w->soft().bodies()[0];
    const BodyId proxy = w->coupling().embedding().proxy(cube);
    REQUIRE_FALSE(proxy.is_null());
    CHECK(w->coupling().embedding().soft_of(proxy) == cube);
    const Particles& p = w->soft().body(cube).p;
    const Vec3 com = node_com(p);
    CHECK(w->rigid().mass(proxy) == Approx(0.2 * 0.2 * 0.2 * 500).epsilon(1e-5));
    const Vec3 j(Real(0.3), Real(-0.2), Real(0.5));
    const Vec3 at = com + Vec3(Real(0.1), Real(0.05), Real(-0.02));
    w->rigid().apply_impulse(proxy, j, at);
    w->step();
    const Vec3 dp = node_momentum(p);
    const Vec3 dl = node_angular_momentum(p, node_com(p)) + (node_com(p) - com).cross(dp);  // about the old centre
    const Vec3 expect_l = (at - com).cross(j);
    const double tol = 4 * round_off(p.size());
    CHECK((dp - j).norm() <= tol * j.norm() + 1e-6);
    CHECK((dl - expect_l).norm() <= 1e-3 * expect_l.norm());
    // And the proxy reports what its nodes do.
    CHECK((w->rigid().linear_velocity(proxy) * w->rigid().mass(proxy) - dp).norm() <= tol * j.norm() + 1e-6);
}

TEST_CASE("five embedded soft cubes stand stacked for 10 s, coupled two-way they fall through each other", "[embedding]") {
    // demos/scenes/stack-of-soft-cubes.json with sleeping off: five 10.8 kg FEM cubes, 1 cm apart.
    // Embedded, each is one proxy and the rigid solver stacks them: every centre of mass stays within
    // 2 cm (the issue's bound) of where it is after the first second's settling (measured: < 0.1 mm under
    // the soft step and Newtonian impulses, 5 mm under split impulses, 7 mm under Baumgarte). Under two-way
    // coupling the cubes meet each other through the soft-soft contacts, which act after each cube's own
    // implicit solve: a cube's weight reaches the one below a step late and the stack of five collapses
    // within a second, crushed on the ground (docs/soft-bodies.md, known failures).
    for (CouplingStrategy s : {CouplingStrategy::EmbedRigid, CouplingStrategy::TwoWay}) {
        INFO(coupling_strategy_name(s));
        SceneDesc d = parse_scene_file(scene_path("stack-of-soft-cubes.json"));
        d.coupling.settings.strategy = s;
        d.settings.rigid.sleeping = false;
        d.settings.soft.sleeping = false;
        auto w = build_world(d);
        const std::vector<SoftBodyId> cubes = w->soft().bodies();
        REQUIRE(cubes.size() == 5);
        std::vector<Vec3> settled;
        double drift = 0;
        for (int step = 0; step < 600; ++step) {
            w->step();
            if (step == 59)
                for (SoftBodyId c : cubes) settled.push_back(node_com(w->soft().body(c).p));
            if (step > 59)
                for (std::size_t k = 0; k < cubes.size(); ++k)
                    drift = std::max(drift, double((node_com(w->soft().body(cubes[k]).p) - settled[k]).norm()));
        }
        REQUIRE(w->soft().all_finite());
        const double top = node_com(w->soft().body(cubes[4]).p).y();
        INFO("drift " << drift << " m, top cube's centre at " << top << " m");
        if (s == CouplingStrategy::EmbedRigid) {
            CHECK(drift < 0.02);
            CHECK(top > 4 * 0.3);  // still the fifth cube up
        } else {
            CHECK(top < 0.3);  // on the ground with the others
        }
    }
}

TEST_CASE("an embedded stack sleeps with its proxies' rigid island and wakes when struck", "[embedding]") {
    // With sleeping on (the scene's default), the proxies' island falls asleep as a rigid stack does
    // (rigid sleep thresholds 0.05 m/s, 0.5 s), and the soft bodies sleep with it: no step of theirs
    // runs. A 5 kg ball dropped on the top cube wakes the island and the cubes with it.
    auto w = build_world(parse_scene_file(scene_path("stack-of-soft-cubes.json")));
    const std::vector<SoftBodyId> cubes = w->soft().bodies();
    for (int step = 0; step < 180; ++step) w->step();
    int awake = 0;
    for (SoftBodyId c : cubes) awake += w->soft().awake(c) ? 1 : 0;
    CHECK(awake == 0);
    BodyDef ball;
    ball.shape = make_sphere(Real(0.1));
    ball.mass = 5;
    ball.pose.p = Vec3(0, Real(1.8), 0);
    w->rigid().create_body(ball);
    bool woke = false;
    for (int step = 0; step < 60 && !woke; ++step) {
        w->step();
        woke = w->soft().awake(cubes[4]);
    }
    CHECK(woke);
    for (int step = 0; step < 120; ++step) w->step();
    REQUIRE(w->soft().all_finite());
    CHECK(node_com(w->soft().body(cubes[4]).p).y() > Real(4 * 0.3));  // the ball did not topple the stack
}

TEST_CASE("a soft bob on a hinge swings with the period of its proxy's inertia", "[embedding]") {
    // A stiff FEM cube (0.2 m, E = 1e7 Pa, 4 kg) hung from a static frame by a hinge 0.4 m above its
    // centre, let go 5 degrees out. A rigid compound pendulum of the proxy's mass and inertia swings with
    // T = 2 pi sqrt(I_pivot / (M g d)), I_pivot = I_c + M d^2 (the finite amplitude adds theta^2/16 =
    // 0.05%). The cube's own elasticity hardly changes its inertia (the strain from its weight is 1e-5):
    // the measured period over three swings is the compound pendulum's within 2% (the issue's bound).
    const Real d = Real(0.4), theta0 = Real(5 * M_PI / 180);
    const Vec3 pivot(0, 2, 0);
    const Vec3 centre = pivot + d * Vec3(std::sin(theta0), -std::cos(theta0), 0);
    // The cube is built axis-aligned at the displaced centre (a 5-degree tilt of the cube itself changes
    // I_pivot by nothing: the cube's inertia is isotropic).
    auto w = build_world(parse_scene_string(cube_scene(centre - Vec3::Constant(Real(0.1)), "[0, -9.81, 0]", 1e7), "bob"));
    const SoftBodyId cube = w->soft().bodies()[0];
    const BodyId proxy = w->coupling().embedding().proxy(cube);
    REQUIRE_FALSE(proxy.is_null());
    const BodyId frame = w->rigid().bodies()[0];
    JointDef hinge;
    hinge.type = JointType::Hinge;
    hinge.body_a = proxy;
    hinge.body_b = frame;
    hinge.local_anchor_a = w->rigid().transform(proxy).apply_inverse(pivot);
    hinge.local_anchor_b = w->rigid().transform(frame).apply_inverse(pivot);
    hinge.local_axis_a = Vec3::UnitZ();
    const JointId joint = w->rigid().create_joint(hinge);

    const Particles& p = w->soft().body(cube).p;
    const RigidProxyState st = measure_rigid_proxy(p.x, p.v, p.mass, p.x);
    const double arm = (st.com - pivot).norm();
    const double i_pivot = double(st.inertia(2, 2)) + double(st.mass) * arm * arm;
    const double expect = 2 * M_PI * std::sqrt(i_pivot / (double(st.mass) * 9.81 * arm));

    // Period from the times the centre crosses below the pivot moving in +x (linear interpolation).
    const double h = w->settings().time_step;
    std::vector<double> crossings;
    double prev = node_com(p).x() - pivot.x();
    double joint_error = 0;
    for (int step = 1; step <= int(4 * expect / h); ++step) {
        w->step();
        const double x = node_com(p).x() - pivot.x();
        if (prev < 0 && x >= 0) crossings.push_back((step - 1 + prev / (prev - x)) * h);
        prev = x;
        joint_error = std::max(joint_error, double(w->rigid().joints().position_error(joint, w->rigid())));
    }
    REQUIRE(crossings.size() >= 3);
    const double period = (crossings.back() - crossings.front()) / double(crossings.size() - 1);
    INFO("period " << period << " s, compound pendulum " << expect << " s, joint error " << joint_error << " m");
    CHECK(std::abs(period - expect) < 0.02 * expect);
    CHECK(joint_error < 1e-3);
}

TEST_CASE("the soft door hangs on two hinges of its proxy with joint error under 1 mm", "[embedding]") {
    // demos/scenes/soft-door.json: a 23 kg FEM slab on two hinges about the vertical line of its left edge
    // (redundant rows, as real doors have), struck by a 4 kg ball at 6 m/s, which it slows to 0.6 m/s
    // while it swings open. Each hinge keeps its anchors within 1 mm (the issue's bound) while the door
    // hangs and takes the blow (measured: 66 um). At 2.7 s the door, swung past 90 degrees, strikes the
    // ball again, and the soft step's soft joint rows give way 1.5 mm for a step (measured) before they
    // pull back: asserted below 2 mm.
    auto w = build_world(parse_scene_file(scene_path("soft-door.json")));
    const SoftBodyId door = w->soft().bodies()[0];
    REQUIRE_FALSE(w->coupling().embedding().proxy(door).is_null());
    const std::vector<JointId> hinges = w->rigid().joints().ids();
    REQUIRE(hinges.size() == 2);
    const BodyId ball = w->rigid().bodies()[4];
    double error = 0, late_error = 0, opened = 0;
    for (int step = 0; step < 180; ++step) {
        w->step();
        for (JointId j : hinges) {
            const double e = w->rigid().joints().position_error(j, w->rigid());
            (step < 150 ? error : late_error) = std::max(step < 150 ? error : late_error, e);
        }
        opened = std::min(opened, double(node_com(w->soft().body(door).p).z()));
        if (step == 30) CHECK(std::abs(w->rigid().linear_velocity(ball).z()) < Real(1));  // the door took the blow
    }
    REQUIRE(w->soft().all_finite());
    INFO("largest hinge error " << error << " m (then " << late_error << " m), centre swung to z = " << opened << " m");
    CHECK(error < 1e-3);
    CHECK(late_error < 2e-3);
    CHECK(opened < -0.1);  // it swung open, away from the ball
}

TEST_CASE("a world with joints on embedded soft bodies saves and loads back", "[embedding][scene]") {
    // Saved after 1 s of swinging: the proxy is not written (the coupling section makes it again), the
    // joints name the soft body with world-frame anchors, and their zero is turned to the new proxy's
    // frame, so the hinge angles read the same (to the round-off of a quaternion product) and the loaded
    // door goes on swinging about the same line.
    auto w = build_world(parse_scene_file(scene_path("soft-door.json")));
    for (int step = 0; step < 60; ++step) w->step();
    const std::string text = scene_to_json_text(*w, "saved-door");
    auto loaded = build_world(parse_scene_string(text, "saved-door"));
    CHECK(loaded->rigid().body_count() == w->rigid().body_count());
    const std::vector<JointId> ja = w->rigid().joints().ids(), jb = loaded->rigid().joints().ids();
    REQUIRE(jb.size() == 2);
    for (std::size_t k = 0; k < 2; ++k) {
        CHECK(std::abs(w->rigid().joints().coordinate(ja[k], w->rigid()) -
                       loaded->rigid().joints().coordinate(jb[k], loaded->rigid())) < 1e-4);
        CHECK(loaded->rigid().joints().position_error(jb[k], loaded->rigid()) < 1e-3);
    }
    for (int step = 0; step < 60; ++step) loaded->step();
    REQUIRE(loaded->soft().all_finite());
    for (JointId j : loaded->rigid().joints().ids()) CHECK(loaded->rigid().joints().position_error(j, loaded->rigid()) < 1e-3);

    // A joint on a soft body that is not embedded has no proxy to hold: the scene is refused, naming it.
    std::string two_way = text;
    const std::string embed = "\"embed-rigid\"";
    two_way.replace(two_way.find(embed), embed.size(), "\"two-way\"");
    try {
        build_world(parse_scene_string(two_way, "not-embedded"));
        FAIL("a joint on a soft body that is not embedded was accepted");
    } catch (const SceneError& e) {
        CHECK(std::string(e.what()).find("/joints/0") != std::string::npos);
        CHECK(std::string(e.what()).find("not embedded") != std::string::npos);
    }
}

TEST_CASE("every soft model embedded falls onto the ground and rests on its proxy's hull", "[embedding]") {
    // One body of each model dropped 0.3 m, embedded, 3 s under the default rigid solver: it lands on
    // the hull of its nodes and rests with its centre of mass where its shape puts it (within 1 cm: the
    // hull's flatness tolerance, 0.4% of the diagonal, and the body's own sag under its weight), nearly
    // still, without sliding off (1 cm). The ball, neutral on flat ground, rolls away slowly on the
    // asymmetry of its 162-node hull (0.07 m/s after 3 s): only its height is asserted. So is the flat
    // cloth's: its padded hull rests for about a second and then rocks on the ground, nodes at 0.2-0.5
    // m/s for a second or more, in float and double, wherever the 3 s fall in that (docs/coupling.md, open).
    struct Case {
        const char* what;
        const char* body;
        double rest_y;  ///< centre of mass at rest (m)
        bool rolls = false;  ///< a ball (its hull rolls off any asymmetry) or the flat cloth (rocks): height only
    };
    const Case cases[] = {
        {"Verlet stick box", R"({"name": "b", "builder": "stick-box", "center": [0, 0.5, 0], "half_extents": [0.3, 0.2, 0.25],
            "mass": 1, "method": "verlet"})", 0.2},
        {"implicit pressure ball", R"({"name": "b", "builder": "icosphere", "center": [0, 0.6, 0], "radius": 0.3,
            "subdivisions": 2, "mass": 1, "method": "implicit", "links": {"stretch": 5000, "damping": 1},
            "material": {"pressure": 50}})", 0.3, true},
        {"implicit cloth (flat: its hull padded)", R"({"name": "b", "builder": "cloth", "nodes": [6, 6],
            "origin": [-0.25, 0.3, -0.25], "edge_u": [0.5, 0, 0], "edge_v": [0, 0, 0.5], "mass": 0.2,
            "method": "implicit", "links": {"stretch": 500, "damping": 0.1}, "material": {"thickness": 0.01}})", 0.01, true},
        {"fast mass-spring stick box", R"({"name": "b", "builder": "stick-box", "center": [0, 0.5, 0],
            "half_extents": [0.3, 0.2, 0.25], "mass": 1, "method": "fast-ms"})", 0.2},
        {"FEM cube", R"({"name": "b", "builder": "tet-box", "min_corner": [-0.1, 0.3, -0.1], "size": [0.2, 0.2, 0.2],
            "cells": [2, 2, 2], "method": "implicit", "fem": {"young": 1e5, "poisson": 0.3, "density": 500}})", 0.1},
    };
    for (const Case& c : cases) {
        INFO(c.what);
        auto w = build_world(parse_scene_string(std::string(R"({"format": "sinew-scene", "version": 1,
          "settings": {"sleeping": {"enabled": false}},
          "bodies": [{"name": "ground", "type": "static", "shape": {"type": "box", "half_extents": [4, 0.5, 4]},
                      "position": [0, -0.5, 0]}],
          "soft_bodies": [)") + c.body + R"(], "coupling": {"strategy": "embed-rigid"}})", c.what));
        const SoftBodyId b = w->soft().bodies()[0];
        REQUIRE_FALSE(w->coupling().embedding().proxy(b).is_null());
        const Vec3 start = node_com(w->soft().body(b).p);
        for (int step = 0; step < 180; ++step) w->step();
        REQUIRE(w->soft().all_finite());
        const Particles& p = w->soft().body(b).p;
        const Vec3 end = node_com(p);
        double speed = 0;
        for (const Vec3& v : p.v) speed = std::max(speed, double(v.norm()));
        INFO("rests at " << end.y() << " m (expected " << c.rest_y << "), fastest node " << speed << " m/s");
        CHECK(std::abs(end.y() - c.rest_y) < 0.01);
        if (c.rolls) continue;
        CHECK(speed < 0.05);
        CHECK(std::hypot(end.x() - start.x(), end.z() - start.z()) < 0.01);
    }
}

TEST_CASE("a sleeping embedded body struck by a rigid body takes its share of the momentum", "[embedding]") {
    // A FEM cube (4 kg) asleep on frictionless ground; a 1 kg frictionless ball slides into it at 2 m/s. The contact wakes the proxy inside the rigid step; the soft body, asleep for that step, wakes
    // after it and its nodes take the proxy's change at the next step's start. Along x nothing else
    // acts: ball and nodes together keep the ball's 2 N s (measured 2.00005 N s; 2% allowed for the soft
    // step's contact softness, which a stiffer cube or another solver may leave mid-exchange).
    auto w = build_world(parse_scene_string(R"({"format": "sinew-scene", "version": 1,
      "bodies": [{"name": "ground", "type": "static", "shape": {"type": "box", "half_extents": [4, 0.5, 4]},
                  "position": [0, -0.5, 0], "material": {"friction": 0}}],
      "soft_bodies": [{"name": "cube", "builder": "tet-box", "min_corner": [-0.1, 0, -0.1], "size": [0.2, 0.2, 0.2],
                  "cells": [2, 2, 2], "method": "implicit", "fem": {"young": 1e6, "poisson": 0.3, "density": 500},
                  "material": {"friction": 0, "thickness": 0.005}}],
      "coupling": {"strategy": "embed-rigid"}})", "struck"));
    const SoftBodyId cube = w->soft().bodies()[0];
    for (int step = 0; step < 120; ++step) w->step();
    REQUIRE_FALSE(w->soft().awake(cube));
    BodyDef ball;
    ball.shape = make_sphere(Real(0.05));
    ball.mass = 1;
    ball.material.friction = 0;
    ball.pose.p = Vec3(Real(-0.5), Real(0.1), 0);
    ball.linear_velocity = Vec3(2, 0, 0);
    const BodyId b = w->rigid().create_body(ball);
    for (int step = 0; step < 60; ++step) w->step();
    CHECK(w->soft().awake(cube));
    const double p = double(w->rigid().linear_velocity(b).x()) + double(node_momentum(w->soft().body(cube).p).x());
    INFO("x-momentum after the blow " << p << " N s (ball " << w->rigid().linear_velocity(b).x() << " m/s)");
    CHECK(std::abs(p - 2.0) < 0.02 * 2.0);
    CHECK(node_momentum(w->soft().body(cube).p).x() > Real(0.5));  // the cube took a good part of it
}

TEST_CASE("an embedded body's proxy goes with it, and comes with a new one", "[embedding]") {
    // Destroying an embedded soft body takes its proxy (and the proxy's joints) at once when the layer is
    // refreshed (the C API does it on every soft create, destroy, pin and attach) or at the next step; a
    // world saved then writes no trace of it. A body made in its slot has a proxy of its own.
    auto w = build_world(parse_scene_file(scene_path("soft-door.json")));
    const SoftBodyId door = w->soft().bodies()[0];
    const BodyId proxy = w->coupling().embedding().proxy(door);
    REQUIRE(w->rigid().joints().ids().size() == 2);
    const std::size_t bodies = w->rigid().body_count();
    w->soft().destroy_body(door);
    w->coupling().refresh_embedding();
    CHECK_FALSE(w->rigid().valid(proxy));
    CHECK(w->rigid().body_count() == bodies - 1);
    CHECK(w->rigid().joints().ids().empty());
    const std::string text = scene_to_json_text(*w, "after");
    CHECK(text.find("body-" + std::to_string(proxy.index) + "\"") == std::string::npos);
    for (int step = 0; step < 10; ++step) w->step();
    CHECK(w->rigid().all_finite());

    const SceneDesc d = parse_scene_file(scene_path("soft-door.json"));
    const SoftBodyId again = w->soft().create_body(d.soft_bodies[0].def);
    w->coupling().refresh_embedding();
    const BodyId fresh = w->coupling().embedding().proxy(again);
    REQUIRE_FALSE(fresh.is_null());
    CHECK(w->coupling().embedding().soft_of(fresh) == again);
    CHECK(w->coupling().embedding().proxy(door).is_null());  // the old handle names nothing
}

TEST_CASE("a two-node embedded rope has a proxy it can turn with", "[embedding]") {
    // Two nodes: the inertia about the line through them is zero, raised to that of a ball of the nodes'
    // radius; the rotation about it is free and resolved towards no turn. It falls onto the ground and
    // lies there, finite.
    auto w = build_world(parse_scene_string(R"({"format": "sinew-scene", "version": 1,
      "bodies": [{"name": "ground", "type": "static", "shape": {"type": "box", "half_extents": [4, 0.5, 4]},
                  "position": [0, -0.5, 0]}],
      "soft_bodies": [{"name": "stick", "builder": "rope", "from": [-0.3, 0.5, 0], "to": [0.3, 0.6, 0], "segments": 1,
                  "mass": 0.2, "method": "implicit", "links": {"stretch": 1000}, "material": {"thickness": 0.02}}],
      "coupling": {"strategy": "embed-rigid"}})", "stick"));
    const SoftBodyId stick = w->soft().bodies()[0];
    REQUIRE_FALSE(w->coupling().embedding().proxy(stick).is_null());
    for (int step = 0; step < 120; ++step) w->step();
    REQUIRE(w->soft().all_finite());
    REQUIRE(w->rigid().all_finite());
    const Particles& p = w->soft().body(stick).p;
    for (const Vec3& x : p.x) CHECK(std::abs(x.y() - Real(0.02)) < Real(0.02));  // on the ground, thickness up
}

TEST_CASE("an embedded soft body's proxy collides as the body's filter says, and follows a change", "[embedding][filter]") {
    // The cube from 0.5 m over a static slab (category 2). Its filter leaves the slab out: its proxy carries
    // the filter and the cube falls past the slab; then the mask admits it and a fresh cube lands on it.
    const std::string base = cube_scene(Vec3(-Real(0.1), Real(0.5), -Real(0.1)), "[0, -9.81, 0]", 2e5);
    SceneDesc d = parse_scene_string(base, "filter.json");
    d.bodies[0].def.shape = make_box(Vec3(1, Real(0.05), 1));
    d.bodies[0].def.pose.p = Vec3(0, Real(-0.05), 0);  // top face y = 0
    d.bodies[0].def.filter = {2, 0xFFFFFFFFu, 0};
    d.soft_bodies[0].def.filter = {1, ~2u, 0};
    const auto lowest = [](const World& w) {
        Real y = std::numeric_limits<Real>::max();
        for (const Vec3& x : w.soft().body(w.soft().bodies().at(0)).p.x) y = std::min(y, x.y());
        return y;
    };
    const auto w = build_world(d);
    const SoftBodyId cube = w->soft().bodies().at(0);
    REQUIRE(!w->coupling().embedding().proxy(cube).is_null());
    CHECK(w->rigid().filter(w->coupling().embedding().proxy(cube)) == CollisionFilter{1, ~2u, 0});
    for (int i = 0; i < 60; ++i) w->step();
    CHECK(lowest(*w) < Real(-0.5));  // 1 s: fell through the slab

    const auto again = build_world(d);
    const SoftBodyId c2 = again->soft().bodies().at(0);
    again->soft().set_filter(c2, CollisionFilter{});
    for (int i = 0; i < 90; ++i) again->step();
    CHECK(again->rigid().filter(again->coupling().embedding().proxy(c2)) == CollisionFilter{});
    CHECK(lowest(*again) == Approx(0).margin(0.02));  // resting on the slab's top face
}

// ---- rigid bodies as stiff FEM proxies (embed-fem, coupling/fem_embedding.hpp) -------------------------

TEST_CASE("embed-fem: a rigid box resting on an FEM block through its proxy carries its weight and comes to rest", "[embedding][embed-fem]") {
    // demos/scenes/box-on-soft-block.json (a 20 kg box on an implicit FEM block) with the box embedded into
    // the FEM system: its proxy (a fan of 48 tets from its centre) meets the block through the soft-soft
    // contacts and the box's own collider is ignored by the block. Under split impulses (one velocity
    // update per step) the box comes to rest; the impulses its proxy sends back, averaged over the last
    // second, are its weight per step, M g h = 3.27 N s, within 1 % (measured 0.2 %). The proxy is kept
    // out of saved scenes: the coupling section makes it again.
    SceneDesc d = parse_scene_file(scene_path("box-on-soft-block.json"));
    d.coupling.settings.strategy = CouplingStrategy::EmbedFem;
    d.coupling.settings.pairs.clear();
    d.settings.rigid.solver = RigidSolverKind::SplitImpulse;
    auto w = build_world(d);
    BodyId box;
    for (BodyId id : w->rigid().bodies())
        if (w->rigid().type(id) == BodyType::Dynamic) box = id;
    REQUIRE(!box.is_null());
    const std::size_t soft_before = w->soft().body_count();
    w->step();
    REQUIRE(w->soft().body_count() == soft_before + 1);  // the proxy
    const SoftBodyId proxy = w->coupling().fem_embedding().proxy(box);
    REQUIRE(!proxy.is_null());
    for (int k = 0; k < 180; ++k) w->step();
    double carried = 0;
    Real speed = 0;
    for (int k = 0; k < 60; ++k) {
        w->step();
        for (const CouplingImpulse& c : w->coupling().impulses()) carried += c.impulse.y() / 60;
        speed = std::max(speed, w->rigid().linear_velocity(box).norm());
        // The block meets the box only through the proxy.
        for (const ParticleContact& c : w->soft().contacts()) REQUIRE(w->soft().colliders()[c.collider].owner != box.index);
    }
    REQUIRE(w->soft().all_finite());
    const double weight = 20 * 9.81 / 60;
    CHECK(w->rigid().mass(box) == Approx(20));
    CHECK(carried == Approx(weight).epsilon(0.01));
    CHECK(speed < 0.01);
    CHECK(w->soft().soft_contacts().size() > 0);
    const std::string saved = scene_to_json_text(*w, "saved");
    CHECK(saved.find("embed-fem") != std::string::npos);
    CHECK(parse_scene_string(saved, "saved.json").soft_bodies.size() == soft_before);
}

TEST_CASE("embed-fem refuses a pair naming a static body or a shape with no proxy, and changes nothing", "[embedding][embed-fem][errors]") {
    World world;
    BodyDef ground;
    ground.type = BodyType::Static;
    ground.shape = make_box(Vec3(2, Real(0.5), 2));
    const BodyId g = world.rigid().create_body(ground);
    BodyDef ball;
    ball.shape = make_compound({{Transform{}, make_sphere(Real(0.1))}});
    ball.pose.p = Vec3(0, 2, 0);
    const BodyId b = world.rigid().create_body(ball);
    ClothGridDesc c;
    c.nx = c.ny = 4;
    const SoftBodyId cloth = world.soft().create_body(make_cloth_grid(c));
    CouplingSettings s;
    s.pairs.push_back({cloth, g, CouplingStrategy::EmbedFem});
    try {
        world.set_coupling(s);
        FAIL("accepted");
    } catch (const std::exception& e) {
        CHECK(std::string(e.what()).find("not dynamic") != std::string::npos);
    }
    s.pairs[0].rigid = b;
    try {
        world.set_coupling(s);
        FAIL("accepted");
    } catch (const std::exception& e) {
        CHECK(std::string(e.what()).find("compound") != std::string::npos);
    }
    CHECK(world.coupling().settings().pairs.empty());
}

TEST_CASE("embed-fem proxy meshes: every shape's fan of tets has the shape's volume", "[embedding][embed-fem]") {
    // The proxy's mass is the body's at uniform density; its volume is the shape's to within the
    // faceting: exact for a box and a hull, the inscribed geodesic polyhedron for a sphere (320 faces:
    // 0.966 of the ball) and a capsule (0.961).
    const auto volume = [](const Shape& s) {
        std::vector<Vec3> nodes;
        std::vector<std::uint32_t> tets;
        REQUIRE(FemEmbedding::proxy_mesh(s, nodes, tets));
        double v = 0;
        for (std::size_t k = 0; k + 3 < tets.size(); k += 4) {
            const double t = tet_volume(nodes[tets[k]], nodes[tets[k + 1]], nodes[tets[k + 2]], nodes[tets[k + 3]]);
            REQUIRE(t > 0);
            v += t;
        }
        return v;
    };
    CHECK(volume(make_box(Vec3(Real(0.5), Real(0.25), Real(0.1)))) == Approx(0.1).epsilon(1e-5));
    const double ball = 4.0 / 3 * 3.14159265358979 * 0.001;
    CHECK(volume(make_sphere(Real(0.1))) == Approx(ball).epsilon(0.05));
    CHECK(volume(make_sphere(Real(0.1))) < ball);
    const double capsule = ball + 3.14159265358979 * 0.01 * 0.4;
    CHECK(volume(make_capsule(Real(0.2), Real(0.1))) == Approx(capsule).epsilon(0.05));
    CHECK(volume(make_convex_hull({Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)})) == Approx(1.0 / 6).epsilon(1e-5));
    std::vector<Vec3> nodes;
    std::vector<std::uint32_t> tets;
    CHECK_FALSE(FemEmbedding::proxy_mesh(make_plane(Vec3::UnitY(), 0), nodes, tets));
}

namespace {
/// The FEM cube of cube_scene embedded one proxy per tet, its nodes weighted as `mass` says.
/// `exact_cg`: the cube's implicit solve to 1e-7 rather than 1e-4 (its CG's residual does not conserve momentum).
std::unique_ptr<World> element_cube(const Vec3& corner, const char* gravity, const char* mass, double young = 1e5,
                                    bool exact_cg = false) {
    std::string text = cube_scene(corner, gravity, young);
    if (exact_cg) {
        const std::string loose = R"("iterations": 100, "cg_tolerance": 0.0001)";
        const std::size_t at = text.find(loose);
        REQUIRE(at != std::string::npos);
        text.replace(at, loose.size(), R"("iterations": 1000, "cg_tolerance": 1e-7)");
    }
    SceneDesc d = parse_scene_string(text, "elements");
    d.coupling.settings.embed_proxies = EmbedProxies::Elements;
    REQUIRE(parse_embed_proxy_mass(mass, d.coupling.settings.embed_proxy_mass));
    return build_world(d);
}
}  // namespace

TEST_CASE("element proxies: one per tet, the nodes' masses split between them, an impulse reaching the nodes exactly", "[embedding][elements]") {
    // Mass splitting (Tonge et al. 2012): a node held by k tets gives each proxy m_i / k, so the proxies'
    // masses sum to the body's, and a velocity change of a proxy reaches each of its nodes divided by k:
    // an impulse J at a proxy's centre changes the nodes' momentum by exactly J. Seed 001's choice gives
    // each tet the whole body's mass: the nodes then take only Σ_e m_i / (k_i M) of J (reproduced on
    // purpose: momentum is not exchanged exactly). Free cube, no gravity, no contact. The split change is
    // not a rigid motion, so the cube's own elastic forces act in the same step: they conserve momentum
    // to their CG's residual (1e-7 here; at 1e-4 the nodes lost 9e-5 of J, in double as in float).
    for (const char* mass : {"physical", "whole-body"}) {
        INFO(mass);
        auto w = element_cube(Vec3(-0.1, 0.5, -0.1), "[0, 0, 0]", mass, 1e5, true);
        const SoftBodyId cube = w->soft().bodies()[0];
        const RigidEmbedding& emb = w->coupling().embedding();
        CHECK(emb.proxy(cube).is_null());
        const std::vector<BodyId> proxies = emb.element_proxies(cube);
        const Particles& p = w->soft().body(cube).p;
        const std::size_t tets = w->soft().body(cube).fem->size();
        REQUIRE(proxies.size() == tets);
        double body_mass = 0, proxy_mass = 0;
        for (Real m : p.mass) body_mass += m;
        std::vector<int> valence(p.size(), 0);
        for (std::size_t e = 0; e < tets; ++e) {
            proxy_mass += w->rigid().mass(proxies[e]);
            CHECK(emb.soft_of(proxies[e]) == cube);
            for (std::uint32_t i : emb.element_nodes(cube, e)) ++valence[i];
        }
        const bool physical = std::string(mass) == "physical";
        CHECK(proxy_mass == Approx(physical ? body_mass : body_mass * double(tets)).epsilon(4 * round_off(p.size())));
        const std::size_t e = 7;
        const Vec3 j(Real(0.3), Real(-0.2), Real(0.5));
        w->rigid().apply_impulse(proxies[e], j, w->rigid().transform(proxies[e]).p);
        w->step();
        double share = 0;  // Σ over the element's nodes of m_i / (k_i M): the part of J its nodes take
        for (std::uint32_t i : emb.element_nodes(cube, e)) share += double(p.mass[i]) / valence[i] / body_mass;
        const Vec3 expect = physical ? j : Vec3(j * Real(share));
        const Vec3 dp = node_momentum(p);
        INFO("nodes took " << dp.transpose() << " of J = " << j.transpose() << " (share " << share << "), off by " << (dp - expect).norm());
        // The CG residual (1e-7) in double; in float the round-off of the sums over 27 nodes and 40 tets.
        CHECK((dp - expect).norm() <= (sizeof(Real) == 4 ? 1e-5 : 1e-7) * j.norm());
        if (!physical) CHECK(share < 0.1);
    }
}

TEST_CASE("element proxies: a thrown cube hitting a free box keeps the momentum, exactly with split masses", "[embedding][elements]") {
    // No gravity: a 4 kg FEM cube at 2 m/s into a 4 kg box at rest. With the nodes' masses split between
    // their tets, every contact impulse on a proxy reaches its nodes whole, and each exchange through a
    // shared node moves momentum between nodes only: box and nodes keep 8 N s over 60 steps within 1e-4
    // relative (measured 3.6e-5 in float). The cube's own implicit solve runs to a CG tolerance of 1e-7
    // here: at 1e-4 its residual, large while the contact deforms the cube, gains 2.7e-4 (the whole-body
    // proxy's rigid changes deform nothing and keep 1.6e-5 at 1e-4). With seed 001's whole-body weights the
    // box takes impulses the nodes do not give up, and the total grows (reproduced on purpose).
    for (const char* mass : {"physical", "whole-body"}) {
        INFO(mass);
        auto w = element_cube(Vec3(-0.1, 0.5, -0.1), "[0, 0, 0]", mass, 1e6, true);
        const SoftBodyId cube = w->soft().bodies()[0];
        Particles& p = w->soft().body(cube).p;
        for (Vec3& v : p.v) v = Vec3(2, 0, 0);
        w->coupling().refresh_embedding();
        BodyDef box;
        box.shape = make_box(Vec3::Constant(Real(0.1)));
        box.mass = 4;
        box.pose.p = Vec3(Real(0.4), Real(0.6), 0);
        const BodyId b = w->rigid().create_body(box);
        double m_cube = 0;
        for (Real m : p.mass) m_cube += m;
        const double p0 = 2 * m_cube;
        for (int step = 0; step < 60; ++step) w->step();
        REQUIRE(w->soft().all_finite());
        const double box_p = 4 * double(w->rigid().linear_velocity(b).x());
        const double total = box_p + double(node_momentum(p).x());
        INFO("box " << box_p << " N s, total " << total << " N s of " << p0);
        CHECK(box_p > 0.2 * p0);  // they met
        if (std::string(mass) == "physical") CHECK(std::abs(total - p0) <= 1e-4 * p0);
        else CHECK(total > 1.05 * p0);
    }
}

TEST_CASE("element proxies: a cube rests on the ground, five stacked do not stand", "[embedding][elements]") {
    // A contact meets an element's rigid part only (its proxy's fit to the nodes), so a tet that compresses
    // without moving its centre goes unseen: a single cube rests, sagging more than its elastic solution,
    // and the stack of five of demos/scenes/stack-of-soft-cubes.json, which one proxy per cube holds
    // within 0.1 mm, collapses: the loss of accuracy per-element embedding pays for contacts anywhere on
    // the body (docs/coupling.md, "Element proxies").
    SceneDesc d = parse_scene_file(scene_path("stack-of-soft-cubes.json"));
    d.coupling.settings.strategy = CouplingStrategy::EmbedRigid;
    d.coupling.settings.embed_proxies = EmbedProxies::Elements;
    d.settings.rigid.sleeping = false;
    d.settings.soft.sleeping = false;
    auto w = build_world(d);
    const std::vector<SoftBodyId> cubes = w->soft().bodies();
    for (int step = 0; step < 300; ++step) w->step();  // 5 s
    REQUIRE(w->soft().all_finite());
    double top = 0, lowest = 1;
    for (SoftBodyId c : cubes) {
        top = std::max(top, double(node_com(w->soft().body(c).p).y()));
        for (const Vec3& x : w->soft().body(c).p.x) lowest = std::min(lowest, double(x.y()));
    }
    INFO("highest centre " << top << " m, lowest node " << lowest << " m");
    CHECK(top < 0.6);        // not five cubes of 0.3 m high any more
    CHECK(top > 0.1);        // each still a cube on the ground, none crushed flat
    CHECK(lowest > -0.005);  // and none through it
}

TEST_CASE("element proxies in scene files: loaded, saved back, bad values named", "[embedding][elements][scene]") {
    std::string text = cube_scene(Vec3(-0.1, 0.5, -0.1), "[0, -9.81, 0]", 1e5);
    const std::string from = R"("coupling": {"strategy": "embed-rigid"})";
    const std::size_t at = text.find(from);
    REQUIRE(at != std::string::npos);
    text.replace(at, from.size(), R"("coupling": {"strategy": "embed-rigid", "proxies": "elements", "proxy_mass": "whole-body"})");
    auto w = build_world(parse_scene_string(text, "elements"));
    CHECK(w->coupling().settings().embed_proxies == EmbedProxies::Elements);
    CHECK(w->coupling().settings().embed_proxy_mass == EmbedProxyMass::WholeBody);
    const SoftBodyId cube = w->soft().bodies()[0];
    CHECK(w->coupling().embedding().element_proxies(cube).size() == w->soft().body(cube).fem->size());
    const std::string saved = scene_to_json_text(*w, "saved");
    CHECK(saved.find("\"proxies\": \"elements\"") != std::string::npos);
    auto back = build_world(parse_scene_string(saved, "saved"));
    CHECK(back->coupling().settings().embed_proxies == EmbedProxies::Elements);
    CHECK(back->rigid().body_count() == w->rigid().body_count());  // the proxies made again, not written
    std::string bad = text;
    bad.replace(bad.find("\"whole-body\""), 12, "\"heavy\"");
    try {
        parse_scene_string(bad, "bad");
        FAIL("accepted");
    } catch (const SceneError& e) {
        CHECK(std::string(e.what()).find("/coupling/proxy_mass") != std::string::npos);
        CHECK(std::string(e.what()).find("whole-body") != std::string::npos);
    }
}
