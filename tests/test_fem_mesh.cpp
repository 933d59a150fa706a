// Tetrahedral meshes (soft/tet_mesh.hpp): the box builder's cuts match across cells and its boundary is
// the box; the checks name the element and its volume; TetGen and gmsh files load; bad meshes and bad
// materials are refused with nothing created; lumped masses sum to ρ V.
#include <catch2/catch.hpp>

#include <cmath>
#include <fstream>
#include <functional>
#include <string>

#include "soft/soft_builders.hpp"
#include "soft/soft_integrators.hpp"
#include "soft/soft_system.hpp"
#include "soft/tet_mesh.hpp"
#include "tests/test_files_util.hpp"

using namespace sinew;

namespace {

SoftBodyDef make_tet_box_body(SoftBodyDef base) {
    return make_tet_body(make_tet_box(Vec3::Zero(), Vec3(1, 0.5, 0.5), 2, 1, 1), std::move(base));
}

std::string refusal(const std::function<void()>& f) {
    try {
        f();
    } catch (const SoftError& e) {
        return e.what();
    }
    return "(accepted)";
}

}  // namespace

TEST_CASE("A tet box has matching cuts, positive tets and the box as its boundary", "[fem][mesh]") {
    for (const HexSplit split : {HexSplit::Five, HexSplit::Six}) {
        const int nx = 3, ny = 2, nz = 4;
        const TetMesh m = make_tet_box(Vec3(-1, 0, 2), Vec3(1.5, 0.5, 2), nx, ny, nz, split);
        const int per = split == HexSplit::Five ? 5 : 6;
        CHECK(m.tet_count() == std::size_t(per * nx * ny * nz));
        CHECK(m.nodes.size() == std::size_t((nx + 1) * (ny + 1) * (nz + 1)));
        REQUIRE_NOTHROW(check_tet_mesh(m.nodes, m.tets, "box"));
        double volume = 0;
        for (std::size_t e = 0; e < m.tet_count(); ++e) {
            const std::uint32_t* t = &m.tets[4 * e];
            const Real v = tet_volume(m.nodes[t[0]], m.nodes[t[1]], m.nodes[t[2]], m.nodes[t[3]]);
            REQUIRE(v > 0);
            volume += v;
        }
        CHECK(volume == Approx(1.5 * 0.5 * 2).epsilon(1e-5));
        // Unmatched cuts would leave interior faces on the boundary: it must be exactly the box's 2 triangles
        // per face quad, enclosing the box's volume.
        const std::vector<std::uint32_t> surface = boundary_triangles(m.tets);
        CHECK(surface.size() / 3 == std::size_t(4 * (nx * ny + ny * nz + nz * nx)));
        CHECK(enclosed_volume(surface, m.nodes) == Approx(1.5).epsilon(1e-5));
    }
}

TEST_CASE("Lumped masses sum to the mesh's density times volume", "[fem][mesh]") {
    const TetMesh m = make_tet_box(Vec3::Zero(), Vec3(1.0, 0.1, 0.1), 20, 2, 2, HexSplit::Six);
    const std::vector<Real> mass = lumped_masses(m.nodes, m.tets, 1000);
    double total = 0;
    for (const Real x : mass) total += x;
    CHECK(total == Approx(1000 * 1.0 * 0.1 * 0.1).epsilon(1e-5));
}

TEST_CASE("Quadratic tets: one node per edge, masses that sum to rho V, a closed boundary of 4 triangles a face", "[fem][mesh]") {
    const int nx = 3, ny = 2, nz = 2;
    const TetMesh linear = make_tet_box(Vec3(-1, 0, 2), Vec3(1.5, 0.5, 2), nx, ny, nz, HexSplit::Six);
    const TetMesh m = make_quadratic(linear);
    REQUIRE(m.order == 2);
    CHECK(m.tet_count() == linear.tet_count());
    // Euler's formula for the box's tet complex: V - E + F - T = 1, with F = (4 T + boundary faces) / 2.
    const std::size_t boundary = boundary_triangles(linear.tets).size() / 3;
    const std::size_t faces = (4 * linear.tet_count() + boundary) / 2;
    const std::size_t edges = linear.nodes.size() + faces - linear.tet_count() - 1;
    CHECK(m.nodes.size() == linear.nodes.size() + edges);
    for (std::size_t i = 0; i < linear.nodes.size(); ++i) REQUIRE(m.nodes[i] == linear.nodes[i]);  // corners keep their indices
    REQUIRE_NOTHROW(check_tet_mesh(m.nodes, m.tets, "box", 2));
    const std::vector<Real> mass = lumped_masses(m.nodes, m.tets, 1000, 2);
    double total = 0;
    for (const Real x : mass) {
        REQUIRE(x > 0);
        total += x;
    }
    CHECK(total == Approx(1000 * 1.5 * 0.5 * 2).epsilon(1e-5));
    const std::vector<std::uint32_t> surface = boundary_triangles(m.tets, 2);
    CHECK(surface.size() / 3 == 4 * boundary);
    CHECK(enclosed_volume(surface, m.nodes) == Approx(1.5).epsilon(1e-5));
}

TEST_CASE("Quadratic mesh checks: an edge node off its midpoint, or two nodes for one edge", "[fem][mesh]") {
    TetMesh m = make_quadratic(make_tet_box(Vec3::Zero(), Vec3(1, 1, 1), 1, 1, 1));
    SECTION("off the midpoint") {
        const std::uint32_t k = m.tets[10 * 2 + 5];
        m.nodes[k] += Vec3(0, 0, Real(0.01));
        CHECK_THAT(refusal([&] { check_tet_mesh(m.nodes, m.tets, "mesh", 2); }),
                   Catch::Contains("node " + std::to_string(k) + " of tet ") && Catch::Contains("is not at the midpoint of its edge"));
    }
    SECTION("two nodes for one edge") {
        // Tet 1's first edge gets a node of its own at the same midpoint: tets 0 and 1 share that edge.
        m.nodes.push_back(m.nodes[m.tets[10 * 1 + 4]]);
        const std::uint32_t old = m.tets[10 * 1 + 4];
        m.tets[10 * 1 + 4] = std::uint32_t(m.nodes.size() - 1);
        const std::string e = refusal([&] { check_tet_mesh(m.nodes, m.tets, "mesh", 2); });
        CHECK_THAT(e, Catch::Contains("has node " + std::to_string(old)) || Catch::Contains("at the same place"));
    }
    SECTION("a count that is not a multiple of 10") {
        m.tets.pop_back();
        CHECK_THAT(refusal([&] { check_tet_mesh(m.nodes, m.tets, "mesh", 2); }), Catch::Contains("not a multiple of 10"));
    }
}

TEST_CASE("Mesh checks name the element, its nodes and its volume", "[fem][mesh]") {
    TetMesh m = make_tet_box(Vec3::Zero(), Vec3(1, 1, 1), 1, 1, 1);
    SECTION("inverted") {
        std::swap(m.tets[4 * 3 + 2], m.tets[4 * 3 + 3]);
        const std::string e = refusal([&] { check_tet_mesh(m.nodes, m.tets, "mesh"); });
        CHECK_THAT(e, Catch::Contains("tet 3") && Catch::Contains("inverted") && Catch::Contains("volume -0.1666"));
    }
    SECTION("degenerate") {
        m.nodes.push_back(Vec3(2, 0, 0));
        m.nodes.push_back(Vec3(3, 0, 0));
        m.tets.insert(m.tets.end(), {1, std::uint32_t(m.nodes.size() - 2), std::uint32_t(m.nodes.size() - 1), 3});
        const std::string e = refusal([&] { check_tet_mesh(m.nodes, m.tets, "mesh"); });
        CHECK_THAT(e, Catch::Contains("tet 5") && Catch::Contains("degenerate"));
    }
    SECTION("duplicate node") {
        m.nodes.push_back(m.nodes[2]);
        const std::string e = refusal([&] { check_tet_mesh(m.nodes, m.tets, "mesh"); });
        CHECK_THAT(e, Catch::Contains("nodes 2 and 8 are at the same place"));
    }
    SECTION("unreferenced node") {
        m.nodes.push_back(Vec3(5, 5, 5));
        CHECK_THAT(refusal([&] { check_tet_mesh(m.nodes, m.tets, "mesh"); }), Catch::Contains("node 8 belongs to no tet"));
    }
    SECTION("index out of range and NaN") {
        m.tets[6] = 99;
        CHECK_THAT(refusal([&] { check_tet_mesh(m.nodes, m.tets, "mesh"); }), Catch::Contains("tet 1 refers to node 99"));
        m.tets[6] = 0;
        m.nodes[4].x() = std::nan("");
        CHECK_THAT(refusal([&] { check_tet_mesh(m.nodes, m.tets, "mesh"); }), Catch::Contains("node 4 must be finite"));
    }
    SECTION("a face shared by three tets") {
        // A second tet on the same side of the central tet's face (0, 3, 5) overlaps the corner tet there.
        const std::uint32_t* c = &m.tets[0];
        m.nodes.push_back(Vec3(0.9, 0.1, 0.05));
        m.tets.insert(m.tets.end(), {c[0], c[1], c[2], std::uint32_t(m.nodes.size() - 1)});
        orient_tets(m.nodes, m.tets);  // no-op: orientations are mixed
        std::uint32_t* t = &m.tets[m.tets.size() - 4];
        if (tet_volume(m.nodes[t[0]], m.nodes[t[1]], m.nodes[t[2]], m.nodes[t[3]]) < 0) std::swap(t[2], t[3]);
        const std::string e = refusal([&] { check_tet_mesh(m.nodes, m.tets, "mesh"); });
        CHECK_THAT(e, Catch::Contains("belongs to 3 tets") || Catch::Contains("not a closed manifold"));
    }
}

TEST_CASE("A bad FEM body is refused with a message naming where, and nothing is created", "[fem][mesh]") {
    SoftSystem sys;
    SoftBodyDef base;
    base.method = SoftMethod::ImplicitEuler;
    const SoftBodyDef good = make_tet_box_body(base);
    const auto refused = [&](SoftBodyDef d) {
        const std::string e = refusal([&] { sys.create_body(std::move(d)); });
        CHECK(sys.body_count() == 0);
        return e;
    };
    SoftBodyDef d = good;
    d.fem.poisson = Real(0.5);
    CHECK_THAT(refused(d), Catch::Contains("fem.poisson = 0.5 must be in (-1, 0.5)"));
    d = good;
    d.fem.young = 0;
    CHECK_THAT(refused(d), Catch::Contains("fem.young = 0 must be finite and > 0"));
    d = good;
    d.fem.young = -5;
    CHECK_THAT(refused(d), Catch::Contains("fem.young = -5 must be finite and > 0"));
    d = good;
    d.positions[3].y() = std::nan("");
    CHECK_THAT(refused(d), Catch::Contains("positions[3] must be finite"));
    d = good;
    std::swap(d.tets[2], d.tets[3]);
    CHECK_THAT(refused(d), Catch::Contains("tet 0") && Catch::Contains("inverted"));
    d = good;
    d.method = SoftMethod::Verlet;
    CHECK_THAT(refused(d), Catch::Contains("tets need a force-based method"));
    d = good;
    d.fem.creep = -1;
    CHECK_THAT(refused(d), Catch::Contains("fem.creep"));
    // The good one is accepted, and the refusals left nothing behind.
    REQUIRE_NOTHROW(sys.create_body(good));
    CHECK(sys.body_count() == 1);
}

TEST_CASE("TetGen .node/.ele files load, 1-based with comments, and their errors name file and line", "[fem][mesh]") {
    test_files::ScratchDir dir("sinew-tetgen");
    const TetMesh box = make_tet_box(Vec3::Zero(), Vec3(1, 2, 3), 2, 2, 2);
    {
        std::ofstream node(dir.dir / "box.node");
        node << "# written by the test\n" << box.nodes.size() << " 3 0 1\n";
        for (std::size_t i = 0; i < box.nodes.size(); ++i)
            node << i + 1 << " " << box.nodes[i].x() << " " << box.nodes[i].y() << " " << box.nodes[i].z() << " 0\n";
        // TetGen's own orientation is the mirror of ours: write every tet the other way round.
        std::ofstream ele(dir.dir / "box.ele");
        ele << box.tet_count() << " 4 0\n";
        for (std::size_t e = 0; e < box.tet_count(); ++e)
            ele << e + 1 << "  " << box.tets[4 * e] + 1 << " " << box.tets[4 * e + 1] + 1 << " " << box.tets[4 * e + 3] + 1 << " "
                << box.tets[4 * e + 2] + 1 << "  # tet\n";
    }
    const TetMesh m = load_tetgen((dir.dir / "box.node").string(), (dir.dir / "box.ele").string());
    REQUIRE(m.nodes.size() == box.nodes.size());
    REQUIRE(m.tets.size() == box.tets.size());
    REQUIRE_NOTHROW(check_tet_mesh(m.nodes, m.tets, "loaded"));
    CHECK((m.nodes[7] - box.nodes[7]).norm() < 1e-5);
    {
        std::ofstream ele(dir.dir / "bad.ele");
        ele << "2 4 0\n1 1 2 3 4\n2 1 2 3 999\n";
    }
    const std::string e = refusal([&] { load_tetgen((dir.dir / "box.node").string(), (dir.dir / "bad.ele").string()); });
    CHECK_THAT(e, Catch::Contains("bad.ele:3") && Catch::Contains("node 999"));
}

TEST_CASE("gmsh .msh files load in formats 2.2 and 4.1", "[fem][mesh]") {
    test_files::ScratchDir dir("sinew-gmsh");
    // Two tets sharing the face (1, 2, 3), plus a triangle element the loader skips.
    const char* v22 =
        "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n5\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n5 0 0 -1\n$EndNodes\n"
        "$Elements\n3\n1 2 2 0 1 1 2 3\n2 4 2 0 1 1 2 3 4\n3 4 2 0 1 1 3 2 5\n$EndElements\n";
    const char* v41 =
        "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Entities\n0 0 0 1\n1 0 0 -1 1 1 1 0 0\n$EndEntities\n"
        "$Nodes\n1 5 1 5\n3 1 0 5\n1\n2\n3\n4\n5\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n0 0 -1\n$EndNodes\n"
        "$Elements\n1 2 1 2\n3 1 4 2\n1 1 2 3 4\n2 1 3 2 5\n$EndElements\n";
    for (const char* text : {v22, v41}) {
        const auto path = dir.dir / "two.msh";
        std::ofstream(path) << text;
        const TetMesh m = load_gmsh(path.string());
        REQUIRE(m.tet_count() == 2);
        REQUIRE(m.nodes.size() == 5);
        REQUIRE_NOTHROW(check_tet_mesh(m.nodes, m.tets, "two.msh"));
        CHECK(boundary_triangles(m.tets).size() == 6 * 3);
    }
    std::ofstream(dir.dir / "flat.msh") << "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 1 1 0\n"
                                           "$EndNodes\n$Elements\n1\n1 4 2 0 1 1 2 3 4\n$EndElements\n";
    const TetMesh flat = load_gmsh((dir.dir / "flat.msh").string());
    const std::string e = refusal([&] { check_tet_mesh(flat.nodes, flat.tets, "flat.msh"); });
    CHECK_THAT(e, Catch::Contains("flat.msh: tet 0") && Catch::Contains("volume 0"));
    std::ofstream(dir.dir / "binary.msh") << "$MeshFormat\n4.1 1 8\n$EndMeshFormat\n";
    CHECK_THAT(refusal([&] { load_gmsh((dir.dir / "binary.msh").string()); }), Catch::Contains("binary.msh:2") && Catch::Contains("ASCII"));
    CHECK_THAT(refusal([&] { load_gmsh((dir.dir / "missing.msh").string()); }), Catch::Contains("cannot open"));
}
