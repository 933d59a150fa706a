// Scene files: a JSON description of a world (settings, materials, shapes, bodies, generators) shared by
// the `sinew` tool, the demos, the benchmarks and the tests, so every tool runs the same cases (Box2D v3
// keeps one set of benchmark scenes for the same reason). The format is documented in
// docs/scene-format.md.
//
// Loading is two steps. parse_scene_*() reads and validates the whole file into a SceneDesc, plain data
// with no world attached: every error (malformed JSON, wrong type, unknown key, bad value, unknown name,
// degenerate shape) is found there, before any body exists, so a bad file never leaves a half-loaded
// world. build_world() then turns a SceneDesc into a World. Other engines (the benchmark's Bullet) can
// build the same scene from the same SceneDesc.
#pragma once

#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "engine/world/world.hpp"
#include "soft/soft_builders.hpp"

namespace sinew {

/// A problem in a scene file. what() reads "FILE: /bodies/3/mass: mass must be > 0, got -1" (the
/// pointer part is left out when the problem concerns the whole file, e.g. malformed JSON).
struct SceneError : std::runtime_error {
    SceneError(std::string file, std::string json_path, std::string problem);
    std::string file;       ///< the scene file, or the origin name given to parse_scene_string()
    std::string json_path;  ///< RFC 6901 JSON pointer to the offending value ("" = the whole document)
    std::string problem;    ///< what is wrong, naming the value
};

/// One body of a scene, fully resolved: named shapes and materials are substituted, generators expanded.
struct SceneBody {
    std::string name;       ///< unique within the scene
    std::string json_path;  ///< where it was defined ("/bodies/4" or "/generators/0"), for later errors
    BodyDef def;
};

/// One joint of a scene, fully resolved: the two bodies are indices into SceneDesc::bodies (their ids
/// in `def` are filled in by build_world), anchors and axis are in the bodies' frames.
struct SceneJoint {
    std::string json_path;  ///< where it was defined ("/joints/2"), for later errors
    std::size_t body_a = 0, body_b = 0;
    /// The body is a soft body (body_a / body_b index soft_bodies): the joint holds its rigid proxy, so
    /// the soft body must be embedded (coupling strategy embed-rigid). A soft body's frame for anchors and
    /// axes is the world's (its proxy's frame as it is made: the nodes' centre of mass, unturned).
    bool soft_a = false, soft_b = false;
    JointDef def;
};

/// One soft body of a scene, fully resolved: `def` holds the geometry the builder made, the method,
/// solver and material settings. `builder` and its parameters are kept so other engines (the benchmark's
/// Bullet) can build the same body their own way (btSoftBodyHelpers::CreatePatch for a cloth grid).
struct SceneSoftBody {
    std::string name;
    std::string json_path;      ///< "/soft_bodies/2"
    std::string builder;        ///< "cloth", "rope", "icosphere", "mesh", "ragdoll", "stick-box", "tet-box", "tet-mesh", "explicit"
    ClothGridDesc cloth;        ///< builder == "cloth": the grid as described
    std::vector<std::uint32_t> cloth_pinned_corners;  ///< builder == "cloth": pinned node indices
    Vec3 icosphere_center = Vec3::Zero();  ///< builder == "icosphere"
    Real icosphere_radius = 0;
    int icosphere_subdivisions = 0;
    /// builder == "tet-box": the box as described (the FEM benchmark refines its cells).
    struct TetBox {
        Vec3 min_corner = Vec3::Zero(), size = Vec3::Ones();
        int cells[3] = {1, 1, 1};
        int split = 5;  ///< tets per cell
    } tet_box;
    LinkMaterial links;         ///< the link material the builder used
    SoftBodyDef def;            ///< geometry, method, solver settings, material
    /// Attachments to scene bodies: def.attachments[k].target is filled in by build_world from
    /// attachment_bodies[k] (an index into SceneDesc::bodies).
    std::vector<std::size_t> attachment_bodies;
    /// builder == "explicit" with "velocities": each particle's initial velocity (m/s), set by build_world
    /// after creation (pinned and attached particles keep zero). Empty: def.initial_velocity for all.
    std::vector<Vec3> velocities;
};

/// The "coupling" section: the world's strategy and settings, and per-pair overrides naming bodies by
/// their index in SceneDesc (build_world turns them into ids).
struct SceneCoupling {
    CouplingSettings settings;  ///< pairs left empty here
    struct Pair {
        std::string json_path;  ///< "/coupling/pairs/0"
        std::size_t soft = 0;   ///< into SceneDesc::soft_bodies
        bool every_rigid = true;
        std::size_t rigid = 0;  ///< into SceneDesc::bodies, unless every_rigid
        CouplingStrategy strategy = CouplingStrategy::TwoWay;
    };
    std::vector<Pair> pairs;
    /// "compare_reference": the strategy `sinew compare` runs to convergence as the reference the others are
    /// measured against: two-way by default; embed-rigid for a scene whose soft bodies meet each other
    /// or hold joints, which only embedding models. Not world state: a saved world does not write it.
    CouplingStrategy compare_reference = CouplingStrategy::TwoWay;
};

/// A parsed and validated scene.
struct SceneDesc {
    std::string file;         ///< where it came from (path or origin name)
    std::string name;         ///< "name" key, or the file name without extension
    std::string description;
    WorldSettings settings;
    int steps = 600;          ///< default step count for `sinew run`
    std::vector<SceneBody> bodies;  ///< "bodies" in file order, then each generator's bodies in order
    std::vector<SceneJoint> joints; ///< "joints" in file order
    std::vector<SceneSoftBody> soft_bodies;  ///< "soft_bodies" in file order
    SceneCoupling coupling;
};

constexpr const char* kSceneFormat = "sinew-scene";  ///< value of the "format" key
constexpr int kSceneVersion = 1;                     ///< highest "version" this build reads

/// Reads and validates a scene file. Throws SceneError (also for a missing or unreadable file).
SceneDesc parse_scene_file(const std::string& path);
/// Same, from text. Relative paths inside (OBJ meshes) are resolved against origin_name's directory.
SceneDesc parse_scene_string(const std::string& text, const std::string& origin_name);

/// Writes `world` as a scene file (docs/scene-format.md) that parse_scene_file() reads back into the same
/// state: settings, every rigid body in slot order (named "body-SLOT"), joints, and soft bodies (builder
/// "explicit": their current particles, links, surface, pins and attachments), velocities included, bit
/// for bit. Not saved: sleep states, contact warm-start impulses and solver caches, so a reloaded world
/// starts awake and cold and drifts slightly from the original as both step (2.7 mm after 60 steps of
/// the stacking showcase; two worlds loaded from one file stay identical).
/// Throws SceneError naming the path if it cannot be written.
void save_scene_file(const World& world, const std::string& path);
/// The same, as JSON text; `name` goes into the "name" key.
std::string scene_to_json_text(const World& world, const std::string& name);

/// Creates a world with the scene's settings, bodies and joints. Bodies are created in SceneDesc order; if
/// `ids` is given it receives their ids in that order; joints follow, in order. Throws SceneError (naming
/// the body's or joint's json_path) if the rigid system rejects one; the partly built world is then
/// discarded.
std::unique_ptr<World> build_world(const SceneDesc& scene, std::vector<BodyId>* ids = nullptr);

// ---- building blocks, public so other engines and tests place bodies identically -------------------

/// Centres of the boxes of a pyramid of `rows` rows (issue 3's pyramid-R): row r (0 = bottom) holds
/// rows - r boxes centred on x = base.x with horizontal pitch `spacing`, at rest height
/// y = base.y + half + r * 2 * half (faces touching), in the plane z = base.z. Bottom row first, each row
/// from -x to +x. `base` is the centre of the bottom row's bottom face.
std::vector<Vec3> pyramid_box_centres(int rows, Real half_extent, Real spacing, const Vec3& base);
/// Centres of a column of `height` boxes standing on `base` (issue 3's tower-H), bottom first.
std::vector<Vec3> tower_box_centres(int height, Real half_extent, const Vec3& base);

/// Rotation from XYZ Euler angles in degrees: about x by rx, then about the fixed y by ry, then about
/// the fixed z by rz (R = Rz * Ry * Rx).
Quat quat_from_euler_xyz_deg(const Vec3& degrees);

/// A triangle mesh read from a Wavefront OBJ file: `v` and `f` lines only (polygons are fanned into
/// triangles, `v/vt/vn` and negative indices are understood, everything else is ignored).
struct ObjMesh {
    std::vector<Vec3> vertices;
    std::vector<std::uint32_t> indices;  ///< 3 per triangle
};
/// Throws std::runtime_error "PATH:LINE: problem" for a missing file or a bad line.
ObjMesh read_obj_file(const std::string& path);

}  // namespace sinew
