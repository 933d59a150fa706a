// The "soft_bodies" section of scene files: each entry names a builder (soft/soft_builders.hpp), a
// method, a link material, solver settings, pins and attachments (docs/scene-format.md, "Soft bodies").
#include <filesystem>
#include <unordered_map>

#include "engine/world/scene_json.hpp"
#include "soft/soft_builders.hpp"
#include "soft/soft_integrators.hpp"
#include "soft/fem_elements.hpp"
#include "soft/tet_mesh.hpp"

namespace sinew::scene_json {
namespace {

LinkMaterial parse_link_material(const Node& body) {
    LinkMaterial m;
    std::optional<Node> n = body.find("links");
    if (!n) return m;
    n->allow_keys({"stretch", "shear", "bend", "damping", "fraction"});
    m.stretch = read_real(*n, "stretch", m.stretch, Range::NonNegative);
    m.shear = read_real(*n, "shear", m.shear, Range::NonNegative);
    m.bend = read_real(*n, "bend", m.bend, Range::NonNegative);
    m.damping = read_real(*n, "damping", m.damping, Range::NonNegative);
    m.fraction = read_real(*n, "fraction", m.fraction, Range::UnitInterval);
    if (m.fraction <= 0) n->get("fraction").fail("fraction must be in (0, 1], got 0");
    return m;
}

void parse_solver(const Node& body, SoftBodyDef& d) {
    std::optional<Node> n = body.find("solver");
    if (!n) return;
    n->allow_keys({"iterations", "cg_tolerance", "isotropic_blend", "implicit_lambda", "long_range_attachments", "preconditioner",
                   "relaxation"});
    d.iterations = read_int(*n, "iterations", d.iterations, 1, 10000);
    d.cg_tolerance = read_real(*n, "cg_tolerance", d.cg_tolerance, Range::Positive);
    if (d.cg_tolerance >= 1) n->get("cg_tolerance").fail("cg_tolerance must be < 1");
    d.isotropic_blend = read_real(*n, "isotropic_blend", d.isotropic_blend, Range::UnitInterval);
    d.implicit_lambda = read_real(*n, "implicit_lambda", d.implicit_lambda, Range::UnitInterval);
    if (d.implicit_lambda < Real(0.5))
        n->get("implicit_lambda").fail("implicit_lambda must be in [0.5, 1] (0.5 = implicit midpoint, 1 = backward Euler)");
    d.long_range_attachments = read_bool(*n, "long_range_attachments", d.long_range_attachments);
    if (auto p = n->find("preconditioner")) {
        if (!p->json().is_string() || !parse_soft_preconditioner(p->json().get<std::string>(), d.preconditioner))
            p->fail("preconditioner must be \"block-jacobi\" or \"rest-factor\", got " + describe(p->json()));
    }
    if (auto r = n->find("relaxation")) {
        if (!r->json().is_string() || !parse_soft_relaxation(r->json().get<std::string>(), d.relaxation))
            r->fail("relaxation must be \"in-order\" or \"by-colour\", got " + describe(r->json()));
    }
}

void parse_material(const Node& body, SoftBodyDef& d) {
    std::optional<Node> n = body.find("material");
    if (!n) return;
    n->allow_keys({"drag", "pressure", "friction", "restitution", "thickness", "self_collision"});
    d.drag = read_real(*n, "drag", d.drag, Range::NonNegative);
    d.pressure = read_real(*n, "pressure", d.pressure, Range::NonNegative);
    d.friction = read_real(*n, "friction", d.friction, Range::NonNegative);
    d.restitution = read_real(*n, "restitution", d.restitution, Range::UnitInterval);
    d.thickness = read_real(*n, "thickness", d.thickness, Range::Positive);
    d.self_collision = read_bool(*n, "self_collision", d.self_collision);
}

// "fem": the elements' material (soft/fem_material.hpp); every bound create_body checks is checked here.
void parse_fem(const Node& body, SoftBodyDef& d) {
    std::optional<Node> n = body.find("fem");
    if (!n) return;
    n->allow_keys({"young", "poisson", "density", "mass_damping", "stiffness_damping", "yield", "creep", "max_plastic", "rotation"});
    FemMaterial& m = d.fem;
    m.young = read_real(*n, "young", m.young, Range::Positive);
    m.poisson = read_real(*n, "poisson", m.poisson, Range::Any);
    if (!(m.poisson > -1 && m.poisson < Real(0.5)))
        n->get("poisson").fail("poisson must be in (-1, 0.5) (0.5 is incompressible, where linear tets lock), got " +
                               n->get("poisson").json().dump());
    m.density = read_real(*n, "density", m.density, Range::Positive);
    m.mass_damping = read_real(*n, "mass_damping", m.mass_damping, Range::NonNegative);
    m.stiffness_damping = read_real(*n, "stiffness_damping", m.stiffness_damping, Range::NonNegative);
    m.yield = read_real(*n, "yield", m.yield, Range::NonNegative);
    m.creep = read_real(*n, "creep", m.creep, Range::NonNegative);
    m.max_plastic = read_real(*n, "max_plastic", m.max_plastic, Range::NonNegative);
    m.rotation = read_enum_named(*n, "rotation", m.rotation, int(FemRotation::Count), fem_rotation_name);
}

std::filesystem::path scene_relative(const Node& b, const Node& path) {
    std::filesystem::path p(path.string());
    if (p.is_relative()) p = std::filesystem::path(b.ctx().dir) / p;
    return p;
}

// A tet mesh file: gmsh's .msh, or TetGen's .node (its .ele beside it) or .ele.
TetMesh load_tet_file(const Node& b, const Node& file) {
    const std::filesystem::path p = scene_relative(b, file);
    const std::string ext = p.extension().string();
    try {
        if (ext == ".msh") return load_gmsh(p.string());
        if (ext == ".node" || ext == ".ele") {
            std::filesystem::path base = p;
            return load_tetgen(base.replace_extension(".node").string(), base.replace_extension(".ele").string());
        }
    } catch (const SoftError& e) {
        file.fail(e.what());
    }
    file.fail("a tet mesh file is a gmsh .msh or a TetGen .node/.ele, got \"" + p.filename().string() + "\"");
}

Real total_mass(const Node& body) { return read_real(body, "mass", 1, Range::Positive); }

void build_explicit(const Node& b, const SoftBodyDef& base, SceneSoftBody& out);  // below

// Builds the geometry. Returns the def with geometry filled; SoftError from a builder is reported at the
// body's path.
void build_geometry(const Node& b, const std::string& builder, const SoftBodyDef& base, SceneSoftBody& out) {
    const LinkMaterial& m = out.links;
    if (builder == "cloth") {
        ClothGridDesc c;
        const Node nodes = b.get("nodes");
        if (nodes.array_size() != 2) nodes.fail("nodes must be [nx, ny], got " + describe(nodes.json()));
        c.nx = checked_int(nodes.item(0), 2, 4096);
        c.ny = checked_int(nodes.item(1), 2, 4096);
        c.origin = read_vec3(b, "origin", c.origin);
        c.edge_u = read_vec3(b, "edge_u", c.edge_u);
        c.edge_v = read_vec3(b, "edge_v", c.edge_v);
        c.total_mass = total_mass(b);
        c.shear = read_bool(b, "shear", c.shear);
        c.bend = read_bool(b, "bend", c.bend);
        c.material = m;
        out.cloth = c;
        out.def = make_cloth_grid(c, base);
        if (auto pins = b.find("pinned_nodes")) {
            for (std::size_t k = 0; k < pins->array_size(); ++k) {
                const Node ij = pins->item(k);
                if (ij.array_size() != 2) ij.fail("a pinned node is [i, j], got " + describe(ij.json()));
                const int i = checked_int(ij.item(0), 0, c.nx - 1), j = checked_int(ij.item(1), 0, c.ny - 1);
                out.cloth_pinned_corners.push_back(cloth_node(c, i, j));
                out.def.pinned.push_back(cloth_node(c, i, j));
            }
        }
    } else if (builder == "rope") {
        out.def = make_rope(b.get("from").vec3(), b.get("to").vec3(), checked_int(b.get("segments"), 1, 100000),
                            total_mass(b), m, base);
    } else if (builder == "icosphere") {
        out.icosphere_center = b.get("center").vec3();
        out.icosphere_radius = checked(b.get("radius"), Range::Positive);
        out.icosphere_subdivisions = read_int(b, "subdivisions", 2, 0, 6);
        out.def = make_icosphere(out.icosphere_center, out.icosphere_radius, out.icosphere_subdivisions, total_mass(b),
                                 m, base);
    } else if (builder == "mesh") {
        const Node obj = b.get("obj");
        std::filesystem::path p(obj.string());
        if (p.is_relative()) p = std::filesystem::path(b.ctx().dir) / p;
        ObjMesh mesh;
        try {
            mesh = read_obj_file(p.string());
        } catch (const std::runtime_error& e) {
            obj.fail(e.what());
        }
        const Real scale = read_real(b, "scale", 1, Range::Positive);
        const Vec3 offset = read_vec3(b, "position", Vec3::Zero());
        for (Vec3& v : mesh.vertices) v = v * scale + offset;
        out.def = make_mesh_body(mesh.vertices, mesh.indices, read_int(b, "link_distance", 1, 1, 3), total_mass(b), m, base);
    } else if (builder == "ragdoll") {
        out.def = make_particle_ragdoll(b.get("feet").vec3(), checked(b.get("height"), Range::Positive), total_mass(b), base);
    } else if (builder == "stick-box") {
        out.def = make_stick_box(b.get("center").vec3(), b.get("half_extents").vec3(), total_mass(b), base);
    } else if (builder == "tet-box") {
        const Node cells = b.get("cells");
        if (cells.array_size() != 3) cells.fail("cells must be [nx, ny, nz], got " + describe(cells.json()));
        const int nx = checked_int(cells.item(0), 1, 1000), ny = checked_int(cells.item(1), 1, 1000),
                  nz = checked_int(cells.item(2), 1, 1000);
        const Vec3 size = b.get("size").vec3();
        if (!(size.minCoeff() > 0)) b.get("size").fail("size must be > 0 along every axis");
        if (b.find("center") && b.find("min_corner")) b.get("center").fail("give either center or min_corner, not both");
        if (!b.find("center") && !b.find("min_corner")) b.fail("a tet-box needs \"center\" or \"min_corner\"");
        const Vec3 min_corner = b.find("center") ? Vec3(b.get("center").vec3() - size / 2) : b.get("min_corner").vec3();
        const int split = read_int(b, "split", 5, 5, 6);
        out.tet_box = {min_corner, size, {nx, ny, nz}, split};
        TetMesh mesh = make_tet_box(min_corner, size, nx, ny, nz, split == 5 ? HexSplit::Five : HexSplit::Six);
        out.def = make_tet_body(read_int(b, "order", 1, 1, 2) == 2 ? make_quadratic(mesh) : mesh, base);
    } else if (builder == "tet-mesh") {
        TetMesh mesh = load_tet_file(b, b.get("file"));
        const Real scale = read_real(b, "scale", 1, Range::Positive);
        const Vec3 offset = read_vec3(b, "position", Vec3::Zero());
        for (Vec3& v : mesh.nodes) v = v * scale + offset;
        if (read_int(b, "order", 1, 1, 2) == 2 && mesh.order == 1) mesh = make_quadratic(mesh);
        out.def = make_tet_body(mesh, base);
    } else if (builder == "explicit") {
        build_explicit(b, base, out);
    }
}

// ---- builder "explicit": the body written out particle by particle (what save_scene_file writes) ----

const std::pair<const char*, LinkKind> kLinkKinds[] = {
    {"structural", LinkKind::Structural}, {"shear", LinkKind::Shear}, {"bend", LinkKind::Bend}, {"other", LinkKind::Other}};

std::uint32_t particle_index(const Node& n, std::size_t count) {
    return static_cast<std::uint32_t>(checked_int(n, 0, static_cast<long long>(count) - 1));
}

// One link object; every bound that SoftSystem::create_body checks is checked here, at its key.
Link parse_link(const Node& l, std::size_t count) {
    l.allow_keys({"a", "b", "rest", "stiffness", "damping", "fraction", "min_length", "max_length", "max_iterations",
                  "kind"});
    Link k;
    k.a = particle_index(l.get("a"), count);
    const Node b = l.get("b");
    k.b = particle_index(b, count);
    if (k.a == k.b) b.fail("a link must join two different particles, got a = b = " + std::to_string(k.a));
    k.rest = checked(l.get("rest"), Range::Positive);
    k.stiffness = read_real(l, "stiffness", k.stiffness, Range::NonNegative);
    k.damping = read_real(l, "damping", k.damping, Range::NonNegative);
    k.fraction = read_real(l, "fraction", k.fraction, Range::UnitInterval);
    if (k.fraction <= 0) l.get("fraction").fail("fraction must be in (0, 1], got 0");
    k.min_length = read_real(l, "min_length", k.min_length, Range::NonNegative);
    k.max_length = read_real(l, "max_length", k.max_length, Range::NonNegative);
    if (k.max_length < k.min_length) {  // min_length > 0 here, so it was given
        const Node min = l.get("min_length");
        if (auto max = l.find("max_length"))
            max->fail("max_length (" + max->json().dump() + ") must be >= min_length (" + min.json().dump() + ")");
        min.fail("min_length = " + min.json().dump() + " needs a max_length >= it (the link acts outside "
                 "[min_length, max_length])");
    }
    k.max_iterations = static_cast<std::uint16_t>(read_int(l, "max_iterations", 0, 0, 65535));
    k.kind = read_enum(l, "kind", k.kind, kLinkKinds);
    return k;
}

void build_explicit(const Node& b, const SoftBodyDef& base, SceneSoftBody& out) {
    out.def = base;
    SoftBodyDef& d = out.def;
    const Node positions = b.get("positions");
    const std::size_t n = positions.array_size();
    if (n == 0) positions.fail("positions must hold at least one particle, got an empty array");
    d.positions.reserve(n);
    for (std::size_t i = 0; i < n; ++i) d.positions.push_back(positions.item(i).vec3());

    const Node masses = b.get("masses");
    if (masses.array_size() != n)
        masses.fail("masses has " + std::to_string(masses.array_size()) + " entries for " + std::to_string(n) +
                    " positions (one mass per particle)");
    d.masses.reserve(n);
    for (std::size_t i = 0; i < n; ++i) d.masses.push_back(checked(masses.item(i), Range::Positive));

    if (auto v = b.find("velocities")) {
        if (b.find("velocity")) v->fail("give either velocity (one for all particles) or velocities, not both");
        if (v->array_size() != n)
            v->fail("velocities has " + std::to_string(v->array_size()) + " entries for " + std::to_string(n) +
                    " positions (one velocity per particle)");
        out.velocities.reserve(n);
        for (std::size_t i = 0; i < n; ++i) out.velocities.push_back(v->item(i).vec3());
    }
    if (auto links = b.find("links")) {
        const std::size_t count = links->array_size();
        d.links.reserve(count);
        for (std::size_t k = 0; k < count; ++k) d.links.push_back(parse_link(links->item(k), n));
    }
    if (auto tris = b.find("triangles")) {
        const std::size_t count = tris->array_size();
        d.triangles.reserve(3 * count);
        for (std::size_t t = 0; t < count; ++t) {
            const Node tri = tris->item(t);
            if (!tri.json().is_array() || tri.json().size() != 3) tri.type_error("[a, b, c] (an array of 3 particle indices)");
            for (std::size_t c = 0; c < 3; ++c) d.triangles.push_back(particle_index(tri.item(c), n));
        }
    }
    if (auto tets = b.find("tets")) {
        const std::size_t count = tets->array_size();
        // Linear tets list 4 particles, quadratic ones 10 (corners, then edge midpoints); the first sets the order.
        const std::size_t per = count > 0 && tets->item(0).json().is_array() && tets->item(0).json().size() == 10 ? 10 : 4;
        d.tet_order = per == 10 ? 2 : 1;
        d.tets.reserve(per * count);
        for (std::size_t t = 0; t < count; ++t) {
            const Node tet = tets->item(t);
            if (!tet.json().is_array() || tet.json().size() != per)
                tet.type_error(per == 4 ? "[a, b, c, d] (an array of 4 particle indices, as the first tet has)"
                                        : "an array of 10 particle indices (a quadratic tet, as the first tet is)");
            for (std::size_t c = 0; c < per; ++c) d.tets.push_back(particle_index(tet.item(c), n));
        }
        if (auto rest = b.find("rest_positions")) {
            if (rest->array_size() != n)
                rest->fail("rest_positions has " + std::to_string(rest->array_size()) + " entries for " + std::to_string(n) + " positions");
            for (std::size_t i = 0; i < n; ++i) d.rest_positions.push_back(rest->item(i).vec3());
        }
        if (auto plastic = b.find("plastic_strain")) {
            if (plastic->array_size() != count)
                plastic->fail("plastic_strain has " + std::to_string(plastic->array_size()) + " entries for " + std::to_string(count) + " tets");
            for (std::size_t t = 0; t < count; ++t) {
                const Node e = plastic->item(t);
                if (e.array_size() != 6) e.type_error("[xx, yy, zz, xy, xz, yz] (6 numbers)");
                Strain6 s;
                for (std::size_t c = 0; c < 6; ++c) s[c] = checked(e.item(c), Range::Any);
                d.plastic_strain.push_back(s);
            }
        }
        // The mesh checks (volumes, duplicates, manifold boundary), reported at "tets".
        try {
            check_tet_mesh(d.rest_positions.empty() ? d.positions : d.rest_positions, d.tets, "tets", d.tet_order);
        } catch (const SoftError& e) {
            tets->fail(e.what());
        }
    } else if (b.find("rest_positions") || b.find("plastic_strain")) {
        b.get(b.find("rest_positions") ? "rest_positions" : "plastic_strain").fail("belongs to FEM bodies: give \"tets\" too");
    }
    // Matyka's pressure needs a closed surface around positive volume (SoftSystem checks it again).
    if (d.pressure > 0) {
        const Node pressure = b.get("material").get("pressure");
        if (d.triangles.empty()) pressure.fail("pressure needs a closed surface, and the body has no \"triangles\"");
        const Real volume = enclosed_volume(d.triangles, d.positions);
        if (!(volume > 0))
            b.get("triangles").fail("pressure needs a closed outward surface, and these triangles enclose " +
                                    std::to_string(volume) + " m^3");
    }
}

const char* const kBuilders[] = {"cloth", "rope", "icosphere", "mesh", "ragdoll", "stick-box", "tet-box", "tet-mesh", "explicit"};

}  // namespace

void parse_soft_bodies(const Node& array, SceneDesc& desc) {
    std::unordered_map<std::string, std::size_t> body_index;
    for (std::size_t i = 0; i < desc.bodies.size(); ++i) body_index.emplace(desc.bodies[i].name, i);
    const std::size_t count = array.array_size();
    for (std::size_t k = 0; k < count; ++k) {
        const Node b = array.item(k);
        b.expect_object();
        SceneSoftBody out;
        out.json_path = b.path();
        out.name = b.find("name") ? b.get("name").string() : "soft" + std::to_string(k);
        out.builder = b.get("builder").string();
        bool known = false;
        for (const char* name : kBuilders) known = known || out.builder == name;
        if (!known)
            b.get("builder").fail("unknown builder \"" + out.builder + "\" (expected one of: " + one_of(kBuilders) + ")");
        // Keys common to every builder, then the builder's own.
        // An explicit body gives its particles' masses and its links one by one instead of "mass" and a
        // link material, so for it "links" is the array of links.
        const bool is_explicit = out.builder == "explicit";
        std::vector<const char*> keys = {"name", "builder", "method", "solver", "material", "pinned", "attachments",
                                         "velocity", "gravity_scale", "allow_sleep", "filter", "user_data"};
        const bool is_fem = out.builder == "tet-box" || out.builder == "tet-mesh" || (is_explicit && b.find("tets"));
        if (!is_explicit && !is_fem) keys.insert(keys.end(), {"mass", "links"});
        // "fem" is a key of FEM bodies only (an explicit body is one when it has "tets").
        if (is_explicit)
            keys.insert(keys.end(), {"positions", "masses", "velocities", "links", "triangles", "tets", "rest_positions", "plastic_strain"});
        if (is_fem) keys.push_back("fem");
        keys.push_back("pinned_box");
        if (out.builder == "tet-box") keys.insert(keys.end(), {"min_corner", "center", "size", "cells", "split", "order"});
        if (out.builder == "tet-mesh") keys.insert(keys.end(), {"file", "scale", "position", "order"});
        if (out.builder == "cloth") keys.insert(keys.end(), {"nodes", "origin", "edge_u", "edge_v", "shear", "bend", "pinned_nodes"});
        if (out.builder == "rope") keys.insert(keys.end(), {"from", "to", "segments"});
        if (out.builder == "icosphere") keys.insert(keys.end(), {"center", "radius", "subdivisions"});
        if (out.builder == "mesh") keys.insert(keys.end(), {"obj", "scale", "position", "link_distance"});
        if (out.builder == "ragdoll") keys.insert(keys.end(), {"feet", "height"});
        if (out.builder == "stick-box") keys.insert(keys.end(), {"center", "half_extents"});
        std::vector<std::string> names;
        for (const char* key : keys) names.emplace_back(key);
        for (auto it = b.json().begin(); it != b.json().end(); ++it) {
            bool ok = false;
            for (const char* key : keys) ok = ok || it.key() == key;
            if (!ok)
                b.ctx().fail(b.path() + "/" + pointer_token(it.key()),
                             "unknown key \"" + it.key() + "\" for " + (is_explicit ? "an " : "a ") + out.builder +
                                 " soft body (expected one of: " +
                                 one_of(names) + ")");
        }

        SoftBodyDef base;
        // FEM bodies need a force-based method: theirs defaults to implicit Euler.
        base.method = read_enum_named(b, "method", is_fem ? SoftMethod::ImplicitEuler : SoftMethod::Verlet, int(SoftMethod::Count),
                                      soft_method_name);
        // A CG cap of 10 (the Verlet relaxations' default) leaves a stiff solid's step far from converged.
        if (is_fem) base.iterations = 100;
        parse_solver(b, base);
        parse_fem(b, base);
        parse_material(b, base);
        base.initial_velocity = read_vec3(b, "velocity", Vec3::Zero());
        base.gravity_scale = read_real(b, "gravity_scale", 1, Range::Any);
        base.allow_sleep = read_bool(b, "allow_sleep", true);
        base.filter = read_filter(b);
        if (auto n = b.find("user_data")) {
            if (!n->json().is_number_unsigned()) n->type_error("an integer >= 0");
            base.user_data = n->json().get<std::uint64_t>();
        }
        if (!is_explicit && !is_fem) out.links = parse_link_material(b);
        try {
            build_geometry(b, out.builder, base, out);
        } catch (const SoftError& e) {
            b.fail(e.what());
        }
        if (!out.def.tets.empty() && !accepts_tets(out.def.method))
            (b.find("method") ? b.get("method") : b)
                .fail(std::string("tets need a force-based method (explicit, semi-implicit or implicit) or fast-ms "
                                  "(projective dynamics), got ") +
                      soft_method_name(out.def.method));
        if (out.def.preconditioner == SoftPreconditioner::RestFactor &&
            (out.def.tets.empty() || out.def.method != SoftMethod::ImplicitEuler))
            b.get("solver").get("preconditioner").fail("rest-factor is for FEM bodies (tets) under the implicit method");
        if (out.def.relaxation == SoftRelaxation::ByColour && out.def.method != SoftMethod::Verlet)
            b.get("solver").get("relaxation").fail(std::string("by-colour is for Verlet bodies, got method ") +
                                                   soft_method_name(out.def.method));
        if (!out.def.tets.empty()) {
            const std::string unfit = fem_method_problem(out.def.fem, out.def.method, out.def.tet_order);
            if (!unfit.empty()) (b.find("fem") ? b.get("fem") : b).fail(unfit);
        }
        const std::size_t n = out.def.positions.size();
        if (auto pins = b.find("pinned")) {
            for (std::size_t i = 0; i < pins->array_size(); ++i) {
                const Node pin = pins->item(i);
                out.def.pinned.push_back(static_cast<std::uint32_t>(checked_int(pin, 0, static_cast<long long>(n) - 1)));
            }
        }
        if (auto box = b.find("pinned_box")) {
            // Every particle inside the box (a clamped end, a fixed base).
            box->allow_keys({"min", "max"});
            const Vec3 lo = box->get("min").vec3(), hi = box->get("max").vec3();
            if (!(lo.array() <= hi.array()).all()) box->get("max").fail("max must be >= min along every axis");
            std::size_t pinned = 0;
            for (std::uint32_t i = 0; i < n; ++i)
                if ((out.def.positions[i].array() >= lo.array()).all() && (out.def.positions[i].array() <= hi.array()).all()) {
                    out.def.pinned.push_back(i);
                    ++pinned;
                }
            if (pinned == 0) box->fail("pinned_box holds none of the body's " + std::to_string(n) + " particles");
        }
        if (auto atts = b.find("attachments")) {
            for (std::size_t i = 0; i < atts->array_size(); ++i) {
                const Node a = atts->item(i);
                a.allow_keys({"particle", "body", "local_point"});
                Attachment att;
                att.particle = static_cast<std::uint32_t>(checked_int(a.get("particle"), 0, static_cast<long long>(n) - 1));
                const Node body = a.get("body");
                auto it = body_index.find(body.string());
                if (it == body_index.end()) body.fail("unknown body \"" + body.string() + "\"");
                att.local_point = read_vec3(a, "local_point", Vec3::Zero());
                out.def.attachments.push_back(att);
                out.attachment_bodies.push_back(it->second);
            }
        }
        desc.soft_bodies.push_back(std::move(out));
    }
}

}  // namespace sinew::scene_json
