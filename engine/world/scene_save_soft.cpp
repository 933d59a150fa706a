// Saved soft bodies: each live soft body, in slot order, as builder "explicit" (docs/scene-format.md):
// its particles' current positions, masses and velocities, its links and surface triangles as they are,
// its pins and its attachments naming rigid bodies "body-SLOT", and its method, solver and material.
// Nothing is recomputed on loading except what SoftSystem::create_body derives from these (inverse
// masses, long-range attachments from the links and pins).
#include "rigid/rigid_body.hpp"
#include "engine/world/scene_json.hpp"
#include "engine/world/scene.hpp"
#include "engine/world/world.hpp"
#include "soft/fem_elements.hpp"
#include "soft/soft_integrators.hpp"

namespace sinew::scene_save {

using scene_json::Json;

namespace {

Json number(Real v) { return Json(static_cast<double>(v)); }
Json vec3(const Vec3& v) { return Json::array({number(v.x()), number(v.y()), number(v.z())}); }

const char* link_kind_name(LinkKind k) {
    switch (k) {
        case LinkKind::Structural: return "structural";
        case LinkKind::Shear: return "shear";
        case LinkKind::Bend: return "bend";
        default: return "other";
    }
}

/// A link with the keys that differ from Link's defaults (which the loader fills in).
Json link_json(const Link& l) {
    const Link d;
    Json j = Json::object();
    j["a"] = l.a;
    j["b"] = l.b;
    j["rest"] = number(l.rest);
    j["stiffness"] = number(l.stiffness);
    if (l.damping != d.damping) j["damping"] = number(l.damping);
    if (l.fraction != d.fraction) j["fraction"] = number(l.fraction);
    if (l.min_length != d.min_length) j["min_length"] = number(l.min_length);
    if (l.max_length != d.max_length) j["max_length"] = number(l.max_length);
    if (l.max_iterations != d.max_iterations) j["max_iterations"] = l.max_iterations;
    if (l.kind != d.kind) j["kind"] = link_kind_name(l.kind);
    return j;
}

Json soft_body_json(const RigidSystem& rigid, const SoftBody& b, std::uint32_t slot, const std::string& pointer,
                    const std::string& origin) {
    const SoftBodyDef& d = b.def;
    Json j = Json::object();
    j["name"] = "soft-" + std::to_string(slot);
    j["builder"] = "explicit";
    j["method"] = soft_method_name(d.method);
    j["solver"] = Json::object({{"iterations", d.iterations},
                                {"cg_tolerance", number(d.cg_tolerance)},
                                {"isotropic_blend", number(d.isotropic_blend)},
                                {"implicit_lambda", number(d.implicit_lambda)},
                                {"long_range_attachments", d.long_range_attachments},
                                {"preconditioner", soft_preconditioner_name(d.preconditioner)},
                                {"relaxation", soft_relaxation_name(d.relaxation)}});
    j["material"] = Json::object({{"drag", number(d.drag)},
                                  {"pressure", number(d.pressure)},
                                  {"friction", number(d.friction)},
                                  {"restitution", number(d.restitution)},
                                  {"thickness", number(d.thickness)},
                                  {"self_collision", d.self_collision}});
    j["gravity_scale"] = number(d.gravity_scale);
    j["allow_sleep"] = d.allow_sleep;
    if (const Json f = scene_json::filter_json(d.filter); !f.is_null()) j["filter"] = f;
    if (d.user_data != 0) j["user_data"] = d.user_data;

    const Particles& p = b.p;
    Json positions = Json::array(), masses = Json::array(), velocities = Json::array();
    bool moving = false;
    for (std::size_t i = 0; i < p.size(); ++i) {
        positions.push_back(vec3(p.x[i]));
        masses.push_back(number(p.mass[i]));
        velocities.push_back(vec3(p.v[i]));
        moving = moving || p.v[i] != Vec3::Zero();
    }
    j["positions"] = std::move(positions);
    j["masses"] = std::move(masses);
    if (moving) j["velocities"] = std::move(velocities);

    Json links = Json::array();
    for (const Link& l : b.links) links.push_back(link_json(l));
    j["links"] = std::move(links);
    // The loader (like SoftSystem::create_body) wants a pressure body's surface around positive volume; one
    // that has turned inside out could be saved but not loaded, so it is refused here.
    if (d.pressure > 0 && !(enclosed_volume(b.triangles, p.x) > 0))
        throw SceneError(origin, pointer + "/triangles",
                         "soft body " + std::to_string(slot) + " has pressure but its surface now encloses " +
                             std::to_string(enclosed_volume(b.triangles, p.x)) +
                             " m^3 (turned inside out), so it cannot be saved as a pressure body");
    if (!b.triangles.empty()) {
        Json triangles = Json::array();
        for (std::size_t t = 0; t + 2 < b.triangles.size(); t += 3)
            triangles.push_back(Json::array({b.triangles[t], b.triangles[t + 1], b.triangles[t + 2]}));
        j["triangles"] = std::move(triangles);
    }

    // FEM: the elements, the rest shape they measure strain from, the material, and any plastic strain.
    if (b.fem) {
        const FemState& s = *b.fem;
        Json tets = Json::array(), rest = Json::array(), plastic = Json::array();
        const std::size_t per = std::size_t(s.nodes_per_tet());  // quadratic tets: 10 (the loader reads the order from it)
        for (std::size_t t = 0; t + per <= s.tets.size(); t += per) tets.push_back(Json(std::vector<std::uint32_t>(&s.tets[t], &s.tets[t] + per)));
        for (const Vec3& x : s.rest) rest.push_back(vec3(x));
        bool plastic_any = false;
        for (const Strain6& e : s.plastic) {
            Json row = Json::array();
            for (const Real x : e) {
                row.push_back(number(x));
                plastic_any = plastic_any || x != 0;
            }
            plastic.push_back(std::move(row));
        }
        j["tets"] = std::move(tets);
        j["rest_positions"] = std::move(rest);
        if (plastic_any) j["plastic_strain"] = std::move(plastic);
        const FemMaterial& m = d.fem;
        j["fem"] = Json::object({{"young", number(m.young)},
                                 {"poisson", number(m.poisson)},
                                 {"density", number(m.density)},
                                 {"mass_damping", number(m.mass_damping)},
                                 {"stiffness_damping", number(m.stiffness_damping)},
                                 {"yield", number(m.yield)},
                                 {"creep", number(m.creep)},
                                 {"max_plastic", number(m.max_plastic)},
                                 {"rotation", fem_rotation_name(m.rotation)}});
    }

    // Attached particles have inverse mass 0 like pinned ones; an attachment whose body is gone leaves
    // its particle where it is, which is what a pin does.
    std::vector<bool> attached(p.size(), false);
    Json attachments = Json::array();
    for (const Attachment& a : b.attachments) {
        const BodyId target = unpack_body_id(a.target);
        if (!rigid.valid(target)) continue;
        attached[a.particle] = true;
        attachments.push_back(Json::object({{"particle", a.particle},
                                            {"body", "body-" + std::to_string(target.index)},
                                            {"local_point", vec3(a.local_point)}}));
    }
    Json pinned = Json::array();
    for (std::size_t i = 0; i < p.size(); ++i)
        if (p.inv_mass[i] == 0 && !attached[i]) pinned.push_back(i);
    if (!pinned.empty()) j["pinned"] = std::move(pinned);
    if (!attachments.empty()) j["attachments"] = std::move(attachments);
    return j;
}

}  // namespace

Json soft_bodies_json(const World& world, const std::string& origin) {
    const SoftSystem& soft = world.soft();
    Json out = Json::array();
    for (std::uint32_t s = 0; s < soft.slot_count(); ++s) {
        if (!soft.slot_alive(s)) continue;
        if (world.coupling().fem_embedding().is_proxy(soft.id_of_slot(s))) continue;  // made again by the coupling section
        // A particle attached to an embedded soft body's proxy: the proxy is not written (the coupling
        // section makes it again), so nothing in the file could name it.
        const std::vector<Attachment>& att = soft.slot_body(s).attachments;
        for (std::size_t k = 0; k < att.size(); ++k)
            if (world.coupling().embedding().is_proxy(unpack_body_id(att[k].target)))
                throw SceneError(origin, "/soft_bodies/" + std::to_string(out.size()) + "/attachments/" + std::to_string(k),
                                 "particle " + std::to_string(att[k].particle) +
                                     " is attached to the rigid proxy of an embedded soft body, which a scene file "
                                     "cannot name (attach it to a rigid body, or join the bodies with a joint)");
        if (soft.slot_alive(s))
            out.push_back(soft_body_json(world.rigid(), soft.slot_body(s), s, "/soft_bodies/" + std::to_string(out.size()),
                                         origin));
    }
    return out;
}

}  // namespace sinew::scene_save
