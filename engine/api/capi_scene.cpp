// C API: worlds from scene files (engine/world/scene.hpp: parse_scene_file, then build_world), the same
// loading `sinew run` does, so a C program and the tool step identical worlds.
#include "engine/api/capi_internal.hpp"
#include "engine/world/scene.hpp"
#include "rigid/joint_set.hpp"

using namespace sinew;
using namespace sinew::capi;

namespace {

// build_world creates the scene's joints in file order in a fresh world, so joint k has slot k and
// generation 1. Each is checked against the scene (same bodies) before its break-event record is kept;
// a joint that does not match is left out (its break event then has null bodies and user data 0).
void remember_scene_joints(WorldEntry& e, const SceneDesc& scene, const std::vector<BodyId>& ids) {
    const JointSet& joints = e.world->rigid().joints();
    for (std::size_t k = 0; k < scene.joints.size(); ++k) {
        const JointId id{static_cast<std::uint32_t>(k), 1};
        if (!joints.valid(id)) continue;
        const JointDef& d = joints.def(id);
        if (d.body_a != ids.at(scene.joints[k].body_a) || d.body_b != ids.at(scene.joints[k].body_b)) continue;
        e.events.remember_joint(id, d);
    }
}

}  // namespace

extern "C" sinew_status sinew_world_create_from_scene_file(const char* path, sinew_world_id* out) {
    const char* fn = "sinew_world_create_from_scene_file";
    return guarded(fn, [&] {
        if (!path) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": path is NULL");
        if (!out) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": out is NULL");
        SceneDesc scene;
        std::vector<BodyId> ids;
        std::unique_ptr<World> world;
        try {
            scene = parse_scene_file(path);  // most errors are found here, before a body exists
            world = build_world(scene, &ids);  // the rest (a joint's lever arm) while building
        } catch (const SceneError& e) {
            // "FILE: /json/pointer: problem", as the tool prints it.
            return fail(SINEW_ERROR_SCENE, std::string(fn) + ": " + e.what());
        }
        const sinew_world_id id = register_world(std::move(world));
        try {
            remember_scene_joints(*find_entry(id, fn), scene, ids);
        } catch (...) {
            unregister_world(id);
            throw;
        }
        log_message(SINEW_LOG_INFO, std::string(fn) + ": loaded scene \"" + scene.name + "\" from " + path + ": " +
                                        std::to_string(scene.bodies.size()) + " bodies, " +
                                        std::to_string(scene.joints.size()) + " joints, " +
                                        std::to_string(scene.soft_bodies.size()) + " soft bodies");
        const World& w = *find_world(id, fn);
        for (SoftBodyId s : w.soft().bodies()) warn_if_unstable(fn, id, w, s);
        *out = id;
        return SINEW_OK;
    });
}

extern "C" sinew_status sinew_world_save_scene(sinew_world_id world, const char* path) {
    const char* fn = "sinew_world_save_scene";
    return guarded(fn, [&] {
        World* w = find_world(world, fn);
        if (!w) return SINEW_ERROR_STALE_ID;
        if (!path) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": path is NULL");
        if (sinew_status s = check_not_stepping(w, fn)) return s;
        try {
            save_scene_file(*w, path);
        } catch (const SceneError& e) {
            return fail(SINEW_ERROR_SCENE, std::string(fn) + ": " + e.what());
        }
        return SINEW_OK;
    });
}
