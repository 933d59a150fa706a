// Turns a validated SceneDesc into a World.
#include "engine/world/scene.hpp"

namespace sinew {

std::unique_ptr<World> build_world(const SceneDesc& scene, std::vector<BodyId>* ids) {
    std::unique_ptr<World> world;
    try {
        world = std::make_unique<World>(scene.settings);
    } catch (const std::invalid_argument& e) {
        // The parser checks every setting's range; this catches limits only the world knows about.
        throw SceneError(scene.file, "/settings", e.what());
    }
    std::vector<BodyId> local_ids;
    std::vector<BodyId>& out = ids ? *ids : local_ids;  // joints need the ids even if the caller does not
    out.clear();
    out.reserve(scene.bodies.size());
    for (const SceneBody& body : scene.bodies) {
        try {
            out.push_back(world->rigid().create_body(body.def));
        } catch (const std::invalid_argument& e) {  // RigidError, ShapeError (e.g. mass properties)
            throw SceneError(scene.file, body.json_path, "body \"" + body.name + "\": " + e.what());
        }
    }
    for (const SceneJoint& joint : scene.joints) {
        if (joint.soft_a || joint.soft_b) continue;  // made below, once the soft bodies have their proxies
        JointDef def = joint.def;
        def.body_a = out.at(joint.body_a);
        def.body_b = out.at(joint.body_b);
        try {
            world->rigid().create_joint(def);
        } catch (const std::invalid_argument& e) {  // RigidError
            throw SceneError(scene.file, joint.json_path, std::string(joint_type_name(def.type)) + " joint: " + e.what());
        }
    }
    std::vector<SoftBodyId> soft_ids;
    soft_ids.reserve(scene.soft_bodies.size());
    for (const SceneSoftBody& soft : scene.soft_bodies) {
        SoftBodyDef def = soft.def;
        for (std::size_t k = 0; k < def.attachments.size(); ++k)
            def.attachments[k].target = pack_body_id(out.at(soft.attachment_bodies[k]));
        SoftBodyId id;
        try {
            id = world->soft().create_body(std::move(def));
        } catch (const std::invalid_argument& e) {  // SoftError
            throw SceneError(scene.file, soft.json_path, "soft body \"" + soft.name + "\": " + e.what());
        }
        soft_ids.push_back(id);
        if (!soft.velocities.empty()) {  // per-particle state of a saved body (builder "explicit")
            // Pinned particles keep zero; attached ones take theirs (their body's point velocity), which
            // the next step overwrites anyway.
            Particles& p = world->soft().body(id).p;
            std::vector<bool> pinned(p.size(), false);
            for (std::uint32_t i : soft.def.pinned) pinned[i] = true;
            for (std::size_t i = 0; i < p.size() && i < soft.velocities.size(); ++i)
                if (!pinned[i]) p.v[i] = soft.velocities[i];
        }
    }
    CouplingSettings coupling = scene.coupling.settings;
    for (const SceneCoupling::Pair& pair : scene.coupling.pairs) {
        CouplingPair p;
        p.soft = soft_ids.at(pair.soft);
        if (!pair.every_rigid) p.rigid = out.at(pair.rigid);
        p.strategy = pair.strategy;
        coupling.pairs.push_back(p);
    }
    try {
        world->set_coupling(coupling);
    } catch (const std::invalid_argument& e) {  // CouplingError: the parser checked the values already
        throw SceneError(scene.file, "/coupling", e.what());
    }
    // Joints on soft bodies hold their rigid proxies. The file gives a soft body's anchors and axis in the
    // world's frame (the proxy's frame as it is made, but for the origin at the nodes' centre of mass).
    for (const SceneJoint& joint : scene.joints) {
        if (!joint.soft_a && !joint.soft_b) continue;
        JointDef def = joint.def;
        // The file's zero (reference_rotation, if given) is in the same frames: a proxy made turned by q
        // (a rope's, whose rotation about its axis is free) turns it to q^-1 ref for A, ref q for B.
        const bool zero_given = def.reference_rotation.coeffs().squaredNorm() > 0;
        const auto end = [&](bool soft, std::size_t index, Vec3& anchor, Vec3* axis) {
            if (!soft) return out.at(index);
            const SceneSoftBody& sb = scene.soft_bodies.at(index);
            try {
                world->coupling().need_proxy(soft_ids.at(index));  // under "auto" the joint makes it embedded
            } catch (const std::invalid_argument& e) {  // CouplingError: a proxy that cannot be made
                throw SceneError(scene.file, joint.json_path, std::string(joint_type_name(def.type)) + " joint: " + e.what());
            }
            const BodyId proxy = world->coupling().embedding().proxy(soft_ids.at(index));
            if (proxy.is_null() && world->coupling().embedding().embedded_by_elements(soft_ids.at(index)))
                throw SceneError(scene.file, joint.json_path,
                                 std::string(joint_type_name(def.type)) + " joint: soft body \"" + sb.name +
                                     "\" is embedded with one proxy per element (coupling \"proxies\": \"elements\"); "
                                     "a joint in a scene file holds a whole-body proxy (\"proxies\": \"body\")");
            if (proxy.is_null())
                throw SceneError(scene.file, joint.json_path,
                                 std::string(joint_type_name(def.type)) + " joint: soft body \"" + sb.name +
                                     "\" is not embedded, so it has no rigid proxy to hold (give it the coupling "
                                     "strategy \"embed-rigid\" or \"auto\")");
            const Transform xf = world->rigid().transform(proxy);
            anchor = xf.apply_inverse(anchor);
            if (axis) *axis = xf.q.conjugate() * *axis;
            if (zero_given)
                def.reference_rotation = axis ? Quat(xf.q.conjugate() * def.reference_rotation)
                                              : Quat(def.reference_rotation * xf.q);
            return proxy;
        };
        def.body_a = end(joint.soft_a, joint.body_a, def.local_anchor_a, &def.local_axis_a);
        def.body_b = end(joint.soft_b, joint.body_b, def.local_anchor_b, nullptr);
        try {
            world->rigid().create_joint(def);
        } catch (const std::invalid_argument& e) {  // RigidError
            throw SceneError(scene.file, joint.json_path, std::string(joint_type_name(def.type)) + " joint: " + e.what());
        }
    }
    return world;
}

}  // namespace sinew
