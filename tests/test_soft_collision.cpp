// Soft bodies under contact: against rigid shapes (soft/particle_collision.hpp, soft/soft_system.hpp, the
// one-way layer coupling/one_way_coupling.hpp: the point-shape distance query against closed forms, no
// particle left inside a shape, Coulomb friction and restitution against their analytic outcomes, the
// contacts fast mass-spring and implicit Euler hold inside their solves, continuous collision, kinematic
// bodies pushing and carrying particles, sleeping and waking, validation of bad definitions) and against
// each other (soft/soft_contacts.hpp: momentum, resting stacks, edge-edge, self-collision, fast
// mass-spring's soft-soft rows).
#include <catch2/catch.hpp>

#include <cmath>
#include <random>
#include <string>

#include "engine/core/segment_closest.hpp"
#include "engine/world/scene.hpp"
#include "engine/world/world.hpp"
#include "soft/soft_builders.hpp"
#include "soft/soft_system.hpp"

using namespace sinew;

namespace {

const std::string kScenes = std::string(SINEW_SOURCE_DIR) + "/demos/scenes/";

Collider make_collider(const Shape& shape, const Transform& xf, Real friction = Real(0.5)) {
    Collider c;
    c.shape = &shape;
    c.xf = xf;
    c.com = xf.p;
    c.box = shape.bounds(xf);
    c.friction = friction;
    return c;
}

// One particle as a soft body.
SoftBodyDef single_particle(const Vec3& x, SoftMethod method) {
    SoftBodyDef d;
    d.method = method;
    d.positions = {x};
    d.masses = {Real(0.1)};
    d.thickness = Real(0.01);
    d.allow_sleep = false;
    return d;
}

struct SoftOnly {
    Pipeline pipeline;
    SoftSystem soft;
    explicit SoftOnly(const SoftSettings& s = {}) : soft(s) { pipeline.add_system(&soft); }
};

/// A 4 x 4 cloth, 0.3 m square, hanging in the plane x = `x` about the x axis, 1 cm thick, never asleep.
/// Links of 100 N/m: omega h = 0.67 at 60 Hz, within semi-implicit Euler's limit.
SoftBodyDef small_cloth(SoftMethod method, Real x) {
    ClothGridDesc g;
    g.nx = g.ny = 4;
    g.origin = Vec3(x, Real(0.15), Real(-0.15));
    g.edge_u = Vec3(0, 0, Real(0.3));
    g.edge_v = Vec3(0, Real(-0.3), 0);
    g.material.stretch = g.material.shear = 100;
    SoftBodyDef base;
    base.method = method;
    base.thickness = Real(0.01);
    base.allow_sleep = false;
    return make_cloth_grid(g, base);
}

Real signed_distance(const Vec3& p, const Shape& s, const Transform& xf) {
    Vec3 sp, n;
    Real d = 0;
    REQUIRE(point_shape_distance(p, s, xf, Real(100), sp, n, d));
    return d;
}

// A 1 m cloth of 33 x 33 nodes (1 kg, links of 1e4 N/m) laid over a 0.4 m wide static table 1 m high,
// friction 0.5 on both, restitution `e` on both, under `method` with `iterations`.
SceneDesc tablecloth_scene(const std::string& method, int iterations, double e) {
    const std::string r = std::to_string(e), it = std::to_string(iterations);
    return parse_scene_string(R"({"format": "sinew-scene", "version": 1,
      "settings": {"sleeping": {"enabled": false}},
      "bodies": [{"name": "table", "type": "static", "shape": {"type": "box", "half_extents": [0.2, 0.5, 1]},
                  "position": [0, 0.5, 0], "material": {"friction": 0.5, "restitution": )" + r + R"(}}],
      "soft_bodies": [{"name": "cloth", "builder": "cloth", "nodes": [33, 33], "origin": [-0.5, 1.01, -0.5],
                       "edge_u": [1, 0, 0], "edge_v": [0, 0, 1], "shear": true, "bend": false, "mass": 1,
                       "method": ")" + method + R"(", "solver": {"iterations": )" + it + R"(},
                       "links": {"stretch": 10000, "shear": 10000},
                       "material": {"friction": 0.5, "thickness": 0.01, "restitution": )" + r + R"(}}]})",
                              "tablecloth");
}

// Ten seconds of the tablecloth: its fastest particle from step `watch_from` on, and at the end its mean
// height and kinetic energy.
struct ClothRun {
    Real fastest = 0, y = 0, energy = 0;
};
ClothRun run_tablecloth(const SceneDesc& scene, int watch_from) {
    auto world = build_world(scene);
    const SoftBody& cloth = world->soft().body(world->soft().bodies()[0]);
    ClothRun r;
    for (int k = 0; k < 600; ++k) {
        world->step();
        r.y = r.energy = 0;
        for (std::size_t i = 0; i < cloth.p.size(); ++i) {
            if (k >= watch_from) r.fastest = std::max(r.fastest, cloth.p.v[i].norm());
            r.y += cloth.p.x[i].y() / Real(cloth.p.size());
            r.energy += Real(0.5) * cloth.p.mass[i] * cloth.p.v[i].squaredNorm();
        }
    }
    return r;
}

}  // namespace

TEST_CASE("point-shape distance matches closed forms for every shape type", "[soft][collision]") {
    const Transform xf{Vec3(1, 2, 3), Quat(Eigen::AngleAxis<Real>(Real(0.7), Vec3(1, 2, 0.5).normalized()))};
    std::mt19937 rng(7);
    std::uniform_real_distribution<Real> u(-2, 2);
    const Real tol = Real(2e-5);  // float rounding of a few metres through a rotation

    SECTION("sphere") {
        const Shape s = make_sphere(Real(0.8));
        for (int k = 0; k < 200; ++k) {
            const Vec3 q(u(rng), u(rng), u(rng));
            CHECK(signed_distance(xf.apply(q), s, xf) == Approx(q.norm() - Real(0.8)).margin(tol));
        }
    }
    SECTION("box, and a convex hull of the same box (two independent routines agree)") {
        const Vec3 he(Real(0.5), Real(0.8), Real(1.1));
        const Shape box = make_box(he);
        std::vector<Vec3> corners;
        for (int i = 0; i < 8; ++i)
            corners.emplace_back(i & 1 ? he.x() : -he.x(), i & 2 ? he.y() : -he.y(), i & 4 ? he.z() : -he.z());
        const Shape hull = make_convex_hull(corners);
        for (int k = 0; k < 300; ++k) {
            const Vec3 q(u(rng), u(rng), u(rng));
            // Closed form: outside, the length of the excess over the half extents; inside, minus the
            // smallest gap to a face.
            const Vec3 excess = (q.cwiseAbs() - he).cwiseMax(Vec3::Zero());
            const Real inside_gap = (he - q.cwiseAbs()).minCoeff();
            const Real expected = excess.squaredNorm() > 0 ? excess.norm() : -inside_gap;
            CHECK(signed_distance(xf.apply(q), box, xf) == Approx(expected).margin(tol));
            CHECK(signed_distance(xf.apply(q), hull, xf) == Approx(expected).margin(tol));
        }
    }
    SECTION("capsule") {
        const Shape s = make_capsule(Real(0.6), Real(0.3));
        for (int k = 0; k < 200; ++k) {
            const Vec3 q(u(rng), u(rng), u(rng));
            const Vec3 c(0, std::clamp(q.y(), Real(-0.6), Real(0.6)), 0);
            CHECK(signed_distance(xf.apply(q), s, xf) == Approx((q - c).norm() - Real(0.3)).margin(tol));
        }
    }
    SECTION("plane") {
        const Shape s = make_plane(Vec3(0, 1, 0), Real(0.25));
        for (int k = 0; k < 50; ++k) {
            const Vec3 q(u(rng), u(rng), u(rng));
            CHECK(signed_distance(xf.apply(q), s, xf) == Approx(q.y() - Real(0.25)).margin(tol));
        }
    }
    SECTION("triangle mesh: in front is outside, behind is inside") {
        const Shape s = make_triangle_mesh({{-1, 0, -1}, {1, 0, -1}, {1, 0, 1}, {-1, 0, 1}}, {0, 2, 1, 0, 3, 2});
        CHECK(signed_distance(Vec3(Real(0.2), Real(0.3), Real(0.1)), s, {}) == Approx(0.3).margin(tol));
        CHECK(signed_distance(Vec3(Real(0.2), Real(-0.05), Real(0.1)), s, {}) == Approx(-0.05).margin(tol));
        // Beyond the edge: the distance to the edge.
        CHECK(signed_distance(Vec3(Real(1.3), Real(0.4), 0), s, {}) == Approx(0.5).margin(tol));
    }
    SECTION("compound: the nearest child decides") {
        const Shape s = make_compound({{Transform{Vec3(-1, 0, 0), Quat::Identity()}, make_sphere(Real(0.5))},
                                       {Transform{Vec3(1, 0, 0), Quat::Identity()}, make_box(Vec3::Constant(Real(0.5)))}});
        CHECK(signed_distance(Vec3(-1, 1, 0), s, {}) == Approx(0.5).margin(tol));
        CHECK(signed_distance(Vec3(1, 1, 0), s, {}) == Approx(0.5).margin(tol));
        CHECK(signed_distance(Vec3(Real(1.1), 0, 0), s, {}) == Approx(-0.4).margin(tol));
    }
}

TEST_CASE("cloth-drop: no particle ends a step inside the ground or the sphere", "[soft][collision]") {
    const SceneDesc scene = parse_scene_file(kScenes + "cloth-drop.json");
    std::vector<BodyId> ids;
    auto world = build_world(scene, &ids);
    const SoftBodyId cloth = world->soft().bodies().at(0);
    const Real r = world->soft().body(cloth).def.thickness;
    const Shape& ground = world->rigid().shape(ids[0]);
    const Shape& ball = world->rigid().shape(ids[1]);
    const Transform xg = world->rigid().transform(ids[0]), xb = world->rigid().transform(ids[1]);
    Real worst = kRealMax;
    int touching = 0;
    for (int step = 0; step < 240; ++step) {
        world->step();
        const Particles& p = world->soft().body(cloth).p;
        for (std::size_t i = 0; i < p.size(); ++i) {
            const Real d = std::min(signed_distance(p.x[i], ground, xg), signed_distance(p.x[i], ball, xb));
            worst = std::min(worst, d);
        }
        touching = static_cast<int>(world->soft().contacts().size());
    }
    INFO("closest approach of a particle centre to a surface: " << worst << " m, thickness " << r);
    // Every step ends with each particle's centre at least its thickness from every surface, up to float
    // rounding of the projection (1e-5 m at coordinates of a few metres).
    CHECK(worst >= r - Real(1e-5));
    // The cloth rests on the sphere and the ground at the end: many particles in contact.
    CHECK(touching > 100);
}

TEST_CASE("particle friction on a slope: sticks below atan(mu), slides with g(sin - mu cos) above", "[soft][collision]") {
    const Real g = Real(9.81);
    const Real mu = Real(0.5);  // collider 0.5 and particle 0.5: geometric mean 0.5
    // Fast mass-spring holds the particle on the plane inside its global step: the friction budget is
    // the normal impulse that solve applied (ParticleCollision::set_held).
    for (SoftMethod method : {SoftMethod::Verlet, SoftMethod::SemiImplicitEuler, SoftMethod::FastMassSpring}) {
        for (Real deg : {Real(20), Real(40)}) {
            DYNAMIC_SECTION(soft_method_name(method) << " at " << deg << " degrees") {
                const Real th = deg * Real(M_PI / 180);
                const Vec3 n(-std::sin(th), std::cos(th), 0);  // slope rising towards +x
                const Shape plane = make_plane(n, 0);
                SoftOnly s;
                SoftBodyDef d = single_particle(n * Real(0.01), method);
                d.friction = mu;
                const SoftBodyId id = s.soft.create_body(d);
                s.soft.colliders().push_back(make_collider(plane, {}, mu));
                const Real h = Real(1) / 240;
                const Vec3 down_slope = -Vec3(std::cos(th), std::sin(th), 0);  // the surface y = x tan(th) falls towards -x
                const Vec3 x0 = s.soft.body(id).p.x[0];
                const int steps = 480;  // 2 s
                for (int k = 0; k < steps; ++k) s.pipeline.step(h);
                const Vec3 x = s.soft.body(id).p.x[0];
                const Real travelled = (x - x0).dot(down_slope);
                const Real off_plane = x.dot(n);
                CHECK(off_plane == Approx(0.01).margin(1e-4));  // stays on the plane at its thickness
                if (deg < 26.5) {  // atan(0.5) = 26.57 degrees: static friction holds
                    CHECK(std::abs(travelled) < 1e-3);
                } else {
                    // a = g (sin - mu cos); distance after t: a t^2 / 2. 2% as issue 3's rigid ramp: the
                    // integrators are first order, and at h = 1/240 the O(h) error is 0.4% of 2 s.
                    const Real a = g * (std::sin(th) - mu * std::cos(th));
                    const Real t = steps * h;
                    CHECK(travelled == Approx(Real(0.5) * a * t * t).epsilon(0.02));
                }
            }
        }
    }
}

TEST_CASE("fast mass-spring holds its contacts inside the global step: a resting cloth's contacts carry its weight",
          "[soft][collision][fast-ms]") {
    // A 1 kg, 1 m cloth of 16 x 16 nodes at k = 1e4 N/m, laid flat at its thickness on the ground: at
    // rest every node is held by its plane, so the normal impulses the contact pass reports sum to the
    // weight's over the step, M g h (within 0.5%: float sums of 256 terms), and nothing sinks or stretches.
    SoftOnly s;
    const Shape ground = make_plane(Vec3::UnitY(), 0);
    s.soft.colliders().push_back(make_collider(ground, {}));
    ClothGridDesc g;
    g.nx = g.ny = 16;
    g.origin = Vec3(Real(-0.5), Real(0.01), Real(-0.5));
    g.edge_u = Vec3(1, 0, 0);
    g.edge_v = Vec3(0, 0, 1);
    g.total_mass = 1;
    g.material.stretch = g.material.shear = Real(1e4);
    SoftBodyDef base;
    base.method = SoftMethod::FastMassSpring;
    base.iterations = 1;
    base.thickness = Real(0.01);
    base.allow_sleep = false;
    const SoftBodyId id = s.soft.create_body(make_cloth_grid(g, base));
    const Real h = Real(1) / 60;
    for (int k = 0; k < 60; ++k) s.pipeline.step(h);
    Real normal = 0;
    for (const ParticleContact& c : s.soft.contacts()) normal += c.impulse.dot(c.normal);
    const Real weight = Real(9.81) * h;  // N s over one step
    CHECK(normal == Approx(weight).epsilon(0.005));
    const SoftBody& b = s.soft.body(id);
    for (const Vec3& x : b.p.x) CHECK(x.y() == Approx(0.01).margin(1e-5));
    CHECK(b.max_stretch() < Real(1.001));
}

TEST_CASE("fast mass-spring with restitution: a tablecloth's edge particles are held, not bounced, and it comes to rest",
          "[soft][collision][fast-ms]") {
    // A 1 m cloth of 33 x 33 nodes over a 0.4 m wide table, restitution 0.5, friction 0.5: the particles at
    // the table's edges carry the hanging sides' pull, several times their own weight. Restitution must
    // reflect a particle's own approach only: when it reflected the impulse held inside the solve over the
    // mass (the load included, above the 1 m/s restitution threshold at the edges), the edges bounced and
    // the cloth flew off (18 m/s within half a second, 700 m up after 5 s). And friction acts inside the
    // global step: applied after it, with the tangential motion taken back, it moved particles their links
    // did not see, and the sides climbed back over the edges (the centre of mass from 0.926 m at 3 s to
    // 0.987 m at 10 s, 0.6 J gained). At rest it lies flat on the table with its sides hanging, the centre of
    // mass at 0.4 x 1.01 + 0.6 x (1.01 - 0.15) = 0.92 m less the sides' stretch (Verlet: 0.905 m).
    // Measured: nothing faster than 0.15 m/s after the first second, at rest by 10 s (1e-5 J) at 0.912 m.
    // Bounds: the 1 m/s restitution threshold; 1e-3 J; 0.89-0.93 m.
    const ClothRun r = run_tablecloth(tablecloth_scene("fast-ms", 1, 0.5), 60);
    CHECK(r.fastest < Real(1));
    CHECK(r.energy < Real(1e-3));
    CHECK(r.y > Real(0.89));
    CHECK(r.y < Real(0.93));
}

TEST_CASE("implicit Euler holds its contacts with colliders at rest inside the solve: a tablecloth and a pressure ball come to rest",
          "[soft][collision][implicit]") {
    // Baraff & Witkin's constraint filter (soft/soft_system.cpp, record_contacts) for mass-spring bodies
    // against colliders at rest. With the projection after the solve alone (measured, float, 10 s):
    // - the tablecloth of the fast mass-spring test (here restitution 0, CG 100) kept particles along the
    //   table's sides in a period-two flutter at 0.4 m/s (5e-4 J) for good; held: the fastest at
    //   2-4 mm/s, 1e-7 J, its centre of mass at 0.912 m (fast mass-spring's);
    // - pressure-ball (642 vertices) rolled 0.8 m across the ground within 10 s of landing; held: its
    //   centre moves less than 1 mm after landing, 3e-10 J.
    // Bounds: the 5 cm/s sleep speed; 1e-5 J; the centre of mass as in the fast mass-spring test; 1 cm.
    SECTION("tablecloth") {
        const ClothRun r = run_tablecloth(tablecloth_scene("implicit", 100, 0), 300);
        CHECK(r.fastest < Real(0.05));
        CHECK(r.energy < Real(1e-5));
        CHECK(r.y > Real(0.89));
        CHECK(r.y < Real(0.93));
    }
    SECTION("pressure ball") {
        SceneDesc scene = parse_scene_file(kScenes + "pressure-ball.json");
        for (SceneSoftBody& b : scene.soft_bodies) {
            b.def.method = SoftMethod::ImplicitEuler;
            b.def.iterations = 100;
        }
        auto world = build_world(scene);
        const SoftBody& ball = world->soft().body(world->soft().bodies()[0]);
        const auto centre = [&] {
            Vec3 c = Vec3::Zero();
            for (const Vec3& x : ball.p.x) c += x / Real(ball.p.size());
            return c;
        };
        for (int k = 0; k < 120; ++k) world->step();  // landed
        const Vec3 landed = centre();
        Real energy = 0;
        for (int k = 0; k < 480; ++k) world->step();
        for (std::size_t i = 0; i < ball.p.size(); ++i) energy += Real(0.5) * ball.p.mass[i] * ball.p.v[i].squaredNorm();
        const Vec3 drift = centre() - landed;
        CHECK(std::hypot(drift.x(), drift.z()) < Real(0.01));
        CHECK(energy < Real(1e-5));
    }
}

TEST_CASE("fast mass-spring: a pressure ball keeps its volume through its landing", "[soft][collision][fast-ms][pressure]") {
    // The bench's pressure-ball (RESULTS.md, soft bodies): a 642-vertex icosphere, r = 0.5 m, 1 kg, edge
    // links of 1e4 N/m, Matyka's gas P V = P_c = 50 J, dropped from 1 m onto the ground at h = 1/60.
    // Projected out of the ground after the solve, its bottom stopped alone and the rest ran on: the ball
    // folded in and stayed at 0.26 of its volume (1 iteration; 0.42 at 10). Held inside the global step,
    // the whole ball feels the ground. Bounds:
    //  - the landing: the ball arrives with E = m g h = 9.8 J; the isothermal gas, compressed from V_0 to V,
    //    stores P_c ln(V_0 / V), so it cannot go below V_0 exp(-E / P_c) = 0.82 V_0 unless the surface
    //    folds (the links take some of the energy: measured 0.84-0.85 at 1 iteration, 0.92 at 3); 0.80.
    //  - settled, 3 iterations: within 10% of the rest volume (the issue's bound; measured 0.99 in float
    //    and double; implicit Euler converged: 0.98).
    //  - settled, 1 iteration: the landing snaps the top in (edge links do not resist it, and one
    //    iteration leaves them soft) and the dent stays: 0.85 in float since friction joined the global
    //    step (0.91 before); in double no dent forms, 0.94 (docs/soft-bodies.md). Bound 0.80, the
    //    landing's: it does not crumple below what the gas can be pressed to.
    for (int iterations : {1, 3}) {
        CAPTURE(iterations);
        SoftOnly s;
        const Shape ground = make_plane(Vec3::UnitY(), 0);
        s.soft.colliders().push_back(make_collider(ground, {}));
        LinkMaterial m;
        m.stretch = m.shear = m.bend = Real(1e4);
        m.damping = 0;
        SoftBodyDef base;
        base.method = SoftMethod::FastMassSpring;
        base.iterations = iterations;
        base.pressure = 50;
        base.friction = Real(0.5);
        base.thickness = Real(0.02);
        base.drag = 0;
        base.allow_sleep = false;
        const SoftBodyId id = s.soft.create_body(make_icosphere(Vec3(0, Real(1.5), 0), Real(0.5), 3, 1, m, base));
        const SoftBody& b = s.soft.body(id);
        REQUIRE(b.p.size() == 642);
        double lowest = 1e30;
        for (int k = 0; k < 600; ++k) {
            s.pipeline.step(Real(1) / 60);
            lowest = std::min(lowest, double(b.volume()) / double(b.rest_volume));
        }
        const double settled = double(b.volume()) / double(b.rest_volume);
        INFO("lowest " << lowest << ", settled " << settled);
        CHECK(lowest > 0.80);
        CHECK(settled > (iterations == 1 ? 0.80 : 0.90));
        CHECK(settled < 1.10);
    }
}

TEST_CASE("restitution: a particle rebounds to e^2 of its drop height, e = 0 does not bounce", "[soft][collision]") {
    for (SoftMethod method : {SoftMethod::Verlet, SoftMethod::SemiImplicitEuler}) {
        for (Real e : {Real(0), Real(0.6)}) {
            DYNAMIC_SECTION(soft_method_name(method) << ", e = " << e) {
                const Shape ground = make_plane(Vec3::UnitY(), 0);
                SoftOnly s;
                const Real H = 1;
                SoftBodyDef d = single_particle(Vec3(0, H + Real(0.01), 0), method);
                d.restitution = e;
                const SoftBodyId id = s.soft.create_body(d);
                s.soft.colliders().push_back(make_collider(ground, {}));
                const Real h = Real(1) / 240;
                bool landed = false;
                Real apex = 0;
                for (int k = 0; k < 600; ++k) {
                    s.pipeline.step(h);
                    const Particles& p = s.soft.body(id).p;
                    if (!landed && !s.soft.contacts().empty()) landed = true;
                    if (landed) apex = std::max(apex, p.x[0].y() - Real(0.01));
                }
                REQUIRE(landed);
                if (e == 0) {
                    CHECK(apex < 1e-3);  // stays on the plane
                } else {
                    // Rebound height e^2 H; 5%: the contact is detected up to one step late, which at
                    // h = 1/240 and 4.4 m/s shifts the energy by about 2 h v / H ~ 4%.
                    CHECK(apex == Approx(e * e * H).epsilon(0.05));
                }
            }
        }
    }
}

TEST_CASE("continuous collision: a cloth thrown at 50 m/s stops at a 0.1 m wall under every soft method", "[soft][collision][continuous]") {
    // At h = 1/60 the cloth crosses 0.83 m a step: from in front of the wall its next predicted position
    // lies beyond it, nearest the far face. The particle's path from the start of the step enters the near
    // face first, and that face is its plane (particle_collision.cpp).
    for (SoftMethod method : {SoftMethod::Verlet, SoftMethod::SemiImplicitEuler, SoftMethod::ImplicitEuler,
                              SoftMethod::FastMassSpring}) {
        DYNAMIC_SECTION(soft_method_name(method)) {
            const Shape wall = make_box(Vec3(Real(0.05), 1, 1));
            const Transform wall_xf{Vec3(1, 0, 0), Quat::Identity()};
            SoftOnly s;
            const SoftBodyId id = s.soft.create_body(small_cloth(method, 0));
            for (Vec3& v : s.soft.body(id).p.v) v = Vec3(50, 0, 0);
            s.soft.colliders().push_back(make_collider(wall, wall_xf));
            const Real face = Real(0.95);
            Real furthest = 0;
            bool touched = false;
            for (int k = 0; k < 30; ++k) {
                s.pipeline.step(Real(1) / 60);
                for (const Vec3& x : s.soft.body(id).p.x) furthest = std::max(furthest, x.x());
                touched = touched || !s.soft.contacts().empty();
            }
            CHECK(touched);
            // Every particle stays in front of the near face (its centre within the thickness, and the
            // round-off of the projection).
            CHECK(furthest < face - Real(0.01) + Real(1e-4));
        }
    }
}

TEST_CASE("continuous collision: a paddle swung at 50 m/s through a hanging cloth carries it instead of passing it", "[soft][collision][continuous]") {
    // The particles barely move; the paddle crosses the cloth's plane within one step. Followed in the
    // paddle's frame, each particle's path enters its front face (particle_collision.cpp).
    for (SoftMethod method : {SoftMethod::Verlet, SoftMethod::ImplicitEuler, SoftMethod::FastMassSpring}) {
        DYNAMIC_SECTION(soft_method_name(method)) {
            const Shape paddle = make_box(Vec3(Real(0.05), 1, 1));
            SoftOnly s;
            const SoftBodyId id = s.soft.create_body(small_cloth(method, 1));
            const Real h = Real(1) / 60, speed = 50;
            s.soft.colliders().push_back(make_collider(paddle, {}));
            Real behind = 0;  // the furthest any particle ends behind the paddle's front face
            for (int k = 1; k <= 4; ++k) {
                Collider& c = s.soft.colliders()[0];
                c.xf.p = Vec3(speed * h * Real(k) - Real(0.5), 0, 0);  // where the paddle ends this step
                c.com = c.xf.p;
                c.v = Vec3(speed, 0, 0);
                c.box = paddle.bounds(c.xf);
                s.pipeline.step(h);
                const Real front = c.xf.p.x() + Real(0.05);
                for (const Vec3& x : s.soft.body(id).p.x) behind = std::max(behind, front - x.x());
            }
            // The paddle passed x = 1 in the second step; every particle stays in front of it (within
            // its thickness and round-off).
            CHECK(behind < Real(1e-3));
        }
    }
}

TEST_CASE("one-way coupling: a kinematic box pushes particles, attached particles follow their body", "[soft][collision]") {
    WorldSettings ws;
    ws.rigid.gravity = Vec3::Zero();
    World world(ws);
    BodyDef pusher;
    pusher.type = BodyType::Kinematic;
    pusher.shape = make_box(Vec3::Constant(Real(0.5)));
    pusher.pose.p = Vec3(-1, 0, 0);
    pusher.linear_velocity = Vec3(1, 0, 0);
    const BodyId box = world.rigid().create_body(pusher);
    // A rope lying across the box's path along z.
    SoftBodyDef rope_base;
    rope_base.allow_sleep = false;
    const SoftBodyId rope = world.soft().create_body(
        make_rope(Vec3(0, 0, -Real(0.3)), Vec3(0, 0, Real(0.3)), 6, Real(0.1), LinkMaterial{}, rope_base));
    for (int k = 0; k < 120; ++k) world.step();  // 2 s: the box front moves from -0.5 to 1.5
    const Transform xf = world.rigid().transform(box);
    const Particles& p = world.soft().body(rope).p;
    for (std::size_t i = 0; i < p.size(); ++i) {
        INFO("particle " << i);
        // Carried in front of the box at its speed (no gravity, no friction needed: it is pushed).
        CHECK(p.x[i].x() >= xf.p.x() + Real(0.5));
        CHECK(p.v[i].x() == Approx(1).margin(0.05));
    }

    // Attachment: a particle follows a point of a spinning kinematic body exactly.
    BodyDef arm;
    arm.type = BodyType::Kinematic;
    arm.shape = make_box(Vec3(1, Real(0.1), Real(0.1)));
    arm.pose.p = Vec3(0, 5, 0);
    arm.angular_velocity = Vec3(0, 0, 2);
    const BodyId arm_id = world.rigid().create_body(arm);
    SoftBodyDef hang = make_rope(Vec3(1, 5, 0), Vec3(1, 4, 0), 5, Real(0.1), LinkMaterial{}, rope_base);
    Attachment a;
    a.particle = 0;
    a.target = pack_body_id(arm_id);
    a.local_point = Vec3(1, 0, 0);
    hang.attachments.push_back(a);
    const SoftBodyId hanging = world.soft().create_body(hang);
    for (int k = 0; k < 45; ++k) {
        world.step();
        const Vec3 expected = world.rigid().transform(arm_id).apply(Vec3(1, 0, 0));
        CHECK((world.soft().body(hanging).p.x[0] - expected).norm() < 1e-5);
    }
    // Once the body is gone the particle stays where it was; nothing dangles on a stale id.
    const Vec3 last = world.soft().body(hanging).p.x[0];
    world.rigid().destroy_body(arm_id);
    for (int k = 0; k < 10; ++k) world.step();
    CHECK((world.soft().body(hanging).p.x[0] - last).norm() < 1e-6);
}

TEST_CASE("a soft body at rest falls asleep, a box dropped on it wakes it", "[soft][sleep]") {
    World world;
    BodyDef ground;
    ground.type = BodyType::Static;
    ground.shape = make_box(Vec3(5, Real(0.5), 5));
    ground.pose.p = Vec3(0, Real(-0.5), 0);
    world.rigid().create_body(ground);
    ClothGridDesc c;
    c.nx = c.ny = 12;
    c.origin = Vec3(-1, Real(0.02), -1);
    c.edge_u = Vec3(2, 0, 0);
    c.edge_v = Vec3(0, 0, 2);
    const SoftBodyId cloth = world.soft().create_body(make_cloth_grid(c));
    int slept_at = -1;
    for (int k = 0; k < 240 && slept_at < 0; ++k) {
        world.step();
        if (!world.soft().awake(cloth)) slept_at = k;
    }
    INFO("fell asleep at step " << slept_at);
    REQUIRE(slept_at >= 0);
    REQUIRE(slept_at < 120);  // a flat cloth on the ground is still within sleep_time (0.5 s) + settling
    BodyDef crate;
    crate.shape = make_box(Vec3::Constant(Real(0.2)));
    crate.pose.p = Vec3(0, 1, 0);
    world.rigid().create_body(crate);
    bool woke = false;
    for (int k = 0; k < 60 && !woke; ++k) {
        world.step();
        woke = world.soft().awake(cloth);
    }
    CHECK(woke);
}

TEST_CASE("bad soft body definitions are rejected by name and leave the system unchanged", "[soft][errors]") {
    SoftSystem soft;
    const SoftBodyId keep = soft.create_body(single_particle(Vec3::Zero(), SoftMethod::Verlet));
    auto expect_error = [&](SoftBodyDef d, const std::string& fragment) {
        INFO("expected an error containing: " << fragment);
        try {
            soft.create_body(std::move(d));
            FAIL("accepted");
        } catch (const SoftError& e) {
            CHECK_THAT(e.what(), Catch::Contains(fragment));
        }
        CHECK(soft.body_count() == 1);
        CHECK(soft.valid(keep));
    };
    const Real nan = std::numeric_limits<Real>::quiet_NaN();
    SoftBodyDef d = single_particle(Vec3::Zero(), SoftMethod::Verlet);
    d.positions.push_back(Vec3(1, 0, 0));
    d.masses.push_back(Real(0.1));
    d.links.push_back({0, 1, 1});

    { auto b = d; b.positions[1].y() = nan; expect_error(b, "positions[1] must be finite"); }
    { auto b = d; b.masses[0] = -1; expect_error(b, "masses[0] must be > 0"); }
    { auto b = d; b.masses.pop_back(); expect_error(b, "masses has 1 entries for 2 positions"); }
    { auto b = d; b.links[0].b = 7; expect_error(b, "links[0].b = 7 is out of range (2 particles)"); }
    { auto b = d; b.links[0].b = 0; expect_error(b, "links[0] joins particle 0 to itself"); }
    { auto b = d; b.links[0].rest = 0; expect_error(b, "links[0].rest must be > 0"); }
    { auto b = d; b.pinned = {2}; expect_error(b, "pinned[0] = 2 is out of range"); }
    { auto b = d; b.triangles = {0, 1}; expect_error(b, "not a multiple of 3"); }
    { auto b = d; b.thickness = 0; expect_error(b, "thickness must be > 0"); }
    { auto b = d; b.restitution = 2; expect_error(b, "restitution must be in [0, 1]"); }
    { auto b = d; b.pressure = 5; expect_error(b, "needs a closed triangle surface"); }
    { auto b = d; b.method = static_cast<SoftMethod>(42); expect_error(b, "method = 42 is not a soft method"); }
    { auto b = d; b.positions.clear(); b.masses.clear(); b.links.clear(); expect_error(b, "positions is empty"); }

    // Stale handles.
    const SoftBodyId gone = soft.create_body(d);
    soft.destroy_body(gone);
    CHECK_FALSE(soft.valid(gone));
    CHECK_THROWS_WITH(soft.body(gone), Catch::Contains("stale or unknown soft body id"));
    CHECK_THROWS_WITH(soft.apply_particle_force(keep, 5, Vec3::Zero()), Catch::Contains("particle 5 is out of range"));
    CHECK_THROWS_WITH(soft.apply_particle_force(keep, 0, Vec3(nan, 0, 0)), Catch::Contains("force must be finite"));
    const SoftBodyId reused = soft.create_body(d);
    CHECK(reused.index == gone.index);
    CHECK(reused.generation != gone.generation);
}

TEST_CASE("changing pins after creation: fast mass-spring with nothing free, LRA rebuilt, attached particles refused", "[soft][errors]") {
    SoftOnly s;
    // A fast mass-spring rope that has stepped (its matrix is factored), then has every particle pinned:
    // nothing is free, the step must solve nothing and leave it where it is.
    SoftBodyDef base;
    base.method = SoftMethod::FastMassSpring;
    base.allow_sleep = false;
    const SoftBodyId rope = s.soft.create_body(make_rope(Vec3(0, 2, 0), Vec3(1, 2, 0), 4, 1, LinkMaterial{}, base));
    s.pipeline.step(Real(1) / 60);
    for (std::uint32_t i = 0; i < 5; ++i) s.soft.set_pinned(rope, i, true);
    const std::vector<Vec3> held = s.soft.body(rope).p.x;
    for (int k = 0; k < 5; ++k) s.pipeline.step(Real(1) / 60);
    for (std::uint32_t i = 0; i < 5; ++i) CHECK(s.soft.body(rope).p.x[i] == held[i]);
    // Freeing one again: it falls.
    s.soft.set_pinned(rope, 2, false);
    for (int k = 0; k < 5; ++k) s.pipeline.step(Real(1) / 60);
    CHECK(s.soft.body(rope).p.x[2].y() < held[2].y());

    // Long-range attachments follow the pins: a 6 x 6 cloth pinned at two corners has 2 x 34 tethers;
    // unpinning one corner leaves 35 free particles tethered to the other.
    ClothGridDesc c;
    c.nx = c.ny = 6;
    SoftBodyDef cb;
    cb.long_range_attachments = true;
    SoftBodyDef cloth_def = make_cloth_grid(c, cb);
    cloth_def.pinned = {cloth_node(c, 0, 0), cloth_node(c, 5, 0)};
    const SoftBodyId cloth = s.soft.create_body(cloth_def);
    CHECK(s.soft.body(cloth).lra.size() == 2 * 34);
    s.soft.set_pinned(cloth, cloth_node(c, 5, 0), false);
    CHECK(s.soft.body(cloth).lra.size() == 35);

    // An attached particle is moved by its attachment: pinning or freeing it is refused by name.
    SoftBodyDef att = make_rope(Vec3(0, 1, 0), Vec3(1, 1, 0), 2, 1, LinkMaterial{});
    Attachment a;
    a.particle = 0;
    att.attachments.push_back(a);
    const SoftBodyId hung = s.soft.create_body(att);
    CHECK_THROWS_WITH(s.soft.set_pinned(hung, 0, false), Catch::Contains("particle 0 is attached to a rigid body"));
}

TEST_CASE("a cloth whose filter leaves out the sphere falls through it onto the ground, from a scene file", "[soft][collision][filter]") {
    // cloth-drop with filters: the sphere is category 2, the cloth's mask leaves it out. The cloth then
    // never touches the sphere and lies flat on the ground; with the mask restored at run time it drapes.
    SceneDesc scene = parse_scene_file(kScenes + "cloth-drop.json");
    REQUIRE(scene.bodies.size() >= 2);
    scene.bodies[1].def.filter = {2, 0xFFFFFFFFu, 0};
    REQUIRE(scene.soft_bodies.size() == 1);
    scene.soft_bodies[0].def.filter = {1, ~2u, 0};
    std::vector<BodyId> ids;
    auto world = build_world(scene, &ids);
    const SoftBodyId cloth = world->soft().bodies().at(0);
    CHECK(world->soft().body(cloth).def.filter.mask == ~2u);
    const Shape& ball = world->rigid().shape(ids[1]);
    const Transform xb = world->rigid().transform(ids[1]);
    const Real r = world->soft().body(cloth).def.thickness;
    Real inside = 0;  // deepest a particle centre got into the sphere
    std::size_t with_sphere = 0, with_ground = 0;
    for (int step = 0; step < 240; ++step) {
        world->step();
        for (const ParticleContact& c : world->soft().contacts())
            (world->soft().colliders()[c.collider].owner == ids[1].index ? with_sphere : with_ground) += 1;
        for (const Vec3& x : world->soft().body(cloth).p.x) inside = std::min(inside, signed_distance(x, ball, xb));
    }
    CHECK(with_sphere == 0);
    CHECK(with_ground > 0);
    CHECK(inside < Real(-0.1));  // through the sphere
    Real highest = -kRealMax;
    for (const Vec3& x : world->soft().body(cloth).p.x) highest = std::max(highest, x.y());
    CHECK(highest < r + Real(0.05));  // flat on the ground (top face y = 0), not draped over the sphere

    // Filters reach the colliders at run time: with the mask admitting the sphere again, a fresh drop
    // drapes over it (its top particle stays above the ground by more than the thickness).
    auto again = build_world(scene, &ids);
    const SoftBodyId c2 = again->soft().bodies().at(0);
    again->soft().set_filter(c2, CollisionFilter{});
    for (int step = 0; step < 240; ++step) again->step();
    Real top = -kRealMax;
    for (const Vec3& x : again->soft().body(c2).p.x) top = std::max(top, x.y());
    CHECK(top > Real(0.5));
}

// ---- soft bodies against soft bodies (soft/soft_contacts.hpp) ------------------------------------------

namespace {

// A 0.3 m FEM cube of 2 x 2 x 2 cells (40 tets, 400 kg/m^3: 10.8 kg), implicit Euler, as the cubes of
// demos/scenes/stack-of-soft-cubes.json.
SoftBodyDef soft_cube(const Vec3& min_corner, const Vec3& velocity = Vec3::Zero()) {
    SoftBodyDef d;
    d.method = SoftMethod::ImplicitEuler;
    d.iterations = 100;
    d.cg_tolerance = Real(1e-3);
    d.fem.young = Real(2e5);
    d.fem.poisson = Real(0.3);
    d.fem.density = 400;
    d.fem.stiffness_damping = Real(0.02);
    d.thickness = Real(0.005);
    d.friction = Real(0.6);
    d.initial_velocity = velocity;
    d.allow_sleep = false;
    return make_tet_body(make_tet_box(min_corner, Vec3::Constant(Real(0.3)), 2, 2, 2), d);
}

Vec3 centre_of_mass(const Particles& p) {
    Vec3 s = Vec3::Zero();
    Real m = 0;
    for (std::size_t i = 0; i < p.size(); ++i) {
        s += p.mass[i] * p.x[i];
        m += p.mass[i];
    }
    return s / m;
}

Vec3 momentum(const Particles& p) {
    Vec3 s = Vec3::Zero();
    for (std::size_t i = 0; i < p.size(); ++i) s += p.mass[i] * p.v[i];
    return s;
}

// Winding number of a closed triangle surface about x (1 inside, 0 outside): the solid angles of its
// triangles over 4 pi (Van Oosterom & Strackee 1983).
double winding_number(const Vec3& x, const std::vector<std::uint32_t>& tris, const std::vector<Vec3>& pts) {
    double sum = 0;
    for (std::size_t t = 0; t + 2 < tris.size(); t += 3) {
        const Eigen::Vector3d a = (pts[tris[t]] - x).cast<double>();
        const Eigen::Vector3d b = (pts[tris[t + 1]] - x).cast<double>();
        const Eigen::Vector3d c = (pts[tris[t + 2]] - x).cast<double>();
        const double la = a.norm(), lb = b.norm(), lc = c.norm();
        sum += 2 * std::atan2(a.dot(b.cross(c)), la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb);
    }
    return sum / (4 * 3.14159265358979323846);
}

// How many particles of body p are inside the closed surface of body q.
int particles_inside(const SoftBody& p, const SoftBody& q) {
    int n = 0;
    for (const Vec3& x : p.p.x) n += winding_number(x, q.triangles, q.p.x) > 0.5 ? 1 : 0;
    return n;
}

void add_ground(World& world) {
    BodyDef ground;
    ground.type = BodyType::Static;
    ground.shape = make_box(Vec3(5, Real(0.5), 5));
    ground.pose.p = Vec3(0, Real(-0.5), 0);
    ground.material.friction = Real(0.6);
    world.rigid().create_body(ground);
}

}  // namespace

TEST_CASE("two soft cubes thrown at each other bounce apart with their momentum conserved", "[soft][collision][soft-soft]") {
    // Gravity off, two 10.8 kg FEM cubes at 1 m/s towards each other, offset by a third of a side so
    // corners and faces meet. Every impulse of the pass is shared between the two bodies (soft_contacts.hpp)
    // and their elements' forces are internal, so the total momentum stays 0 to round-off: 1e-4 of either
    // cube's 10.8 N s in float (a step's sums over 27 nodes of float products carry about 1e-6 relative).
    SoftSettings s;
    s.gravity = Vec3::Zero();
    s.sleeping = false;
    SoftSystem soft(s);
    SoftBodyDef left = soft_cube(Vec3(Real(-0.32), 0, 0), Vec3(1, 0, 0));
    SoftBodyDef right = soft_cube(Vec3(Real(0.02), Real(0.1), Real(0.1)), Vec3(-1, 0, 0));
    // CG stopped at a relative residual r leaves momentum errors of about r times the step's impulses.
    left.cg_tolerance = right.cg_tolerance = Real(1e-6);
    const SoftBodyId a = soft.create_body(left);
    const SoftBodyId b = soft.create_body(right);
    const Real p_one = momentum(soft.body(a).p).norm();
    REQUIRE(p_one == Approx(10.8).epsilon(0.01));
    Pipeline pipeline;
    pipeline.add_system(&soft);
    int touched = 0;
    int inside = 0;
    for (int k = 0; k < 90; ++k) {
        pipeline.step(Real(1) / 60);
        touched += soft.soft_contacts().empty() ? 0 : 1;
        // No node of either cube ends a step inside the other.
        inside = std::max(inside, particles_inside(soft.body(a), soft.body(b)) + particles_inside(soft.body(b), soft.body(a)));
        const Vec3 total = momentum(soft.body(a).p) + momentum(soft.body(b).p);
        INFO("step " << k);
        REQUIRE(total.norm() < 1e-4 * p_one);
    }
    INFO("steps in contact " << touched);
    CHECK(touched > 0);
    CHECK(inside == 0);
    // They came back apart: the left cube moves left, the right one right.
    CHECK(momentum(soft.body(a).p).x() < 0);
    CHECK(momentum(soft.body(b).p).x() > 0);
    CHECK(centre_of_mass(soft.body(a).p).x() < centre_of_mass(soft.body(b).p).x() - Real(0.3));
}

TEST_CASE("a soft cube resting on another: the contacts carry its weight, 1 cm of thickness between them", "[soft][collision][soft-soft]") {
    // The upper cube at rest takes from the soft-soft contacts, per step, the momentum gravity gives it:
    // m g h = 10.8 * 9.81 / 60 = 1.766 N s (measured 1.7635 after 2 s, 0.15 % short while it still
    // settles: 1 % allowed). The surfaces stay the two thicknesses (1 cm) apart within 1 mm.
    World world;
    add_ground(world);
    const SoftBodyId lower = world.soft().create_body(soft_cube(Vec3(Real(-0.15), Real(0.005), Real(-0.15))));
    const SoftBodyId upper = world.soft().create_body(soft_cube(Vec3(Real(-0.15), Real(0.315), Real(-0.15))));
    for (int k = 0; k < 150; ++k) world.step();
    REQUIRE(world.soft().all_finite());
    double carried = 0;
    for (int k = 0; k < 30; ++k) {
        world.step();
        Real up = 0;
        for (const SoftSoftContact& c : world.soft().soft_contacts()) {
            if (c.body == upper.index) up += c.impulse * c.normal.y();
            if (c.other == upper.index) up -= c.impulse * c.normal.y();
        }
        carried += up / 30;
    }
    const double weight = 10.8 * 9.81 / 60;
    CHECK(carried == Approx(weight).epsilon(0.01));
    Real top = -kRealMax, bottom = kRealMax;
    for (const Vec3& x : world.soft().body(lower).p.x) top = std::max(top, x.y());
    for (const Vec3& x : world.soft().body(upper).p.x) bottom = std::min(bottom, x.y());
    CHECK(bottom - top == Approx(0.01).margin(0.001));
}

TEST_CASE("a cloth dropped on a soft block drapes over it, a sleeping block wakes, a filter lets it through", "[soft][collision][soft-soft]") {
    // A 12 x 12 Verlet cloth (1 m) dropped from 0.3 m onto a sleeping 0.3 m FEM cube: the falling cloth
    // wakes the cube, and after 2 s no cloth particle over the cube's top face is below it (the 0.5 cm
    // thicknesses apart, 2 mm allowed for the sag between the cube's nodes). With filters that exclude
    // each other the cloth falls through the cube to the ground.
    for (bool filtered : {false, true}) {
        INFO((filtered ? "filtered" : "colliding"));
        World world;
    add_ground(world);
        SoftBodyDef cube = soft_cube(Vec3(Real(-0.15), 0, Real(-0.15)));
        cube.allow_sleep = true;
        if (filtered) cube.filter.category = 2, cube.filter.mask = ~std::uint32_t(2);
        const SoftBodyId block = world.soft().create_body(cube);
        for (int k = 0; k < 120; ++k) world.step();
        REQUIRE_FALSE(world.soft().awake(block));
        ClothGridDesc c;
        c.nx = c.ny = 12;
        c.origin = Vec3(Real(-0.5), Real(0.6), Real(-0.5));
        c.edge_u = Vec3(1, 0, 0);
        c.edge_v = Vec3(0, 0, 1);
        c.total_mass = Real(0.2);
        SoftBodyDef base;
        base.thickness = Real(0.005);
        base.allow_sleep = false;
        if (filtered) base.filter.category = 4, base.filter.mask = ~std::uint32_t(2);
        const SoftBodyId cloth = world.soft().create_body(make_cloth_grid(c, base));
        bool woke = false;
        for (int k = 0; k < 120; ++k) {
            world.step();
            woke |= world.soft().awake(block);
        }
        REQUIRE(world.soft().all_finite());
        Real top = -kRealMax;
        for (const Vec3& x : world.soft().body(block).p.x) top = std::max(top, x.y());
        Real lowest_over = kRealMax;
        for (const Vec3& x : world.soft().body(cloth).p.x)
            if (std::abs(x.x()) < Real(0.14) && std::abs(x.z()) < Real(0.14)) lowest_over = std::min(lowest_over, x.y());
        INFO("block top " << top << " m, lowest cloth particle over it " << lowest_over << " m");
        if (!filtered) {
            CHECK(woke);
            CHECK(lowest_over > top + Real(0.008));
        } else {
            CHECK(lowest_over < Real(0.02));  // on the ground, through the cube
        }
    }
}

namespace {

// A 1 m square of two triangles in the plane through `centre` spanned by unit directions u and v (its
// edges along them), 0.2 kg, `method`, 1 cm thick. Links of 400 N/m, 50 under semi-implicit Euler: a
// corner of 0.05 kg on up to three links has omega ~ sqrt(2 * 3 k / m), omega h = 1.3 at 60 Hz (< 2).
SoftBodyDef square(const Vec3& centre, const Vec3& u, const Vec3& v, SoftMethod method) {
    const Real hs = Real(0.5);
    const std::vector<Vec3> x = {centre - hs * u - hs * v, centre + hs * u - hs * v, centre + hs * u + hs * v,
                                 centre - hs * u + hs * v};
    SoftBodyDef base;
    base.method = method;
    base.thickness = Real(0.01);
    base.allow_sleep = false;
    base.iterations = method == SoftMethod::ImplicitEuler ? 50 : 10;
    LinkMaterial m;
    m.stretch = m.shear = method == SoftMethod::SemiImplicitEuler ? 50 : 400;
    return make_mesh_body(x, {0, 1, 2, 0, 2, 3}, 1, Real(0.2), m, base);
}

// Closest distance between segments p0-p1 and q0-q1.
Real segment_distance(const Vec3& p0, const Vec3& p1, const Vec3& q0, const Vec3& q1) {
    Real s = 0, t = 0;
    closest_segment_params(p0, p1 - p0, q0, q1 - q0, s, t);
    return (p0 + s * (p1 - p0) - q0 - t * (q1 - q0)).norm();
}

}  // namespace

TEST_CASE("edge on edge: a square dropped edge-first across another's edge rests on it, momentum kept", "[soft][collision][soft-soft]") {
    // Two squares standing in perpendicular vertical planes: the lower one (x = 0) held by its four
    // corners, its top edge along z at y = 1; the upper one (z = 0) falls from 0.2 m above with its bottom
    // edge along x. They meet edge on edge at (0, 1, 0), half a metre from every particle: no particle
    // comes near the other's triangles, so only the edge-edge contact can hold it (without it the square
    // fell through). While it balances there (it topples off within a second), the two edges stay the two
    // thicknesses (2 cm) apart, within 1 mm of the position sweeps' tolerance, under every soft method.
    for (SoftMethod method : {SoftMethod::Verlet, SoftMethod::SemiImplicitEuler, SoftMethod::ImplicitEuler, SoftMethod::FastMassSpring}) {
        INFO(soft_method_name(method));
        SoftOnly s;
        SoftBodyDef lower = square(Vec3(0, Real(0.5), 0), Vec3::UnitZ(), Vec3::UnitY(), method);
        lower.pinned = {0, 1, 2, 3};
        const SoftBodyId lo = s.soft.create_body(lower);
        const SoftBodyId up = s.soft.create_body(square(Vec3(0, Real(1.72), 0), Vec3::UnitX(), Vec3::UnitY(), method));
        Real closest = kRealMax;
        int touched = 0;
        for (int k = 0; k < 30; ++k) {
            s.pipeline.step(Real(1) / 60);
            const std::vector<Vec3>& a = s.soft.body(up).p.x;
            const std::vector<Vec3>& b = s.soft.body(lo).p.x;
            closest = std::min(closest, segment_distance(a[0], a[1], b[3], b[2]));
            touched += s.soft.soft_edge_contacts().empty() ? 0 : 1;
        }
        INFO("closest " << closest << " m, steps touching " << touched);
        REQUIRE(s.soft.all_finite());
        CHECK(touched > 10);
        CHECK(closest > Real(0.019));
        CHECK(s.soft.body(up).p.x[0].y() > Real(0.95));  // still up there, not through
    }
    // Gravity off, both free, thrown at each other edge first at 1 m/s each: the pass's impulses are
    // equal and opposite, so the total momentum stays zero to float rounding, and they part.
    SoftSettings settings;
    settings.gravity = Vec3::Zero();
    SoftOnly s(settings);
    SoftBodyDef lower = square(Vec3(0, Real(0.5), 0), Vec3::UnitZ(), Vec3::UnitY(), SoftMethod::Verlet);
    SoftBodyDef upper = square(Vec3(0, Real(1.53), 0), Vec3::UnitX(), Vec3::UnitY(), SoftMethod::Verlet);
    lower.initial_velocity = Vec3(0, 1, 0);
    upper.initial_velocity = Vec3(0, -1, 0);
    const SoftBodyId lo = s.soft.create_body(lower);
    const SoftBodyId up = s.soft.create_body(upper);
    const auto momentum = [&] {
        Vec3 p = Vec3::Zero();
        for (SoftBodyId id : {lo, up})
            for (std::size_t i = 0; i < 4; ++i) p += s.soft.body(id).p.mass[i] * s.soft.body(id).p.v[i];
        return p;
    };
    int touched = 0;
    for (int k = 0; k < 30; ++k) {
        s.pipeline.step(Real(1) / 60);
        touched += s.soft.soft_edge_contacts().empty() ? 0 : 1;
        CHECK(momentum().norm() < Real(1e-5));  // against 0.4 N s each way
    }
    CHECK(touched > 0);
    const Real apart = s.soft.body(up).p.x[0].y() - s.soft.body(lo).p.x[3].y();
    CHECK(apart > Real(0.02));
}

TEST_CASE("self-collision: a folded cloth's upper layer comes to rest on its lower layer, not through it", "[soft][collision][soft-soft]") {
    // A 2 m x 1 m implicit cloth (21 x 11 nodes, 10 cm apart) lying on the ground folded in half along
    // x = 1 m: the lower layer at y = 1 cm, the upper layer laid back over it at 5 cm (the fold is its
    // rest shape). Gravity brings the upper layer down. With self_collision its particles come to rest on
    // the lower layer, the two thicknesses (2 cm) above it within 3 mm (measured 20.0-21.4 mm);
    // without, they fall through onto the ground, level with the lower layer.
    for (bool self : {true, false}) {
        INFO("self_collision " << self);
        World world;
        add_ground(world);
        std::vector<Vec3> v;
        std::vector<std::uint32_t> idx;
        const int nx = 21, nz = 11;
        for (int i = 0; i < nx; ++i)
            for (int k = 0; k < nz; ++k) {
                const bool upper = i > 10;
                v.push_back(Vec3(Real(0.1) * Real(upper ? 20 - i : i), upper ? Real(0.05) : Real(0.01), Real(0.1) * Real(k)));
            }
        for (int i = 0; i + 1 < nx; ++i)
            for (int k = 0; k + 1 < nz; ++k) {
                const std::uint32_t a = std::uint32_t(i * nz + k), b = a + nz, c = b + 1, d = a + 1;
                idx.insert(idx.end(), {a, d, c, a, c, b});
            }
        SoftBodyDef base;
        base.method = SoftMethod::ImplicitEuler;
        base.thickness = Real(0.01);
        base.self_collision = self;
        base.allow_sleep = false;
        const SoftBodyId cloth = world.soft().create_body(make_mesh_body(v, idx, 1, Real(0.5), LinkMaterial{}, base));
        for (int k = 0; k < 120; ++k) world.step();
        REQUIRE(world.soft().all_finite());
        const Particles& p = world.soft().body(cloth).p;
        // The upper layer away from the fold (x <= 0.7 m, nodes i >= 13) and from its rim (a particle over
        // the lower layer's edge has half its triangles under it: 13-17 mm there) against the node under it.
        Real lowest_gap = kRealMax, highest_gap = -kRealMax;
        for (int i = 13; i + 1 < nx; ++i)
            for (int k = 1; k + 1 < nz; ++k) {
                const Real gap = p.x[std::size_t(i * nz + k)].y() - p.x[std::size_t((20 - i) * nz + k)].y();
                lowest_gap = std::min(lowest_gap, gap);
                highest_gap = std::max(highest_gap, gap);
            }
        INFO("upper layer above the lower: " << lowest_gap << " to " << highest_gap << " m");
        if (self) {
            CHECK(lowest_gap > Real(0.017));
            CHECK(highest_gap < Real(0.023));
        } else {
            CHECK(std::abs(lowest_gap) < Real(0.005));
        }
    }
}

TEST_CASE("fast mass-spring holds soft-soft contacts inside its global step: pressure balls do not merge",
          "[soft][collision][soft-soft][fast-ms]") {
    // hard-soft-collide: two fast mass-spring pressure balls (0.5 kg, r 0.3 m) thrown at each other at
    // 3 m/s each, gravity off. With the soft-soft contacts only in the pass after the solve, 226 of the
    // 324 particles ended inside the other ball (they deflated and merged). Held as rows of the global
    // step (each ball against the other's surface where the step starts), none does, and both keep their
    // volume within 10% (the bench's VolumeCheck; measured 0.98). The rows of the two balls are not paired
    // impulses (each ball holds against the other's surface on its own), so the total momentum drifts
    // during the impact: measured at most 0.029 N s, 1.9% of one ball's 1.5 N s; 3% allowed.
    SceneDesc scene = parse_scene_file(kScenes + "hard-soft-collide.json");
    std::unique_ptr<World> world = build_world(scene);
    const auto ids = world->soft().bodies();
    REQUIRE(ids.size() == 2);
    const SoftBody& a = world->soft().body(ids[0]);
    const SoftBody& b = world->soft().body(ids[1]);
    const Real volume0 = a.volume();
    int inside = 0;
    Real least_volume = 1, drift = 0;
    for (int k = 0; k < scene.steps; ++k) {
        world->step();
        REQUIRE(world->soft().all_finite());
        inside = std::max(inside, particles_inside(a, b) + particles_inside(b, a));
        least_volume = std::min({least_volume, a.volume() / volume0, b.volume() / volume0});
        drift = std::max(drift, (momentum(a.p) + momentum(b.p)).norm());
    }
    CHECK(inside == 0);
    CHECK(least_volume > Real(0.9));
    CHECK(drift < Real(0.03 * 1.5));
}

TEST_CASE("fast mass-spring pressure balls stacked three high stay finite and out of each other",
          "[soft][collision][soft-soft][fast-ms]") {
    // Held against each other's predicted surfaces, both balls of a contact took its whole reaction and
    // this stack blew up within 2 s (1.7e7 J); with the contacts in the pass alone the balls were crushed
    // inside out through the ground. Now the stack stands, topples (balls on balls) and the three come to
    // lie on the ground (measured: volumes 0.96-0.97 at rest). Asserted: finite; kinetic energy below the
    // stack's potential energy over the ground (9.1 J); no particle below y = -1 cm (they rest at +1 cm,
    // their thickness: two thicknesses of slack for the landing); volumes within 15%.
    SceneDesc scene = parse_scene_file(kScenes + "hard-soft-collide.json");
    scene.settings.rigid.gravity = Vec3(0, Real(-9.81), 0);
    const SceneSoftBody proto = scene.soft_bodies[0];
    scene.soft_bodies.clear();
    for (int k = 0; k < 3; ++k) {
        SceneSoftBody s = proto;
        s.name = "ball-" + std::to_string(k);
        for (Vec3& x : s.def.positions) x += Vec3(Real(0.5), Real(0.31 + 0.62 * k) - 1, 0);
        s.def.initial_velocity = Vec3::Zero();
        scene.soft_bodies.push_back(s);
    }
    SceneBody ground;
    ground.name = "ground";
    ground.def.type = BodyType::Static;
    ground.def.shape = make_box(Vec3(5, Real(0.5), 5));
    ground.def.pose.p = Vec3(0, Real(-0.5), 0);
    scene.bodies.push_back(ground);
    std::unique_ptr<World> world = build_world(scene);
    std::vector<Real> volume0;
    for (const SoftBodyId id : world->soft().bodies()) volume0.push_back(world->soft().body(id).volume());
    Real most_energy = 0, lowest = kRealMax, least_volume = 1;
    int inside = 0;
    for (int k = 0; k < 300; ++k) {
        world->step();
        REQUIRE(world->soft().all_finite());
        Real energy = 0;
        const auto ids = world->soft().bodies();
        for (std::size_t j = 0; j < ids.size(); ++j) {
            const SoftBody& b = world->soft().body(ids[j]);
            for (std::size_t i = 0; i < b.p.size(); ++i) {
                energy += Real(0.5) * b.p.mass[i] * b.p.v[i].squaredNorm();
                lowest = std::min(lowest, b.p.x[i].y());
            }
            least_volume = std::min(least_volume, b.volume() / volume0[j]);
            for (std::size_t q = 0; q < ids.size(); ++q)
                if (q != j) inside = std::max(inside, particles_inside(b, world->soft().body(ids[q])));
        }
        most_energy = std::max(most_energy, energy);
    }
    CHECK(most_energy < Real(9.1));
    CHECK(lowest > Real(-0.01));
    CHECK(least_volume > Real(0.85));
    CHECK(inside == 0);
}
