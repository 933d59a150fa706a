// Scene file parser: JSON text -> validated SceneDesc (format: docs/scene-format.md).
//
// Validation is strict on purpose: a typo in a key ("frction") silently falling back to a default is the
// worst kind of scene bug, so unknown keys are errors everywhere, and every error names the offending
// value by its RFC 6901 JSON pointer (the JSON plumbing that makes this possible is scene_json.hpp).
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <unordered_map>
#include <unordered_set>

#include "engine/core/mass_properties.hpp"
#include "engine/world/scene.hpp"
#include "engine/world/scene_json.hpp"

namespace sinew {

SceneError::SceneError(std::string file_, std::string json_path_, std::string problem_)
    : std::runtime_error(file_ + ": " + (json_path_.empty() ? std::string() : json_path_ + ": ") + problem_),
      file(std::move(file_)),
      json_path(std::move(json_path_)),
      problem(std::move(problem_)) {}

namespace {

using namespace scene_json;

// ---- the scene ------------------------------------------------------------------------------------

class SceneParser {
public:
    SceneParser(const Json& root, Context ctx) : ctx_(std::move(ctx)), root_(root, "", "scene", ctx_) {}

    SceneDesc parse() {
        if (!root_.json().is_object()) root_.fail("a scene file must hold a JSON object, got " + describe(root_.json()));
        // Format and version first: if this is not a scene file at all, say that rather than listing keys.
        const Node format = root_.get("format");
        if (format.string() != kSceneFormat)
            format.fail("format must be \"" + std::string(kSceneFormat) + "\", got " + describe(format.json()));
        const Node version = root_.get("version");
        const long long v = version.integer();
        if (v < 1 || v > kSceneVersion)
            version.fail("unsupported scene version " + std::to_string(v) + " (this build reads version " +
                         std::to_string(kSceneVersion) + ")");
        root_.allow_keys({"format", "version", "name", "description", "settings", "materials", "shapes", "bodies",
                          "generators", "soft_bodies", "joints", "coupling"});

        desc_.file = ctx_.file;
        desc_.name = std::filesystem::path(ctx_.file).stem().string();
        if (auto n = root_.find("name")) desc_.name = n->string();
        if (auto n = root_.find("description")) desc_.description = n->string();
        if (auto n = root_.find("settings")) parse_settings(*n);
        if (auto n = root_.find("materials")) parse_materials(*n);
        if (auto n = root_.find("shapes")) {
            n->expect_object();
            shapes_ = n;
        }
        if (auto n = root_.find("bodies")) {
            const std::size_t count = n->array_size();
            desc_.bodies.reserve(count);
            for (std::size_t i = 0; i < count; ++i) parse_body(n->item(i), i);
        }
        if (auto n = root_.find("generators")) {
            const std::size_t count = n->array_size();
            for (std::size_t i = 0; i < count; ++i) parse_generator(n->item(i), i);
        }
        if (auto n = root_.find("joints")) parse_joints(*n);  // after the bodies: joints name them
        if (auto n = root_.find("soft_bodies")) parse_soft_bodies(*n, desc_);  // attachments name bodies
        if (auto n = root_.find("coupling")) parse_coupling(*n, desc_);  // pairs name both kinds of body
        return std::move(desc_);
    }

private:
    // ---- settings -----------------------------------------------------------------------------------
    void parse_settings(const Node& s) {
        s.allow_keys({"time_step", "steps", "max_steps_per_frame", "gravity", "solver", "sleeping"});
        WorldSettings& w = desc_.settings;
        RigidSettings& r = w.rigid;
        w.time_step = read_real(s, "time_step", w.time_step, Range::Positive);
        desc_.steps = read_int(s, "steps", desc_.steps, 1);
        w.max_steps_per_frame = read_int(s, "max_steps_per_frame", w.max_steps_per_frame, 1, kMaxStepsPerFrame);
        r.gravity = read_vec3(s, "gravity", r.gravity);

        if (auto solver = s.find("solver")) {
            const Node& o = *solver;
            o.allow_keys({"kind", "velocity_iterations", "warm_starting", "position_correction", "baumgarte", "slop",
                          "restitution_threshold", "contact_margin", "max_correction_velocity", "newton", "substeps",
                          "contact_hertz", "contact_damping_ratio", "contact_push_velocity", "contact_mass_ratio",
                          "gyroscopic", "continuous"});
            // One solver kind. Files of format 1 before it named the sequential-impulse solvers as
            // "sequential_impulse" plus a "position_correction"; they still load (docs/scene-format.md).
            static const std::pair<const char*, RigidSolverKind> kinds[] = {
                {"soft_step", RigidSolverKind::SoftStep},   {"split_impulse", RigidSolverKind::SplitImpulse},
                {"baumgarte", RigidSolverKind::Baumgarte}, {"newton", RigidSolverKind::Newton},
                {"sequential_impulse", RigidSolverKind::SoftStep}};
            static const std::pair<const char*, RigidSolverKind> corrections[] = {
                {"baumgarte", RigidSolverKind::Baumgarte}, {"split_impulse", RigidSolverKind::SplitImpulse},
                {"soft_step", RigidSolverKind::SoftStep}};
            r.solver = read_enum(o, "kind", r.solver, kinds);
            if (o.find("position_correction")) {
                const bool legacy = o.find("kind") && o.get("kind").json() == "sequential_impulse";
                if (!legacy)
                    o.get("position_correction")
                        .fail("position_correction is only read with \"kind\": \"sequential_impulse\"; name the solver "
                              "in kind (soft_step, split_impulse, baumgarte, newton)");
                r.solver = read_enum(o, "position_correction", r.solver, corrections);
            }
            r.velocity_iterations = read_int(o, "velocity_iterations", r.velocity_iterations, 1, 1000);
            r.warm_starting = read_bool(o, "warm_starting", r.warm_starting);
            r.gyroscopic = read_bool(o, "gyroscopic", r.gyroscopic);
            r.baumgarte = read_real(o, "baumgarte", r.baumgarte, Range::UnitInterval);
            r.linear_slop = read_real(o, "slop", r.linear_slop, Range::NonNegative);
            if (r.linear_slop >= 1) o.get("slop").fail("slop must be < 1 m, got " + o.get("slop").json().dump());
            r.restitution_threshold = read_real(o, "restitution_threshold", r.restitution_threshold, Range::NonNegative);
            r.contact_margin = read_real(o, "contact_margin", r.contact_margin, Range::Positive);
            if (r.contact_margin >= 1)
                o.get("contact_margin").fail("contact_margin must be < 1 m, got " + o.get("contact_margin").json().dump());
            r.max_correction_velocity =
                read_real(o, "max_correction_velocity", r.max_correction_velocity, Range::Positive);
            r.substeps = read_int(o, "substeps", r.substeps, 0, 64);
            r.contact_hertz = read_real(o, "contact_hertz", r.contact_hertz, Range::Positive);
            r.contact_damping_ratio = read_real(o, "contact_damping_ratio", r.contact_damping_ratio, Range::NonNegative);
            r.contact_push_velocity = read_real(o, "contact_push_velocity", r.contact_push_velocity, Range::Positive);
            r.contact_mass_ratio = read_real(o, "contact_mass_ratio", r.contact_mass_ratio, Range::NonNegative);
            r.continuous = read_bool(o, "continuous", r.continuous);
            if (r.contact_mass_ratio != 0 && r.contact_mass_ratio < 1)
                o.get("contact_mass_ratio").fail("contact_mass_ratio must be 0 (no bound) or >= 1, got " +
                                                 o.get("contact_mass_ratio").json().dump());
            if (auto newton = o.find("newton")) {
                const Node& n = *newton;
                n.allow_keys({"collision_iterations", "contact_iterations", "shock_propagation", "projection_fraction"});
                r.newton_collision_iterations = read_int(n, "collision_iterations", r.newton_collision_iterations, 0);
                r.newton_contact_iterations = read_int(n, "contact_iterations", r.newton_contact_iterations, 1);
                r.newton_shock_propagation = read_bool(n, "shock_propagation", r.newton_shock_propagation);
                r.newton_projection_fraction =
                    read_real(n, "projection_fraction", r.newton_projection_fraction, Range::UnitInterval);
            }
        }
        if (auto sleeping = s.find("sleeping")) {
            const Node& o = *sleeping;
            o.allow_keys({"enabled", "linear_velocity", "angular_velocity", "time"});
            r.sleeping = read_bool(o, "enabled", r.sleeping);
            r.sleep_linear_velocity = read_real(o, "linear_velocity", r.sleep_linear_velocity, Range::NonNegative);
            r.sleep_angular_velocity = read_real(o, "angular_velocity", r.sleep_angular_velocity, Range::NonNegative);
            r.sleep_time = read_real(o, "time", r.sleep_time, Range::NonNegative);
        }
        // One sleeping switch for the world: soft bodies follow the rigid settings.
        w.soft.sleeping = r.sleeping;
        if (r.sleep_time > 0) w.soft.sleep_time = r.sleep_time;
    }

    // ---- materials ----------------------------------------------------------------------------------
    static Material parse_material_object(const Node& m) {
        m.allow_keys({"density", "friction", "restitution"});
        Material out;
        out.density = read_real(m, "density", out.density, Range::Positive);
        out.friction = read_real(m, "friction", out.friction, Range::NonNegative);
        out.restitution = read_real(m, "restitution", out.restitution, Range::UnitInterval);
        return out;
    }

    void parse_materials(const Node& ms) {
        ms.expect_object();
        for (const auto& item : ms.json().items()) {
            Node m(item.value(), ms.path() + "/" + pointer_token(item.key()), item.key(), ctx_);
            if (item.key().empty()) m.fail("a material name must not be empty");
            materials_.emplace(item.key(), parse_material_object(m));
        }
    }

    /// A material: a name from "materials" or an inline object.
    Material material_ref(const Node& n) const {
        if (n.json().is_string()) {
            auto it = materials_.find(n.string());
            if (it == materials_.end()) {
                std::vector<std::string> names;
                for (const auto& m : materials_) names.push_back(m.first);
                std::sort(names.begin(), names.end());
                n.fail("unknown material \"" + n.string() + "\"" +
                       (names.empty() ? std::string(" (the scene defines no materials)")
                                      : " (defined: " + one_of(names) + ")"));
            }
            return it->second;
        }
        if (!n.json().is_object()) n.type_error("a material name or a material object");
        return parse_material_object(n);
    }

    // ---- shapes -------------------------------------------------------------------------------------
    /// A shape: a name from "shapes" or an inline object.
    Shape shape_ref(const Node& n) {
        if (n.json().is_string()) return named_shape(n);
        if (!n.json().is_object()) n.type_error("a shape name or a shape object");
        return parse_shape_object(n);
    }

    // Named shapes are built on first use and then shared, so a thousand bodies naming one hull share
    // its data (Shape holds it by shared_ptr).
    Shape named_shape(const Node& ref) {
        const std::string& name = ref.string();
        if (auto it = built_shapes_.find(name); it != built_shapes_.end()) return it->second;
        std::optional<Node> def = shapes_ ? shapes_->find(name.c_str()) : std::nullopt;
        if (!def) {
            std::vector<std::string> names;
            if (shapes_)
                for (const auto& item : shapes_->json().items()) names.push_back(item.key());
            ref.fail("unknown shape \"" + name + "\"" +
                     (names.empty() ? std::string(" (the scene defines no named shapes)")
                                    : " (defined: " + one_of(names) + ")"));
        }
        if (!shapes_in_progress_.insert(name).second) ref.fail("shape \"" + name + "\" refers to itself");
        Shape s = parse_shape_object(*def);
        shapes_in_progress_.erase(name);
        built_shapes_.emplace(name, s);
        return s;
    }

    /// Runs a shape factory, reporting its ShapeError at the shape's path.
    template <class F>
    static Shape factory(const Node& n, F&& make) {
        try {
            return make();
        } catch (const ShapeError& e) {
            n.fail(e.what());
        }
    }

    static std::vector<Vec3> read_points(const Node& n) {
        const std::size_t count = n.array_size();
        std::vector<Vec3> points;
        points.reserve(count);
        for (std::size_t i = 0; i < count; ++i) points.push_back(n.item(i).vec3());
        return points;
    }

    Shape parse_shape_object(const Node& n) {
        n.expect_object();
        static const std::pair<const char*, ShapeType> types[] = {
            {"sphere", ShapeType::Sphere},          {"box", ShapeType::Box},
            {"capsule", ShapeType::Capsule},        {"convex_hull", ShapeType::ConvexHull},
            {"plane", ShapeType::Plane},            {"triangle_mesh", ShapeType::TriangleMesh},
            {"compound", ShapeType::Compound}};
        n.get("type");  // required: fails with "missing required key" if absent
        const ShapeType type = read_enum(n, "type", ShapeType::Count, types);
        switch (type) {
            case ShapeType::Sphere: {
                n.allow_keys({"type", "radius"});
                const Real radius = checked(n.get("radius"), Range::Positive);
                return factory(n, [&] { return make_sphere(radius); });
            }
            case ShapeType::Box: {
                n.allow_keys({"type", "half_extents"});
                const Node he = n.get("half_extents");
                const Vec3 e = he.vec3();
                for (int i = 0; i < 3; ++i) checked(he.item(static_cast<std::size_t>(i)), Range::Positive);
                return factory(n, [&] { return make_box(e); });
            }
            case ShapeType::Capsule: {
                n.allow_keys({"type", "radius", "half_height"});
                const Real radius = checked(n.get("radius"), Range::Positive);
                const Real half_height = checked(n.get("half_height"), Range::NonNegative);
                return factory(n, [&] { return make_capsule(half_height, radius); });
            }
            case ShapeType::ConvexHull: {
                n.allow_keys({"type", "points"});
                const std::vector<Vec3> points = read_points(n.get("points"));
                return factory(n, [&] { return make_convex_hull(points); });
            }
            case ShapeType::Plane: {
                n.allow_keys({"type", "normal", "offset"});
                const Vec3 normal = n.get("normal").vec3();
                const Real offset = read_real(n, "offset", 0, Range::Any);
                return factory(n, [&] { return make_plane(normal, offset); });
            }
            case ShapeType::TriangleMesh: return parse_triangle_mesh(n);
            case ShapeType::Compound: return parse_compound(n);
            default: n.fail("unreachable shape type");
        }
    }

    Shape parse_triangle_mesh(const Node& n) {
        n.allow_keys({"type", "vertices", "indices", "obj"});
        std::vector<Vec3> vertices;
        std::vector<std::uint32_t> indices;
        if (auto obj = n.find("obj")) {
            if (n.find("vertices") || n.find("indices"))
                obj->fail("give either \"obj\" or \"vertices\" and \"indices\", not both");
            std::filesystem::path p(obj->string());
            if (p.is_relative()) p = std::filesystem::path(ctx_.dir) / p;
            try {
                ObjMesh mesh = read_obj_file(p.string());
                vertices = std::move(mesh.vertices);
                indices = std::move(mesh.indices);
            } catch (const std::runtime_error& e) {
                obj->fail(e.what());
            }
        } else {
            vertices = read_points(n.get("vertices"));
            const Node tris = n.get("indices");
            const std::size_t count = tris.array_size();
            indices.reserve(3 * count);
            for (std::size_t t = 0; t < count; ++t) {
                const Node tri = tris.item(t);
                if (!tri.json().is_array() || tri.json().size() != 3)
                    tri.type_error("[a, b, c] (an array of 3 vertex indices)");
                for (std::size_t k = 0; k < 3; ++k) {
                    const Node index = tri.item(k);
                    const long long v = index.integer();
                    if (v < 0 || v >= static_cast<long long>(vertices.size()))
                        index.fail("vertex index " + std::to_string(v) + " is out of range (the mesh has " +
                                   std::to_string(vertices.size()) + " vertices)");
                    indices.push_back(static_cast<std::uint32_t>(v));
                }
            }
        }
        return factory(n, [&] { return make_triangle_mesh(vertices, indices); });
    }

    Shape parse_compound(const Node& n) {
        n.allow_keys({"type", "children"});
        const Node children = n.get("children");
        const std::size_t count = children.array_size();
        std::vector<std::pair<Transform, Shape>> parts;
        parts.reserve(count);
        for (std::size_t i = 0; i < count; ++i) {
            const Node c = children.item(i);
            c.allow_keys({"shape", "position", "rotation", "rotation_deg"});
            Shape child = shape_ref(c.get("shape"));
            parts.emplace_back(parse_pose(c), std::move(child));
        }
        return factory(n, [&] { return make_compound(parts); });
    }

    // ---- poses --------------------------------------------------------------------------------------
    /// [w, x, y, z], finite and not zero; not normalised.
    static Quat read_quaternion(const Node& quat) {
        if (!quat.json().is_array() || quat.json().size() != 4) quat.type_error("[w, x, y, z] (an array of 4 numbers)");
        const Quat q(quat.item(0).real(), quat.item(1).real(), quat.item(2).real(), quat.item(3).real());
        if (!(q.norm() > Real(1e-6))) quat.fail(quat.name() + " quaternion must not be zero, got " + quat.json().dump());
        return q;
    }

    static Transform parse_pose(const Node& obj) {
        Transform xf;
        xf.p = read_vec3(obj, "position", Vec3::Zero());
        std::optional<Node> quat = obj.find("rotation");
        std::optional<Node> euler = obj.find("rotation_deg");
        if (quat && euler) euler->fail("give either rotation or rotation_deg, not both");
        if (quat) {
            if (!quat->json().is_array() || quat->json().size() != 4)
                quat->type_error("[w, x, y, z] (an array of 4 numbers)");
            double c[4];
            double norm2 = 0;
            for (std::size_t i = 0; i < 4; ++i) {
                c[i] = quat->item(i).number();
                norm2 += c[i] * c[i];
            }
            // Normalised here (scene files are hand-written); a zero or near-zero one has no direction.
            const double norm = std::sqrt(norm2);
            if (!(norm > 1e-6) || !std::isfinite(norm))
                quat->fail("rotation quaternion must not be zero, got " + quat->json().dump());
            xf.q = Quat(Real(c[0] / norm), Real(c[1] / norm), Real(c[2] / norm), Real(c[3] / norm));
            // One that is unit to the precision of Real already (a saved world's) is taken as written, so
            // that it comes back bit for bit: RigidSystem::create_body normalises it in Real anyway.
            const Quat written(static_cast<Real>(c[0]), static_cast<Real>(c[1]), static_cast<Real>(c[2]),
                               static_cast<Real>(c[3]));
            double written2 = 0;
            for (int i = 0; i < 4; ++i) written2 += double(written.coeffs()[i]) * double(written.coeffs()[i]);
            if (std::abs(written2 - 1) <= 8 * double(kEpsilon)) xf.q = written;
        } else if (euler) {
            xf.q = quat_from_euler_xyz_deg(euler->vec3());
        }
        return xf;
    }

    // ---- bodies -------------------------------------------------------------------------------------
    void add_body(SceneBody body, const Node& where) {
        auto [it, inserted] = body_names_.emplace(body.name, body.json_path);
        if (!inserted) where.fail("duplicate body name \"" + body.name + "\" (first used at " + it->second + ")");
        desc_.bodies.push_back(std::move(body));
    }

    void parse_body(const Node& b, std::size_t index) {
        b.allow_keys({"name", "type", "shape", "position", "rotation", "rotation_deg", "linear_velocity",
                      "angular_velocity", "material", "mass", "linear_damping", "angular_damping", "gravity_scale",
                      "allow_sleep", "filter", "sensor", "bullet", "user_data"});
        static const std::pair<const char*, BodyType> types[] = {
            {"static", BodyType::Static}, {"kinematic", BodyType::Kinematic}, {"dynamic", BodyType::Dynamic}};
        SceneBody body;
        body.json_path = b.path();
        body.name = "body-" + std::to_string(index);
        if (auto n = b.find("name")) {
            body.name = n->string();
            if (body.name.empty()) n->fail("a body name must not be empty");
        }
        BodyDef& d = body.def;
        d.type = read_enum(b, "type", BodyType::Dynamic, types);
        const Node shape = b.get("shape");
        d.shape = shape_ref(shape);
        if (d.type != BodyType::Static && !d.shape.can_be_dynamic())
            shape.fail(std::string("a ") + shape_type_name(d.shape.type) + " shape can only be used by a static body, and body \"" +
                       body.name + "\" is " + body_type_name_lower(d.type));
        d.pose = parse_pose(b);
        d.linear_velocity = read_vec3(b, "linear_velocity", Vec3::Zero());
        d.angular_velocity = read_vec3(b, "angular_velocity", Vec3::Zero());
        if (const std::string why = velocity_problem(d.linear_velocity, Vec3::Zero()); !why.empty())
            b.find("linear_velocity")->fail(why);
        if (const std::string why = velocity_problem(Vec3::Zero(), d.angular_velocity); !why.empty())
            b.find("angular_velocity")->fail(why);
        if (d.type == BodyType::Static) {
            for (const char* key : {"linear_velocity", "angular_velocity"})
                if (auto n = b.find(key); n && !n->vec3().isZero(0))
                    n->fail("a static body cannot move; use \"type\": \"kinematic\" for a moving body");
        }
        if (auto n = b.find("material")) d.material = material_ref(*n);
        if (auto n = b.find("mass")) {
            if (d.type != BodyType::Dynamic)
                n->fail("mass applies to dynamic bodies only; body \"" + body.name + "\" is " + body_type_name_lower(d.type));
            d.mass = checked(*n, Range::Positive);
        }
        d.linear_damping = read_real(b, "linear_damping", d.linear_damping, Range::NonNegative);
        d.angular_damping = read_real(b, "angular_damping", d.angular_damping, Range::NonNegative);
        d.gravity_scale = read_real(b, "gravity_scale", d.gravity_scale, Range::Any);
        d.allow_sleep = read_bool(b, "allow_sleep", d.allow_sleep);
        d.filter = read_filter(b);
        d.sensor = read_bool(b, "sensor", false);
        d.bullet = read_bool(b, "bullet", false);
        if (d.bullet && d.type != BodyType::Dynamic)
            b.get("bullet").fail("only a dynamic body can be a bullet, and body \"" + body.name + "\" is " +
                                 (d.type == BodyType::Static ? "static" : "kinematic"));
        if (d.sensor && !d.shape.can_be_dynamic())
            shape.fail(std::string("a sensor's shape must be a sphere, box, capsule, hull or compound, and body \"") +
                       body.name + "\"'s is a " + shape_type_name(d.shape.type));
        check_mass_properties(d, b);
        if (auto n = b.find("user_data")) {
            if (!n->json().is_number_unsigned()) n->type_error("an integer >= 0");
            d.user_data = n->json().get<std::uint64_t>();
        }
        add_body(std::move(body), b.find("name") ? *b.find("name") : b);
    }

    // The rigid system computes these when the body is created; doing it here too means a shape with no
    // usable mass (a sliver hull, a mass that overflows) is reported while parsing, at the body's path.
    static void check_mass_properties(const BodyDef& d, const Node& where) {
        if (d.type != BodyType::Dynamic) return;
        try {
            MassProperties mp = d.mass > 0 ? mass_properties_for_mass(d.shape, d.mass)
                                           : compute_mass_properties(d.shape, d.material.density);
            if (!(mp.mass > 0) || !is_finite(mp.mass) || !mp.inertia.allFinite())
                where.fail("the body's mass properties are not finite and positive (mass " + std::to_string(mp.mass) + ")");
        } catch (const ShapeError& e) {
            where.fail(e.what());
        }
    }

    static std::string body_type_name_lower(BodyType t) {
        switch (t) {
            case BodyType::Static: return "static";
            case BodyType::Kinematic: return "kinematic";
            default: return "dynamic";
        }
    }

    // ---- generators ---------------------------------------------------------------------------------
    void parse_generator(const Node& g, std::size_t index) {
        g.expect_object();
        enum class Kind { Pyramid, Tower };
        static const std::pair<const char*, Kind> kinds[] = {{"pyramid", Kind::Pyramid}, {"tower", Kind::Tower}};
        g.get("type");
        const Kind kind = read_enum(g, "type", Kind::Pyramid, kinds);
        if (kind == Kind::Pyramid)
            g.allow_keys({"type", "name", "rows", "half_extent", "spacing", "base", "mass", "material", "count",
                          "grid_spacing", "allow_sleep"});
        else
            g.allow_keys({"type", "name", "height", "half_extent", "base", "mass", "material", "count",
                          "grid_spacing", "allow_sleep"});

        const char* size_key = kind == Kind::Pyramid ? "rows" : "height";
        const int size = checked_int(g.get(size_key), 1, 100000);
        const Real half = read_real(g, "half_extent", Real(0.5), Range::Positive);
        Real spacing = 2 * half;
        if (kind == Kind::Pyramid) {
            spacing = read_real(g, "spacing", 2 * half, Range::Positive);  // default: faces touching
            if (spacing < 2 * half)
                g.get("spacing").fail("spacing = " + g.get("spacing").json().dump() +
                                      " is less than a box width (2 * half_extent), so neighbours would overlap");
        }
        const Vec3 base = read_vec3(g, "base", Vec3::Zero());

        SceneBody proto;
        proto.json_path = g.path();
        BodyDef& d = proto.def;
        d.type = BodyType::Dynamic;
        d.shape = factory(g, [&] { return make_box(Vec3::Constant(half)); });
        if (auto n = g.find("material")) d.material = material_ref(*n);
        d.mass = read_real(g, "mass", 0, Range::Positive);
        d.allow_sleep = read_bool(g, "allow_sleep", true);
        check_mass_properties(d, g);

        // A grid of copies, centred on `base`, one pitch of grid_spacing apart along x and z.
        int nx = 1, nz = 1;
        if (auto c = g.find("count")) {
            if (!c->json().is_array() || c->json().size() != 2) c->type_error("[nx, nz] (an array of 2 integers)");
            nx = checked_int(c->item(0), 1, 10000);
            nz = checked_int(c->item(1), 1, 10000);
        }
        // Footprint of one stack along x; the default pitch leaves one spacing of free floor between them.
        const Real width = kind == Kind::Pyramid ? Real(size - 1) * spacing + 2 * half : 2 * half;
        const Real default_pitch = kind == Kind::Pyramid ? width + spacing : 2 * width;
        const Real pitch = read_real(g, "grid_spacing", default_pitch, Range::Positive);
        if (pitch < width)
            g.get("grid_spacing").fail("grid_spacing = " + g.get("grid_spacing").json().dump() +
                                       " is less than the width of one " + (kind == Kind::Pyramid ? "pyramid" : "tower") +
                                       " (" + std::to_string(width) + "), so copies would overlap");
        const long long total = static_cast<long long>(nx) * nz * (kind == Kind::Pyramid ? size * (size + 1LL) / 2 : size);
        if (total > 10000000) g.fail("generator would create " + std::to_string(total) + " bodies (limit 10,000,000)");

        std::string prefix = std::string(kind == Kind::Pyramid ? "pyramid" : "tower") + std::to_string(index);
        if (auto n = g.find("name")) {
            prefix = n->string();
            if (prefix.empty()) n->fail("a generator name must not be empty");
        }
        const Node& where = g.find("name") ? *g.find("name") : g;
        for (int ix = 0; ix < nx; ++ix) {
            for (int iz = 0; iz < nz; ++iz) {
                const Vec3 origin = base + Vec3(Real(2 * ix - nx + 1) * Real(0.5) * pitch, 0,
                                                Real(2 * iz - nz + 1) * Real(0.5) * pitch);
                const std::string copy = nx * nz > 1 ? "/p" + std::to_string(ix * nz + iz) : "";
                if (kind == Kind::Pyramid) {
                    const std::vector<Vec3> centres = pyramid_box_centres(size, half, spacing, origin);
                    std::size_t k = 0;
                    for (int r = 0; r < size; ++r)
                        for (int c = 0; c < size - r; ++c) add_generated(proto, centres[k++], prefix + copy + "/r" +
                                                                            std::to_string(r) + "/c" + std::to_string(c), where);
                } else {
                    const std::vector<Vec3> centres = tower_box_centres(size, half, origin);
                    for (int r = 0; r < size; ++r)
                        add_generated(proto, centres[static_cast<std::size_t>(r)], prefix + copy + "/r" + std::to_string(r), where);
                }
            }
        }
    }

    void add_generated(const SceneBody& proto, const Vec3& centre, std::string name, const Node& where) {
        SceneBody b = proto;
        b.name = std::move(name);
        b.def.pose.p = centre;
        add_body(std::move(b), where);
    }

    // ---- joints -------------------------------------------------------------------------------------
    // Each joint names its two bodies (from "bodies" or generators); anchors and the axis are in the
    // bodies' frames. Everything JointSet::create() would reject is caught here, at the offending key.
    void parse_joints(const Node& js) {
        const std::size_t count = js.array_size();
        if (count == 0) return;
        std::unordered_map<std::string, std::size_t> index_of;
        index_of.reserve(desc_.bodies.size());
        for (std::size_t i = 0; i < desc_.bodies.size(); ++i) index_of.emplace(desc_.bodies[i].name, i);
        // Soft bodies are parsed after the joints (their attachments name rigid bodies); a joint may name
        // one by its "name" (checked fully when the soft bodies are parsed).
        soft_index_of_.clear();
        if (auto soft = root_.find("soft_bodies"))
            for (std::size_t i = 0; i < soft->array_size(); ++i)
                if (auto name = soft->item(i).find("name"))
                    if (name->json().is_string()) soft_index_of_.emplace(name->json().get<std::string>(), i);
        desc_.joints.reserve(count);
        for (std::size_t i = 0; i < count; ++i) parse_joint(js.item(i), index_of);
    }

    std::size_t joint_body(const Node& ref, const std::unordered_map<std::string, std::size_t>& index_of,
                           bool& soft) const {
        const std::string& name = ref.string();
        auto it = index_of.find(name);
        soft = false;
        auto s = soft_index_of_.find(name);
        if (it != index_of.end() && s != soft_index_of_.end())
            ref.fail("\"" + name + "\" names both a rigid body and a soft body: a joint cannot tell which");
        if (it == index_of.end() && s != soft_index_of_.end()) {
            soft = true;
            return s->second;
        }
        if (it == index_of.end())
            ref.fail("unknown body \"" + name + "\"" +
                     (desc_.bodies.empty() ? std::string(" (the scene has no bodies)")
                                           : " (no body of the scene has that name)"));
        return it->second;
    }

    void parse_joint(const Node& n, const std::unordered_map<std::string, std::size_t>& index_of) {
        n.expect_object();
        static const std::pair<const char*, JointType> types[] = {{"ball", JointType::Ball},
                                                                  {"hinge", JointType::Hinge},
                                                                  {"slider", JointType::Slider},
                                                                  {"distance", JointType::Distance},
                                                                  {"fixed", JointType::Fixed}};
        n.get("type");
        const JointType type = read_enum(n, "type", JointType::Ball, types);
        const bool has_axis = type == JointType::Hinge || type == JointType::Slider;
        if (has_axis)
            n.allow_keys({"type", "body_a", "body_b", "anchor_a", "anchor_b", "collide_connected", "break_force", "axis",
                          "limit", "motor", "reference_rotation"});
        else if (type == JointType::Distance)
            n.allow_keys({"type", "body_a", "body_b", "anchor_a", "anchor_b", "collide_connected", "break_force",
                          "length", "frequency", "damping_ratio"});
        else if (type == JointType::Fixed)
            n.allow_keys({"type", "body_a", "body_b", "anchor_a", "anchor_b", "collide_connected", "break_force",
                          "reference_rotation"});
        else
            n.allow_keys({"type", "body_a", "body_b", "anchor_a", "anchor_b", "collide_connected", "break_force"});

        SceneJoint sj;
        sj.json_path = n.path();
        JointDef& d = sj.def;
        d.type = type;
        const Node ref_a = n.get("body_a"), ref_b = n.get("body_b");
        sj.body_a = joint_body(ref_a, index_of, sj.soft_a);
        sj.body_b = joint_body(ref_b, index_of, sj.soft_b);
        // A soft body stands in as a dynamic body whose frame is the world's (its proxy's, unturned).
        SceneBody soft_a, soft_b;
        soft_a.name = ref_a.string();
        soft_b.name = ref_b.string();
        const SceneBody& a = sj.soft_a ? soft_a : desc_.bodies[sj.body_a];
        const SceneBody& b = sj.soft_b ? soft_b : desc_.bodies[sj.body_b];
        if (sj.body_a == sj.body_b && sj.soft_a == sj.soft_b)
            ref_b.fail("body_b must differ from body_a (both are \"" + a.name + "\")");
        // A soft body's frame is the world's: its origin is nowhere in particular, so its anchor is given.
        if (sj.soft_a && !n.find("anchor_a"))
            n.fail("anchor_a is required when body_a is a soft body (\"" + a.name + "\"): a world point");
        if (sj.soft_b && type == JointType::Distance && !n.find("anchor_b"))
            n.fail("anchor_b is required for a distance joint whose body_b is a soft body (\"" + b.name + "\"): a world point");
        if (a.def.type != BodyType::Dynamic && b.def.type != BodyType::Dynamic)
            n.fail("a joint needs at least one dynamic body; \"" + a.name + "\" is " + body_type_name_lower(a.def.type) +
                   " and \"" + b.name + "\" is " + body_type_name_lower(b.def.type));
        // anchor_b defaults to the world point of anchor_a, so one anchor places the joint (for a distance
        // joint, whose anchors are apart, to B's origin).
        d.local_anchor_a = read_vec3(n, "anchor_a", Vec3::Zero());
        const Vec3 world_a = a.def.pose.apply(d.local_anchor_a);
        d.local_anchor_b = read_vec3(n, "anchor_b", type == JointType::Distance ? Vec3::Zero()
                                                                                : b.def.pose.apply_inverse(world_a));
        d.collide_connected = read_bool(n, "collide_connected", false);
        d.break_force = read_real(n, "break_force", 0, Range::NonNegative);
        // The joint's zero as a relative orientation (saved scenes write it: their bodies have moved since
        // the joint was made). Normalised by the joint set unless it already is unit.
        if (auto ref = n.find("reference_rotation")) d.reference_rotation = read_quaternion(*ref);

        if (has_axis) {
            const Node axis = n.get("axis");
            d.local_axis_a = axis.vec3();
            if (!(d.local_axis_a.norm() > Real(1e-6))) axis.fail("axis must be non-zero, got " + axis.json().dump());
            if (auto limit = n.find("limit")) {
                limit->allow_keys({"lower", "upper"});
                const Node lo = limit->get("lower"), hi = limit->get("upper");
                d.enable_limit = true;
                d.lower = lo.real();
                d.upper = hi.real();
                if (type == JointType::Hinge) {  // the hinge angle is measured in (-pi, pi]
                    if (d.lower < -kPi) lo.fail("a hinge's lower limit must be >= -pi rad, got " + lo.json().dump());
                    if (d.upper > kPi) hi.fail("a hinge's upper limit must be <= pi rad, got " + hi.json().dump());
                }
                if (d.lower > d.upper)
                    limit->fail("lower (" + lo.json().dump() + ") must be <= upper (" + hi.json().dump() + ")");
            }
            if (auto motor = n.find("motor")) {
                motor->allow_keys({"speed", "max_force"});
                d.enable_motor = true;
                d.motor_speed = read_real(*motor, "speed", 0, Range::Any);
                d.max_motor_force = checked(motor->get("max_force"), Range::NonNegative);
            }
        }
        if (type == JointType::Distance) {
            d.frequency = read_real(n, "frequency", 0, Range::NonNegative);
            d.damping_ratio = read_real(n, "damping_ratio", 0, Range::NonNegative);
            if (auto len = n.find("length")) {
                d.length = checked(*len, Range::Positive);
                if (!(d.length > Real(1e-4))) len->fail("length must be > 1e-4 m, got " + len->json().dump());
            } else {
                const Real now = (b.def.pose.apply(d.local_anchor_b) - world_a).norm();
                if (!(now > Real(1e-4)))
                    n.fail("the anchors coincide, so the rest length (their distance at creation) would be 0; "
                           "give \"length\" > 0 or use a ball joint");
            }
        }
        desc_.joints.push_back(std::move(sj));
    }

    Context ctx_;
    Node root_;
    SceneDesc desc_;
    std::unordered_map<std::string, Material> materials_;
    std::optional<Node> shapes_;
    std::unordered_map<std::string, Shape> built_shapes_;
    std::unordered_set<std::string> shapes_in_progress_;
    std::unordered_map<std::string, std::string> body_names_;  // name -> json path of first use
    std::unordered_map<std::string, std::size_t> soft_index_of_;  // soft body name -> index, for joints
};

}  // namespace

SceneDesc parse_scene_string(const std::string& text, const std::string& origin_name) {
    const scene_json::Json root = scene_json::parse_json_text(text, origin_name);
    scene_json::Context ctx{origin_name, std::filesystem::path(origin_name).parent_path().string()};
    return SceneParser(root, std::move(ctx)).parse();
}

SceneDesc parse_scene_file(const std::string& path) {
    std::error_code ec;
    if (std::filesystem::is_directory(path, ec)) throw SceneError(path, "", "is a directory, not a scene file");
    std::ifstream in(path, std::ios::binary);
    if (!in) throw SceneError(path, "", std::string("cannot open scene file (") + std::strerror(errno) + ")");
    std::ostringstream text;
    text << in.rdbuf();
    if (in.bad()) throw SceneError(path, "", "cannot read scene file");
    return parse_scene_string(text.str(), path);
}

}  // namespace sinew
