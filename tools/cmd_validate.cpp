// `sinew validate SCENE.json...`: parse and build each scene, report the first problem of each.
#include <iostream>

#include "engine/world/scene.hpp"
#include "tools/commands.hpp"

namespace sinew::tool {

namespace {

int validate(const std::vector<std::string>& args) {
    std::vector<std::string> files;
    for (const std::string& a : args) {
        if (!a.empty() && a[0] == '-') throw UsageError("unknown option '" + a + "'");
        files.push_back(a);
    }
    if (files.empty()) throw UsageError("no scene file given");
    int status = kExitOk;
    for (const std::string& file : files) {
        try {
            // Building too, not just parsing: a scene is valid only if the world accepts every body.
            const SceneDesc scene = parse_scene_file(file);
            const std::unique_ptr<World> world = build_world(scene);
            if (files.size() > 1) std::cout << file << ": ";
            std::cout << "ok: " << world->rigid().body_count() << " bodies" << std::endl;
        } catch (const SceneError& e) {
            std::cerr << e.what() << std::endl;
            status = kExitFailure;
        }
    }
    return status;
}

}  // namespace

const Command validate_command = {
    "validate", validate, "check scene files: parse, build, report the first problem of each",
    "usage: sinew validate SCENE.json [SCENE.json...]\n"
    "\n"
    "Parses and builds each scene. Prints \"ok: N bodies\" (prefixed by the file name when several are\n"
    "given) or, on stderr, the problem as FILE: /json/pointer: message.\n"
    "Exit status: 0 all valid, 1 some scene is invalid, 2 bad arguments.\n"};

}  // namespace sinew::tool
