// Scene loader: good files give exactly the settings and bodies they state; every bad file in
// tests/data/scenes/bad/ is rejected with the JSON pointer and problem listed in its EXPECTED.tsv.
#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <set>
#include <sstream>

#include "engine/world/scene.hpp"

using namespace sinew;
using Catch::Matchers::Contains;

namespace {

const std::string kScenes = std::string(SINEW_SOURCE_DIR) + "/tests/data/scenes";

// Values parsed from decimal text are rounded once to Real; comparisons allow a few ulps of that.
const Real kTol = 8 * kEpsilon;

struct BadCase {
    std::string file, json_path, fragment;
};

std::vector<BadCase> bad_cases() {
    std::ifstream in(kScenes + "/bad/EXPECTED.tsv");
    REQUIRE(in);
    std::vector<BadCase> cases;
    std::string line;
    while (std::getline(in, line)) {
        if (line.empty() || line[0] == '#') continue;
        std::istringstream ls(line);
        BadCase c;
        std::getline(ls, c.file, '\t');
        std::getline(ls, c.json_path, '\t');
        std::getline(ls, c.fragment);
        cases.push_back(c);
    }
    return cases;
}

const SceneBody& body_named(const SceneDesc& s, const std::string& name) {
    for (const SceneBody& b : s.bodies)
        if (b.name == name) return b;
    FAIL("no body named " << name);
    throw std::logic_error("unreachable");
}

bool near(const Vec3& a, const Vec3& b, Real tol = kTol) { return (a - b).cwiseAbs().maxCoeff() <= tol * (1 + b.norm()); }
bool near(const Quat& a, const Quat& b, Real tol = kTol) {
    // q and -q are the same rotation.
    return std::min((a.coeffs() - b.coeffs()).norm(), (a.coeffs() + b.coeffs()).norm()) <= tol;
}

}  // namespace

TEST_CASE("every bad scene file is rejected at the expected JSON pointer", "[scene]") {
    const std::vector<BadCase> cases = bad_cases();
    REQUIRE(cases.size() >= 40);

    // The table and the folder must agree, so a new bad file cannot go untested.
    std::set<std::string> listed, present;
    for (const BadCase& c : cases) listed.insert(c.file);
    for (const auto& entry : std::filesystem::directory_iterator(kScenes + "/bad"))
        if (entry.path().extension() == ".json") present.insert(entry.path().filename().string());
    CHECK(listed == present);

    for (const BadCase& c : cases) {
        INFO("file " << c.file);
        const std::string path = kScenes + "/bad/" + c.file;
        bool threw = false;
        try {
            build_world(parse_scene_file(path));  // some problems need the bodies (a joint's lever arm)
        } catch (const SceneError& e) {
            threw = true;
            INFO("what(): " << e.what());
            CHECK(e.file == path);
            CHECK(e.json_path == c.json_path);
            CHECK_THAT(e.problem, Contains(c.fragment));
            const std::string expected_what = path + ": " + (c.json_path.empty() ? "" : c.json_path + ": ") + e.problem;
            CHECK(std::string(e.what()) == expected_what);
        }
        CHECK(threw);
    }
}

TEST_CASE("what() reads FILE: POINTER: PROBLEM", "[scene]") {
    const std::string path = kScenes + "/bad/negative-mass.json";
    try {
        parse_scene_file(path);
        FAIL("no error");
    } catch (const SceneError& e) {
        CHECK(std::string(e.what()) == path + ": /bodies/3/mass: mass must be > 0, got -1");
    }
}

TEST_CASE("malformed JSON is reported with line and column", "[scene]") {
    // Line 3 column 12 is where the reader meets "bodies" instead of ',' or '}'.
    const std::string text = "{\n  \"format\": \"sinew-scene\",\n  \"version\": 1 \"bodies\": []\n}\n";
    try {
        parse_scene_string(text, "inline.json");
        FAIL("no error");
    } catch (const SceneError& e) {
        CHECK(e.json_path.empty());
        CHECK_THAT(e.problem, Contains("malformed JSON at line 3, column 16"));
    }
}

TEST_CASE("a missing scene file is a SceneError", "[scene]") {
    try {
        parse_scene_file(kScenes + "/no-such-scene.json");
        FAIL("no error");
    } catch (const SceneError& e) {
        CHECK(e.json_path.empty());
        CHECK_THAT(e.problem, Contains("cannot open scene file"));
    }
    CHECK_THROWS_AS(parse_scene_file(kScenes), SceneError);  // a directory
}

TEST_CASE("numbers too large for Real are rejected", "[scene]") {
    const std::string text = R"({"format": "sinew-scene", "version": 1,
        "bodies": [ { "shape": { "type": "sphere", "radius": 1e300 } } ] })";
    if (sizeof(Real) == 4) {
        try {
            parse_scene_string(text, "big.json");
            FAIL("no error");
        } catch (const SceneError& e) {
            CHECK(e.json_path == "/bodies/0/shape/radius");
            CHECK_THAT(e.problem, Contains("out of range for single precision"));
        }
    } else {
        // In double a 1e300 m sphere is representable; it fails later only because its mass overflows.
        CHECK_THROWS_AS(parse_scene_string(text, "big.json"), SceneError);
    }
}

TEST_CASE("a minimal scene has the documented defaults", "[scene]") {
    const SceneDesc s = parse_scene_file(kScenes + "/good/minimal.json");
    const WorldSettings def;
    CHECK(s.name == "minimal");
    CHECK(s.description.empty());
    CHECK(s.steps == 600);
    CHECK(s.bodies.empty());
    CHECK(s.settings.time_step == def.time_step);
    CHECK(s.settings.max_steps_per_frame == def.max_steps_per_frame);
    CHECK(s.settings.rigid.gravity == def.rigid.gravity);
    CHECK(s.settings.rigid.solver == def.rigid.solver);
    CHECK(s.settings.rigid.velocity_iterations == def.rigid.velocity_iterations);
    CHECK(s.settings.rigid.sleeping == def.rigid.sleeping);
}

TEST_CASE("every key of the full scene lands in WorldSettings and the bodies", "[scene]") {
    const SceneDesc s = parse_scene_file(kScenes + "/good/full.json");
    CHECK(s.name == "everything");
    CHECK_THAT(s.description, Contains("every key"));
    CHECK(s.steps == 123);

    const WorldSettings& w = s.settings;
    const RigidSettings& r = w.rigid;
    CHECK(w.time_step == Real(0.01));
    CHECK(w.max_steps_per_frame == 4);
    CHECK(r.gravity == Vec3(0, -10, Real(0.5)));
    CHECK(r.solver == RigidSolverKind::Newton);
    CHECK(r.velocity_iterations == 7);
    CHECK_FALSE(r.warm_starting);
    CHECK(r.baumgarte == Real(0.3));
    CHECK(r.linear_slop == Real(0.01));
    CHECK(r.restitution_threshold == Real(0.5));
    CHECK(r.contact_margin == Real(0.04));
    CHECK(r.max_correction_velocity == Real(2.5));
    CHECK(r.newton_collision_iterations == 3);
    CHECK(r.newton_contact_iterations == 12);
    CHECK_FALSE(r.newton_shock_propagation);
    CHECK(r.newton_projection_fraction == Real(0.4));
    CHECK_FALSE(r.sleeping);
    CHECK(r.sleep_linear_velocity == Real(0.1));
    CHECK(r.sleep_angular_velocity == Real(0.2));
    CHECK(r.sleep_time == Real(1.5));

    // 8 listed bodies, then the generator's 2 pyramids of 3 boxes.
    REQUIRE(s.bodies.size() == 8 + 6);

    const SceneBody& floor = body_named(s, "floor");
    CHECK(floor.def.type == BodyType::Static);
    CHECK(floor.def.shape.type == ShapeType::Plane);
    CHECK(near(floor.def.shape.normal, Vec3(0, 1, 0)));  // normalised by make_plane, offset with it
    CHECK(floor.def.shape.offset == Approx(-1));
    CHECK(floor.json_path == "/bodies/0");

    const SceneBody& ramp = body_named(s, "ramp");
    REQUIRE(ramp.def.shape.type == ShapeType::TriangleMesh);
    CHECK(ramp.def.shape.mesh->vertices.size() == 4);
    // The quad "f 1 4 3 2" is fanned into (0,3,2) and (0,2,1).
    CHECK(ramp.def.shape.mesh->indices == std::vector<std::uint32_t>{0, 3, 2, 0, 2, 1});
    CHECK(ramp.def.pose.p == Vec3(5, 0, 0));

    const SceneBody& tri = body_named(s, "tri");
    REQUIRE(tri.def.shape.type == ShapeType::TriangleMesh);
    CHECK(tri.def.shape.mesh->indices == std::vector<std::uint32_t>{0, 2, 1});

    const SceneBody& pusher = body_named(s, "pusher");
    CHECK(pusher.def.type == BodyType::Kinematic);
    CHECK(pusher.def.shape.half_extents == Vec3(1, Real(0.5), Real(0.25)));
    CHECK(pusher.def.linear_velocity == Vec3(1, 0, 0));
    CHECK(pusher.def.angular_velocity == Vec3(0, Real(0.5), 0));

    const SceneBody& ball = body_named(s, "ball1");
    CHECK(ball.def.type == BodyType::Dynamic);  // the default type
    CHECK(ball.def.shape.type == ShapeType::Sphere);
    CHECK(ball.def.shape.radius == Real(0.25));
    CHECK(ball.def.material.density == 1100);
    CHECK(ball.def.material.friction == Real(0.9));
    CHECK(ball.def.material.restitution == Real(0.8));
    CHECK(near(ball.def.pose.q, Quat::Identity()));  // [2,0,0,0] normalised
    CHECK(ball.def.linear_velocity == Vec3(0, -1, 0));
    CHECK(ball.def.mass == 0);  // from density

    const SceneBody& heavy = body_named(s, "heavy");
    CHECK(heavy.def.shape.type == ShapeType::ConvexHull);
    CHECK(heavy.def.mass == 5);
    CHECK(heavy.def.material.friction == Real(0.02));
    CHECK(heavy.def.material.density == Material{}.density);  // not given: default
    CHECK(heavy.def.pose.p == Vec3(1, 2, 3));
    // 90 degrees about x: (cos 45, sin 45, 0, 0).
    const Real h = std::sqrt(Real(0.5));
    CHECK(near(heavy.def.pose.q, Quat(h, h, 0, 0)));
    CHECK(heavy.def.linear_damping == Real(0.1));
    CHECK(heavy.def.angular_damping == Real(0.2));
    CHECK(heavy.def.gravity_scale == Real(0.5));
    CHECK_FALSE(heavy.def.allow_sleep);
    CHECK(heavy.def.user_data == 42);

    const SceneBody& bell = body_named(s, "bell");
    REQUIRE(bell.def.shape.type == ShapeType::Compound);
    REQUIRE(bell.def.shape.children->size() == 3);
    const auto& kids = *bell.def.shape.children;
    CHECK(kids[0].shape->type == ShapeType::Sphere);
    CHECK(kids[0].local.p == Vec3(Real(-0.5), 0, 0));
    CHECK(kids[2].shape->type == ShapeType::Capsule);
    // rotation_deg [0,0,90] turns the capsule's y axis onto -x.
    CHECK(near(Vec3(kids[2].local.q * Vec3::UnitY()), Vec3(-1, 0, 0)));
    CHECK(near(bell.def.pose.q, Quat(0, 0, Real(0.6), Real(0.8))));  // [0,0,3,4] / 5
    CHECK(bell.def.material.density == 500);

    const SceneBody& unnamed = s.bodies[7];
    CHECK(unnamed.name == "body-7");
    CHECK(unnamed.def.shape.type == ShapeType::Capsule);
    CHECK(unnamed.def.shape.half_height == Real(0.3));

    // Generator: copies centred on base.x at +-grid_spacing/2; bottom row at +-spacing/2 around each.
    struct Expect {
        const char* name;
        Vec3 p;
    };
    const Expect gen[] = {{"pyr/p0/r0/c0", Vec3(Real(-1.8), Real(1.25), 10)}, {"pyr/p0/r0/c1", Vec3(Real(-1.2), Real(1.25), 10)},
                          {"pyr/p0/r1/c0", Vec3(Real(-1.5), Real(1.75), 10)}, {"pyr/p1/r0/c0", Vec3(Real(1.2), Real(1.25), 10)},
                          {"pyr/p1/r0/c1", Vec3(Real(1.8), Real(1.25), 10)},  {"pyr/p1/r1/c0", Vec3(Real(1.5), Real(1.75), 10)}};
    for (const Expect& e : gen) {
        INFO(e.name);
        const SceneBody& b = body_named(s, e.name);
        CHECK(near(b.def.pose.p, e.p));
        CHECK(b.def.shape.half_extents == Vec3::Constant(Real(0.25)));
        CHECK(b.def.material.friction == Real(0.02));
        CHECK(b.json_path == "/generators/0");
    }
}

TEST_CASE("pyramid generator reproduces issue 3's pyramid-10 exactly", "[scene]") {
    const SceneDesc s = parse_scene_file(kScenes + "/good/pyramid-10.json");
    const int R = 10;
    REQUIRE(s.bodies.size() == 1 + R * (R + 1) / 2);
    CHECK(s.steps == 600);
    CHECK_FALSE(s.settings.rigid.sleeping);
    CHECK(s.settings.rigid.velocity_iterations == 10);

    const SceneBody& ground = s.bodies[0];
    CHECK(ground.def.type == BodyType::Static);
    // Top face of the ground at y = 0.
    CHECK(ground.def.pose.p.y() + ground.def.shape.half_extents.y() == 0);

    // Row r holds R - r boxes centred on x = 0, one pitch apart, at y = 0.5 + r: all exact binary
    // fractions, so exact equality is the right test (the boxes start exactly touching).
    std::size_t k = 1;
    for (int r = 0; r < R; ++r) {
        const int n = R - r;
        for (int i = 0; i < n; ++i, ++k) {
            const SceneBody& b = s.bodies[k];
            INFO("row " << r << " box " << i << " (" << b.name << ")");
            CHECK(b.def.type == BodyType::Dynamic);
            CHECK(b.def.shape.type == ShapeType::Box);
            CHECK(b.def.shape.half_extents == Vec3::Constant(Real(0.5)));
            CHECK(b.def.mass == 1);
            CHECK(b.def.material.friction == Real(0.6));
            CHECK(b.def.material.restitution == 0);
            CHECK(b.def.pose.p.x() == Real(i) - Real(n - 1) / 2);
            CHECK(b.def.pose.p.y() == Real(0.5) + Real(r));
            CHECK(b.def.pose.p.z() == 0);
            CHECK(b.def.pose.q.coeffs() == Quat::Identity().coeffs());
        }
    }
}

TEST_CASE("tower generator grid: columns centred on base, boxes stacked face to face", "[scene]") {
    const SceneDesc s = parse_scene_file(kScenes + "/good/tower-grid.json");
    REQUIRE(s.bodies.size() == 1 + 2 * 3 * 4);
    std::map<std::pair<Real, Real>, std::vector<Real>> columns;  // (x, z) -> heights
    for (std::size_t k = 1; k < s.bodies.size(); ++k) {
        const BodyDef& d = s.bodies[k].def;
        CHECK(d.mass == 2);
        columns[{d.pose.p.x(), d.pose.p.z()}].push_back(d.pose.p.y());
    }
    // count [2, 3], grid_spacing 2 around base (10, 0, -2): x in {9, 11}, z in {-4, -2, 0}.
    REQUIRE(columns.size() == 6);
    for (Real x : {Real(9), Real(11)})
        for (Real z : {Real(-4), Real(-2), Real(0)}) {
            INFO("column " << x << ", " << z);
            REQUIRE(columns.count({x, z}) == 1);
            CHECK(columns[{x, z}] == std::vector<Real>{Real(0.25), Real(0.75), Real(1.25), Real(1.75)});
        }
    CHECK(s.bodies[1].name == "t/p0/r0");
}

TEST_CASE("placement helpers", "[scene]") {
    CHECK(pyramid_box_centres(0, Real(0.5), 1, Vec3::Zero()).empty());
    const std::vector<Vec3> p = pyramid_box_centres(3, Real(0.5), 1, Vec3(1, 2, 3));
    REQUIRE(p.size() == 6);
    CHECK(p[0] == Vec3(0, Real(2.5), 3));
    CHECK(p[2] == Vec3(2, Real(2.5), 3));
    CHECK(p[5] == Vec3(1, Real(4.5), 3));
    const std::vector<Vec3> t = tower_box_centres(2, 1, Vec3(0, 1, 0));
    REQUIRE(t.size() == 2);
    CHECK(t[1] == Vec3(0, 4, 0));
    // Euler order: x first, then fixed y, then fixed z. x 90 then z 90 sends y -> z -> z.
    const Quat q = quat_from_euler_xyz_deg(Vec3(90, 0, 90));
    CHECK(near(Vec3(q * Vec3::UnitY()), Vec3(0, 0, 1)));
    CHECK(near(Vec3(q * Vec3::UnitX()), Vec3(0, 1, 0)));
}

TEST_CASE("build_world creates the scene's bodies in order", "[scene]") {
    const SceneDesc s = parse_scene_file(kScenes + "/good/full.json");
    std::vector<BodyId> ids;
    std::unique_ptr<World> world = build_world(s, &ids);
    REQUIRE(world);
    REQUIRE(ids.size() == s.bodies.size());
    CHECK(world->rigid().body_count() == s.bodies.size());
    CHECK(world->settings().time_step == Real(0.01));
    CHECK(world->rigid().settings().solver == RigidSolverKind::Newton);
    for (std::size_t i = 0; i < ids.size(); ++i) {
        INFO(s.bodies[i].name);
        CHECK(world->rigid().type(ids[i]) == s.bodies[i].def.type);
        CHECK(near(world->rigid().transform(ids[i]).p, s.bodies[i].def.pose.p));
    }
    CHECK(world->rigid().mass(ids[5]) == Approx(5));  // "heavy": mass given
}

TEST_CASE("pyramid spacing defaults to faces touching for any box size", "[scene]") {
    const SceneDesc s = parse_scene_string(R"({"format": "sinew-scene", "version": 1,
        "generators": [ { "type": "pyramid", "rows": 2, "half_extent": 0.75 } ] })",
                                           "inline.json");
    REQUIRE(s.bodies.size() == 3);
    // Bottom row at x = -+0.75 (pitch 1.5 = one box width), top box at y = 0.75 + 1.5.
    CHECK(s.bodies[0].def.pose.p == Vec3(Real(-0.75), Real(0.75), 0));
    CHECK(s.bodies[1].def.pose.p == Vec3(Real(0.75), Real(0.75), 0));
    CHECK(s.bodies[2].def.pose.p == Vec3(0, Real(2.25), 0));
    CHECK(s.name == "inline");
}

TEST_CASE("soft bodies: every builder, method and setting is read as written", "[scene][soft]") {
    const SceneDesc s = parse_scene_file(kScenes + "/good/soft-bodies.json");
    REQUIRE(s.soft_bodies.size() == 6);
    const SceneSoftBody& flag = s.soft_bodies[0];
    CHECK(flag.name == "flag");
    CHECK(flag.json_path == "/soft_bodies/0");
    CHECK(flag.builder == "cloth");
    CHECK(flag.def.method == SoftMethod::ImplicitEuler);
    CHECK(flag.def.positions.size() == 8 * 6);
    CHECK(flag.cloth.nx == 8);
    CHECK(flag.cloth.ny == 6);
    CHECK(flag.def.pinned == std::vector<std::uint32_t>{0, 7});
    CHECK(flag.links.stretch == Approx(2000));
    CHECK(flag.links.shear == Approx(1500));
    CHECK(flag.links.bend == Approx(50));
    CHECK(flag.def.iterations == 40);
    CHECK(flag.def.cg_tolerance == Approx(0.001));
    CHECK(flag.def.isotropic_blend == Approx(0.25));
    CHECK(flag.def.implicit_lambda == Approx(0.75));
    CHECK(flag.def.long_range_attachments);
    CHECK(flag.def.drag == Approx(0.1));
    CHECK(flag.def.friction == Approx(0.4));
    CHECK(flag.def.restitution == Approx(0.2));
    CHECK(flag.def.thickness == Approx(0.015));
    CHECK(flag.def.initial_velocity.isApprox(Vec3(0, 0, 1)));
    CHECK(flag.def.gravity_scale == Approx(0.5));
    CHECK_FALSE(flag.def.allow_sleep);
    Real mass = 0;
    for (Real m : flag.def.masses) mass += m;
    CHECK(mass == Approx(0.5));
    // Shear links carry the shear stiffness, bend links the bend stiffness.
    for (const Link& l : flag.def.links) {
        if (l.kind == LinkKind::Shear) CHECK(l.stiffness == Approx(1500));
        if (l.kind == LinkKind::Bend) CHECK(l.stiffness == Approx(50));
    }

    const SceneSoftBody& rope = s.soft_bodies[1];
    CHECK(rope.def.positions.size() == 11);
    CHECK(rope.def.links.size() == 10);
    REQUIRE(rope.def.attachments.size() == 1);
    CHECK(rope.attachment_bodies == std::vector<std::size_t>{1});
    CHECK(rope.def.links[0].fraction == Approx(0.8));

    const SceneSoftBody& ball = s.soft_bodies[2];
    CHECK(ball.def.positions.size() == 42);  // 10 * 4 + 2
    CHECK(ball.def.pressure == Approx(20));
    CHECK(ball.icosphere_radius == Approx(0.4));

    const SceneSoftBody& crate = s.soft_bodies[3];
    CHECK(crate.def.method == SoftMethod::FastMassSpring);
    REQUIRE(crate.def.positions.size() == 8);
    CHECK(crate.def.triangles.size() == 12 * 3);
    // Scaled by 0.5 and moved to (2, 1, 2): corners at 2 +- 0.25, 1 +- 0.25.
    CHECK(crate.def.positions[0].isApprox(Vec3(Real(1.75), Real(0.75), Real(1.75))));
    CHECK(s.soft_bodies[4].builder == "ragdoll");
    CHECK(s.soft_bodies[5].def.links.size() == 28);
    CHECK(s.soft_bodies[5].def.method == SoftMethod::ExplicitEuler);

    // The world builds, the attachment targets the kinematic hook, and a few steps stay finite.
    std::vector<BodyId> ids;
    auto world = build_world(s, &ids);
    REQUIRE(world->soft().body_count() == 6);
    const SoftBody& built_rope = world->soft().body(world->soft().bodies()[1]);
    REQUIRE(built_rope.attachments.size() == 1);
    CHECK(built_rope.attachments[0].target == pack_body_id(ids[1]));
    for (int k = 0; k < 10; ++k) world->step();
    CHECK(world->soft().all_finite());
    // The attached particle sits at the hook's point.
    CHECK((built_rope.p.x[0] - Vec3(3, Real(3.9), 0)).norm() < 1e-5);
}

TEST_CASE("the solver is one kind, files naming sequential_impulse and a position_correction still load", "[scene]") {
    // tests/data/scenes/good/joints.json is written in the older form.
    CHECK(parse_scene_file(kScenes + "/good/joints.json").settings.rigid.solver == RigidSolverKind::SplitImpulse);
    for (RigidSolverKind k : {RigidSolverKind::SoftStep, RigidSolverKind::SplitImpulse, RigidSolverKind::Baumgarte,
                              RigidSolverKind::Newton}) {
        const std::string text = std::string(R"({"format": "sinew-scene", "version": 1, "settings": {"solver": {"kind": ")") +
                                 rigid_solver_name(k) + "\"}}}";
        CHECK(parse_scene_string(text, "inline").settings.rigid.solver == k);
        RigidSolverKind parsed{};
        CHECK(parse_rigid_solver(rigid_solver_name(k), parsed));
        CHECK(parsed == k);
    }
    // The old "sequential_impulse" alone meant the default correction, the soft step.
    CHECK(parse_scene_string(R"({"format": "sinew-scene", "version": 1, "settings": {"solver": {"kind": "sequential_impulse"}}})",
                           "inline")
              .settings.rigid.solver == RigidSolverKind::SoftStep);
}

TEST_CASE("the scene format document's example loads and runs as copied", "[scene]") {
    std::ifstream in(std::string(SINEW_SOURCE_DIR) + "/docs/scene-format.md");
    REQUIRE(in);
    const std::string doc((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::size_t section = doc.find("\n## Example");
    REQUIRE(section != std::string::npos);
    const std::size_t begin = doc.find("```json\n", section);
    REQUIRE(begin != std::string::npos);
    const std::size_t end = doc.find("```", begin + 8);
    REQUIRE(end != std::string::npos);
    const auto world = build_world(parse_scene_string(doc.substr(begin + 8, end - begin - 8), "scene-format.md example"));
    for (int i = 0; i < 60; ++i) world->step();
    CHECK(world->rigid().all_finite());
    CHECK(world->rigid().body_count() == 20);  // 5 bodies and a 5-row pyramid of 15
}
