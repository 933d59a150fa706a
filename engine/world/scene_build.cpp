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
    if (ids) {
        ids->clear();
        ids->reserve(scene.bodies.size());
    }
    for (const SceneBody& body : scene.bodies) {
        try {
            const BodyId id = world->rigid().create_body(body.def);
            if (ids) ids->push_back(id);
        } catch (const std::invalid_argument& e) {  // RigidError, ShapeError (e.g. mass properties)
            throw SceneError(scene.file, body.json_path, "body \"" + body.name + "\": " + e.what());
        }
    }
    return world;
}

}  // namespace sinew
