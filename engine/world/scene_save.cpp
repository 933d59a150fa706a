// Saving a world as a scene file (docs/scene-format.md, "Saving a world"): settings, rigid bodies in slot
// order named "body-SLOT" with their current state, joints naming them, and soft bodies written out
// particle by particle (builder "explicit", scene_save_soft.cpp). The text layout and the exact printing
// of numbers are in scene_save_text.cpp.
//
// The file is read back by the ordinary loader, so that a saved world and the world built from the file
// start from the same state bit for bit. Numbers are printed so that they read back as the same Real
// (scene_save_text.cpp). Some values are recomputed on loading: a body's rotation (normalised by the
// loader and by RigidSystem::create_body unless already unit), its origin (the system keeps the centre
// of mass x and rebuilds it as q * com + origin), a hinge or slider axis (normalised by JointSet::create),
// a plane's normal and a compound child's rotation (normalised by their shape factories). For those the
// saver writes a value, within a few ulps of the true one, that the load maps exactly onto the world's
// value: it tries the true value, then its neighbours one and two ulps away. Joints also get their
// reference rotation (JointDef::reference_rotation), without which a reloaded joint would take its
// bodies' current relative orientation as its zero.
#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <unordered_map>

#include "rigid/rigid_body.hpp"
#include "engine/core/mass_properties.hpp"
#include "engine/world/scene.hpp"
#include "engine/world/scene_json.hpp"
#include "rigid/joint_set.hpp"

namespace sinew {

namespace scene_save {
using scene_json::Json;
// scene_save_text.cpp
std::string real_text(Real v);
std::string json_text(const Json& doc, const std::string& origin);
// scene_save_soft.cpp
Json soft_bodies_json(const World& world, const std::string& origin);
}  // namespace scene_save

namespace {

using scene_json::Json;

Json number(Real v) { return Json(static_cast<double>(v)); }
Json vec3(const Vec3& v) { return Json::array({number(v.x()), number(v.y()), number(v.z())}); }
Json quat(const Quat& q) { return Json::array({number(q.w()), number(q.x()), number(q.y()), number(q.z())}); }
std::string body_name(std::uint32_t slot) { return "body-" + std::to_string(slot); }

bool same_bits(Real a, Real b) { return std::memcmp(&a, &b, sizeof(Real)) == 0; }
bool same_bits(const Vec3& a, const Vec3& b) {
    return same_bits(a.x(), b.x()) && same_bits(a.y(), b.y()) && same_bits(a.z(), b.z());
}
bool same_bits(const Quat& a, const Quat& b) { return same_bits(a.w(), b.w()) && same_bits(a.vec(), b.vec()); }

/// `x` moved by `steps` representable values (negative: down).
Real nudge(Real x, int steps) {
    for (; steps > 0; --steps) x = std::nextafter(x, kRealMax);
    for (; steps < 0; ++steps) x = std::nextafter(x, -kRealMax);
    return x;
}

// ---- values the load recomputes: find what to write so that it comes back exactly -----------------

/// A value among `target`'s neighbours (each of its N components moved by at most 2 ulps, nearest
/// first) that `load` maps onto `target` exactly; `target` itself if none does (then the load is off
/// by an ulp or so).
template <int N, class Value, class Load>
Value preimage(const Value& target, Load load) {
    if (same_bits(load(target), target)) return target;
    for (int radius = 1; radius <= 2; ++radius) {
        int offset[N];
        const int side = 2 * radius + 1;
        int combos = 1;
        for (int k = 0; k < N; ++k) combos *= side;
        for (int c = 0; c < combos; ++c) {
            int rest = c, reach = 0;
            for (int k = 0; k < N; ++k) {
                offset[k] = rest % side - radius;
                rest /= side;
                reach = std::max(reach, std::abs(offset[k]));
            }
            if (reach != radius) continue;  // tried at a smaller radius
            Value v = target;
            for (int k = 0; k < N; ++k) v.coeffs()[k] = nudge(target.coeffs()[k], offset[k]);
            if (same_bits(load(v), target)) return v;
        }
    }
    return target;
}

/// The double the loader reads from the text written for v (the shortest decimal that narrows back to
/// v, which is not v itself in double).
double read_back(Real v) {
    const std::string text = scene_save::real_text(v);
    double d = 0;
    std::from_chars(text.data(), text.data() + text.size(), d);
    return d;
}

/// What the loader and RigidSystem::create_body make of a rotation written as q. The loader (parse_pose)
/// takes a quaternion that is unit to Real's precision as written, and normalises any other in double
/// before narrowing it to Real; create_body keeps one that is unit to rounding and normalises others.
Quat loaded_rotation(const Quat& q) {
    const double c[4] = {read_back(q.w()), read_back(q.x()), read_back(q.y()), read_back(q.z())};
    double norm2 = 0;
    for (double v : c) norm2 += v * v;
    const double norm = std::sqrt(norm2);
    Quat read(Real(c[0] / norm), Real(c[1] / norm), Real(c[2] / norm), Real(c[3] / norm));
    const Quat written(static_cast<Real>(c[0]), static_cast<Real>(c[1]), static_cast<Real>(c[2]),
                       static_cast<Real>(c[3]));
    double written2 = 0;
    for (int i = 0; i < 4; ++i) written2 += double(written.coeffs()[i]) * double(written.coeffs()[i]);
    if (std::abs(written2 - 1) <= 8 * double(kEpsilon)) read = written;
    return std::abs(read.squaredNorm() - 1) <= 4 * kEpsilon ? read : Quat(read.normalized());
}

struct VecCoeffs {  // Vec3 with the coeffs() accessor preimage() uses
    Vec3 v;
    Vec3& coeffs() { return v; }
    const Vec3& coeffs() const { return v; }
};
bool same_bits(const VecCoeffs& a, const VecCoeffs& b) { return same_bits(a.v, b.v); }

/// A unit vector to write so that v.normalized() (JointSet::create, make_plane) gives `unit` exactly.
Vec3 unit_to_write(const Vec3& unit) {
    return preimage<3>(VecCoeffs{unit}, [](const VecCoeffs& c) { return VecCoeffs{c.v.normalized()}; }).v;
}

/// The body origin to write: create_body places the centre of mass at q * com + origin, so each
/// component is searched for the origin that lands exactly on the world's centre of mass.
Vec3 origin_to_write(const Vec3& com_world, const Quat& q, const Vec3& local_com, const Vec3& origin) {
    const Vec3 arm = q * local_com;
    Vec3 out = origin;
    for (int k = 0; k < 3; ++k) {
        for (int step = 0; step <= 8; ++step) {
            const Real candidate = nudge(origin[k], (step % 2 ? 1 : -1) * ((step + 1) / 2));
            if (same_bits(Real(arm[k] + candidate), com_world[k])) {
                out[k] = candidate;
                break;
            }
        }
    }
    return out;
}

// ---- settings -----------------------------------------------------------------------------------

Json settings_json(const World& world) {
    const RigidSettings& r = world.rigid().settings();
    Json solver = Json::object();
    solver["kind"] = rigid_solver_name(r.solver);
    solver["velocity_iterations"] = r.velocity_iterations;
    solver["warm_starting"] = r.warm_starting;
    solver["gyroscopic"] = r.gyroscopic;
    solver["baumgarte"] = number(r.baumgarte);
    solver["slop"] = number(r.linear_slop);
    solver["restitution_threshold"] = number(r.restitution_threshold);
    solver["contact_margin"] = number(r.contact_margin);
    solver["max_correction_velocity"] = number(r.max_correction_velocity);
    solver["substeps"] = r.substeps;
    solver["contact_hertz"] = number(r.contact_hertz);
    solver["contact_damping_ratio"] = number(r.contact_damping_ratio);
    solver["contact_push_velocity"] = number(r.contact_push_velocity);
    solver["contact_mass_ratio"] = number(r.contact_mass_ratio);
    solver["continuous"] = r.continuous;
    Json newton = Json::object();
    newton["collision_iterations"] = r.newton_collision_iterations;
    newton["contact_iterations"] = r.newton_contact_iterations;
    newton["shock_propagation"] = r.newton_shock_propagation;
    newton["projection_fraction"] = number(r.newton_projection_fraction);
    solver["newton"] = std::move(newton);

    Json sleeping = Json::object();
    sleeping["enabled"] = r.sleeping;
    sleeping["linear_velocity"] = number(r.sleep_linear_velocity);
    sleeping["angular_velocity"] = number(r.sleep_angular_velocity);
    sleeping["time"] = number(r.sleep_time);

    Json s = Json::object();
    s["time_step"] = number(world.settings().time_step);
    s["max_steps_per_frame"] = world.settings().max_steps_per_frame;
    s["gravity"] = vec3(r.gravity);
    s["solver"] = std::move(solver);
    s["sleeping"] = std::move(sleeping);
    return s;
}

// ---- shapes -------------------------------------------------------------------------------------

Json shape_json(const Shape& s) {
    Json j = Json::object();
    j["type"] = shape_type_name(s.type);
    switch (s.type) {
        case ShapeType::Sphere: j["radius"] = number(s.radius); break;
        case ShapeType::Box: j["half_extents"] = vec3(s.half_extents); break;
        case ShapeType::Capsule:
            j["radius"] = number(s.radius);
            j["half_height"] = number(s.half_height);
            break;
        case ShapeType::ConvexHull: {
            Json points = Json::array();
            for (const Vec3& v : s.hull->vertices) points.push_back(vec3(v));
            j["points"] = std::move(points);
            break;
        }
        case ShapeType::Plane: {
            // make_plane divides normal and offset by the normal's length.
            const Vec3 normal = unit_to_write(s.normal);
            const Real length = normal.norm();
            Real offset = s.offset;
            for (int step = 0; step <= 4 && !same_bits(Real(offset / length), s.offset); ++step)
                offset = nudge(s.offset * length, (step % 2 ? 1 : -1) * ((step + 1) / 2));
            j["normal"] = vec3(normal);
            j["offset"] = number(offset);
            break;
        }
        case ShapeType::TriangleMesh: {
            Json vertices = Json::array(), indices = Json::array();
            for (const Vec3& v : s.mesh->vertices) vertices.push_back(vec3(v));
            const std::vector<std::uint32_t>& ix = s.mesh->indices;
            for (std::size_t t = 0; t + 2 < ix.size(); t += 3) indices.push_back(Json::array({ix[t], ix[t + 1], ix[t + 2]}));
            j["vertices"] = std::move(vertices);
            j["indices"] = std::move(indices);
            break;
        }
        case ShapeType::Compound: {
            Json children = Json::array();
            for (const CompoundChild& c : *s.children) {
                Json child = Json::object();
                child["shape"] = shape_json(*c.shape);
                child["position"] = vec3(c.local.p);
                // make_compound normalises the child's rotation in place (q.normalize()).
                child["rotation"] = quat(preimage<4>(c.local.q, [](const Quat& q) { return Quat(q.normalized()); }));
                children.push_back(std::move(child));
            }
            j["children"] = std::move(children);
            break;
        }
        default: break;
    }
    return j;
}

/// The shared data of a hull, mesh or compound (bodies made from one named scene shape share it), or
/// null for the shapes that are plain values.
const void* shared_data(const Shape& s) {
    switch (s.type) {
        case ShapeType::ConvexHull: return s.hull.get();
        case ShapeType::TriangleMesh: return s.mesh.get();
        case ShapeType::Compound: return s.children.get();
        default: return nullptr;
    }
}

// ---- bodies -------------------------------------------------------------------------------------

const char* body_type_key(BodyType t) {
    switch (t) {
        case BodyType::Static: return "static";
        case BodyType::Kinematic: return "kinematic";
        default: return "dynamic";
    }
}

Json body_json(const RigidSystem& rigid, BodyId id, const std::unordered_map<const void*, std::string>& shared) {
    const BodyType type = rigid.type(id);
    const Shape& shape = rigid.shape(id);
    const Material& m = rigid.material(id);
    Json b = Json::object();
    b["name"] = body_name(id.index);
    b["type"] = body_type_key(type);
    auto it = shared.find(shared_data(shape));
    b["shape"] = it != shared.end() ? Json(it->second) : shape_json(shape);

    // Pose: the state holds the centre of mass x and the rotation q; the file holds the origin.
    const RigidSystem::State& st = rigid.state();
    const Quat q_file = preimage<4>(st.q[id.index], loaded_rotation);
    Vec3 local_com = Vec3::Zero();
    const bool dynamic = type == BodyType::Dynamic;
    bool density_gives_mass = false;
    if (dynamic) {
        // The mass properties create_body will compute from what is written below: from the material's
        // density if that reproduces the body's mass, else from the mass.
        MassProperties mp;
        try {
            mp = compute_mass_properties(shape, m.density);
            density_gives_mass = same_bits(mp.mass, rigid.mass(id));
        } catch (const ShapeError&) {  // a density that was never used (the body was made with a mass)
        }
        if (!density_gives_mass) mp = mass_properties_for_mass(shape, rigid.mass(id));
        local_com = mp.center;
    }
    b["position"] = vec3(origin_to_write(st.x[id.index], loaded_rotation(q_file), local_com, rigid.transform(id).p));
    b["rotation"] = quat(q_file);
    if (type != BodyType::Static) {
        b["linear_velocity"] = vec3(rigid.linear_velocity(id));
        b["angular_velocity"] = vec3(rigid.angular_velocity(id));
    }
    Json material = Json::object();
    if (m.density > 0 && std::isfinite(m.density)) material["density"] = number(m.density);
    material["friction"] = number(m.friction);
    material["restitution"] = number(m.restitution);
    b["material"] = std::move(material);
    // A body made with an explicit mass keeps the material's density unused: write the mass then.
    if (dynamic && !density_gives_mass) b["mass"] = number(rigid.mass(id));
    b["linear_damping"] = number(rigid.linear_damping(id));
    b["angular_damping"] = number(rigid.angular_damping(id));
    b["gravity_scale"] = number(rigid.gravity_scale(id));
    b["allow_sleep"] = rigid.allow_sleep(id);
    if (const Json f = scene_json::filter_json(rigid.filter(id)); !f.is_null()) b["filter"] = f;
    if (rigid.is_sensor(id)) b["sensor"] = true;
    if (rigid.is_bullet(id)) b["bullet"] = true;
    if (rigid.user_data(id) != 0) b["user_data"] = rigid.user_data(id);
    return b;
}

// ---- joints -------------------------------------------------------------------------------------

Json joint_json(const JointDef& d) {
    Json j = Json::object();
    j["type"] = joint_type_name(d.type);
    j["body_a"] = body_name(d.body_a.index);
    j["body_b"] = body_name(d.body_b.index);
    j["anchor_a"] = vec3(d.local_anchor_a);
    j["anchor_b"] = vec3(d.local_anchor_b);
    j["collide_connected"] = d.collide_connected;
    j["break_force"] = number(d.break_force);
    if (d.type == JointType::Hinge || d.type == JointType::Slider) {
        j["axis"] = vec3(unit_to_write(d.local_axis_a));
        if (d.enable_limit) j["limit"] = Json::object({{"lower", number(d.lower)}, {"upper", number(d.upper)}});
        if (d.enable_motor)
            j["motor"] = Json::object({{"speed", number(d.motor_speed)}, {"max_force", number(d.max_motor_force)}});
    }
    if (d.type == JointType::Distance) {
        j["length"] = number(d.length);  // resolved at creation
        j["frequency"] = number(d.frequency);
        j["damping_ratio"] = number(d.damping_ratio);
    }
    // The joint's zero: the bodies have moved since it was made, so it is not their orientation now.
    if (d.type == JointType::Hinge || d.type == JointType::Slider || d.type == JointType::Fixed)
        j["reference_rotation"] = quat(d.reference_rotation);
    return j;
}

}  // namespace

namespace {

/// The text of the scene; a value that is not finite (a diverged world) throws SceneError naming
/// `origin` and the value's pointer.
std::string scene_text(const World& world, const std::string& name, const std::string& origin) {
    const RigidSystem& rigid = world.rigid();
    Json doc = Json::object();
    doc["format"] = kSceneFormat;
    doc["version"] = kSceneVersion;
    doc["name"] = name;
    doc["description"] = "Saved from a Sinew world: rigid bodies in slot order as \"body-SLOT\" with their current "
                         "state, soft bodies particle by particle (builder \"explicit\").";
    doc["settings"] = settings_json(world);

    // Hulls, meshes and compounds that several bodies share are written once, under "shapes".
    std::unordered_map<const void*, int> uses;
    for (std::uint32_t s = 0; s < rigid.slot_count(); ++s)
        if (rigid.slot_alive(s))
            if (const void* data = shared_data(rigid.slot_shape(s))) ++uses[data];
    std::unordered_map<const void*, std::string> shared;
    Json shapes = Json::object();
    for (std::uint32_t s = 0; s < rigid.slot_count(); ++s) {
        if (!rigid.slot_alive(s)) continue;
        const void* data = shared_data(rigid.slot_shape(s));
        if (data == nullptr || uses[data] < 2 || shared.count(data)) continue;
        const std::string key = "shape-" + std::to_string(shared.size());
        shared.emplace(data, key);
        shapes[key] = shape_json(rigid.slot_shape(s));
    }
    if (!shapes.empty()) doc["shapes"] = std::move(shapes);

    // Embedded soft bodies' proxies are not written: the coupling section makes them again.
    const RigidEmbedding& embedding = world.coupling().embedding();
    const auto soft_of = [&](BodyId id) { return embedding.count() ? embedding.soft_of(id) : SoftBodyId{}; };
    Json bodies = Json::array();
    for (std::uint32_t s = 0; s < rigid.slot_count(); ++s)
        if (rigid.slot_alive(s) && !embedding.is_proxy(rigid.id_of_slot(s)))
            bodies.push_back(body_json(rigid, rigid.id_of_slot(s), shared));
    doc["bodies"] = std::move(bodies);

    Json joints = Json::array();
    for (JointId id : rigid.joints().ids()) {
        JointDef d = rigid.joints().def(id);
        // A joint on a proxy names its soft body, with that end's anchor and axis in the world's frame
        // and the joint's zero turned to match (the proxy made at load is unturned): with c the proxy's
        // orientation now, q_A^-1 q_B = ref becomes c ref for a proxy A and ref c^-1 for a proxy B.
        const SoftBodyId sa = soft_of(d.body_a), sb = soft_of(d.body_b);
        for (const SoftBodyId& held : {sa, sb})
            if (!held.is_null() && embedding.embedded_by_elements(held))
                throw SceneError(origin, "/joints/" + std::to_string(joints.size()),
                                 "a joint holds an element proxy of soft body " + std::to_string(held.index) +
                                     " (coupling proxies \"elements\"), which a scene file cannot name (a joint "
                                     "in a file holds a soft body's whole-body proxy)");
        const bool zero_given = d.reference_rotation.coeffs().squaredNorm() > 0;
        if (!sa.is_null()) {
            const Transform xf = rigid.transform(d.body_a);
            d.local_anchor_a = xf.apply(d.local_anchor_a);
            d.local_axis_a = xf.q * d.local_axis_a;
            if (zero_given) d.reference_rotation = xf.q * d.reference_rotation;
        }
        if (!sb.is_null()) {
            const Transform xf = rigid.transform(d.body_b);
            d.local_anchor_b = xf.apply(d.local_anchor_b);
            if (zero_given) d.reference_rotation = d.reference_rotation * xf.q.conjugate();
        }
        Json j = joint_json(d);
        if (!sa.is_null()) j["body_a"] = "soft-" + std::to_string(sa.index);
        if (!sb.is_null()) j["body_b"] = "soft-" + std::to_string(sb.index);
        joints.push_back(std::move(j));
    }
    if (!joints.empty()) doc["joints"] = std::move(joints);

    Json soft = scene_save::soft_bodies_json(world, origin);
    if (!soft.empty()) doc["soft_bodies"] = std::move(soft);

    // Coupling: written when it is not the default; pairs naming bodies that no longer exist are dropped.
    const CouplingSettings& c = world.coupling().settings();
    const CouplingSettings defaults;
    Json pairs = Json::array();
    for (const CouplingPair& p : c.pairs) {
        if (!world.soft().valid(p.soft) || (!p.rigid.is_null() && !rigid.valid(p.rigid))) continue;
        if (embedding.is_proxy(p.rigid))  // a pair with a proxy: the proxy is not written, the pair is moot
            continue;
        Json j = {{"soft", "soft-" + std::to_string(p.soft.index)}, {"strategy", coupling_strategy_name(p.strategy)}};
        if (!p.rigid.is_null()) j["rigid"] = body_name(p.rigid.index);
        pairs.push_back(std::move(j));
    }
    if (c.strategy != defaults.strategy || c.exchange_iterations != defaults.exchange_iterations ||
        c.gain != defaults.gain || c.substeps != defaults.substeps || c.tolerance != defaults.tolerance ||
        c.embed_proxies != defaults.embed_proxies || c.embed_proxy_mass != defaults.embed_proxy_mass || !pairs.empty()) {
        Json j = {{"strategy", coupling_strategy_name(c.strategy)},
                  {"exchange_iterations", c.exchange_iterations},
                  {"gain", c.gain},
                  {"substeps", c.substeps}};
        if (c.strategy == CouplingStrategy::Auto || c.tolerance != defaults.tolerance) j["tolerance"] = c.tolerance;
        if (c.embed_proxies != defaults.embed_proxies || c.embed_proxy_mass != defaults.embed_proxy_mass) {
            j["proxies"] = embed_proxies_name(c.embed_proxies);
            j["proxy_mass"] = embed_proxy_mass_name(c.embed_proxy_mass);
        }
        if (!pairs.empty()) j["pairs"] = std::move(pairs);
        doc["coupling"] = std::move(j);
    }
    return scene_save::json_text(doc, origin);
}

}  // namespace

std::string scene_to_json_text(const World& world, const std::string& name) { return scene_text(world, name, name); }

void save_scene_file(const World& world, const std::string& path) {
    const std::string text = scene_text(world, std::filesystem::path(path).stem().string(), path);

    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    if (!out) throw SceneError(path, "", std::string("cannot write scene file (") + std::strerror(errno) + ")");
    out.write(text.data(), static_cast<std::streamsize>(text.size()));
    out.close();
    if (!out) throw SceneError(path, "", "cannot write scene file (write failed; disk full?)");
}

}  // namespace sinew
