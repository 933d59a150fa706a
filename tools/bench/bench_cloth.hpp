// `sinew bench cloth`: the soft-body scenes of issue 5 run with every Sinew soft method (several settings
// each) and with Bullet's btSoftBody, measured in the same run on the same machine.
//
// Each scene is one plain description (ClothScene) that both engines build from, so the two sides see the
// same geometry, masses, gravity, step and contacts.
#pragma once

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "engine/core/math.hpp"
#include "engine/world/scene.hpp"

namespace sinew::bench {

enum class ClothSceneKind { HangingCloth, ClothDrop, PressureBall };

/// Everything both engines need to build one benchmark scene.
struct ClothScene {
    std::string name;
    ClothSceneKind kind = ClothSceneKind::HangingCloth;
    Real h = Real(1) / 60;                     ///< s, one step per frame
    int steps = 600;
    Vec3 gravity = Vec3(0, Real(-9.81), 0);    ///< m/s^2
    Real total_mass = 1;                       ///< kg, spread evenly over all nodes (pins keep their share)

    // cloth (HangingCloth, ClothDrop): an n x n grid, structural and shear (both diagonals) links
    int n = 32;
    Vec3 corner00 = Vec3::Zero();              ///< node (0, 0)
    Vec3 corner10 = Vec3::Zero();              ///< node (n-1, 0)
    Vec3 corner01 = Vec3::Zero();              ///< node (0, n-1)
    bool pin_corners = false;                  ///< pin nodes (0, 0) and (n-1, 0)

    // closed surface (PressureBall): an icosphere
    Vec3 ball_centre = Vec3::Zero();
    Real ball_radius = Real(0.5);
    int ball_subdivisions = 3;                 ///< 3 -> 642 vertices
    Real pressure = 0;                         ///< Matyka's P_c (J); Bullet's kPR (same force law, see .cpp)

    // static colliders
    bool has_sphere = false;
    Vec3 sphere_centre = Vec3::Zero();
    Real sphere_radius = Real(0.5);
    bool has_ground = false;                   ///< the plane y = ground_y, solid below
    Real ground_y = 0;
    Real friction = Real(0.5);                 ///< particle/node against collider (Coulomb)
    Real thickness = Real(0.02);               ///< m: Sinew's particle radius, Bullet's collision margin
};

/// The benchmark description of a scene file (demos/scenes/cloth-32.json, ...): one soft body (a square
/// cloth, free or pinned at nodes [0,0] and [n-1,0], or an icosphere) and static colliders (a sphere and an
/// axis-aligned ground box). Throws SceneError for anything else, naming the file.
ClothScene cloth_scene_from(const SceneDesc& scene);
/// cloth_scene_from(parse_scene_file(scene_dir/NAME.json)).
ClothScene cloth_scene(const std::string& name, const std::string& scene_dir);

/// Rest surface of a scene's closed body (PressureBall): vertices and counter-clockwise triangles, from
/// Sinew's icosphere builder, so Bullet gets the very same mesh.
void scene_ball_mesh(const ClothScene& s, std::vector<Vec3>& vertices, std::vector<std::uint32_t>& triangles);

/// One (scene, engine, variant) run.
struct ClothRun {
    std::string scene;
    std::string engine;   ///< sinew-verlet, sinew-semi-implicit, sinew-implicit, sinew-fast-ms, bullet
    std::string variant;  ///< the setting, e.g. "it10+lra", "k=1e4 cg20"
    int nodes = 0;
    int links = 0;        ///< links measured for stretch (structural, shear, surface edges)
    int iterations = 0;   ///< Verlet relaxations / CG cap / local-global iterations / Bullet piterations
    double stiffness = 0;  ///< N/m of the spring methods (0 for the constraint methods)
    bool lra = false;     ///< long-range attachments on
    int steps = 0;
    double ms_per_step_median = 0;
    double max_stretch = 0;     ///< largest current / rest length over the measured links, at the last step
    double peak_stretch = 0;    ///< the same, largest over every step of the run
    double volume_ratio = std::numeric_limits<double>::quiet_NaN();  ///< closed bodies: volume / rest volume, last step
    double max_penetration = 0; ///< m: deepest any node is inside the sphere or below the ground, last step
    bool finite = true;
};

std::string to_json_line(const ClothRun& r);

/// What a step's time is measured with. Thread CPU time (the default) leaves out the time the thread
/// waits for a core, which dominates the noise on a shared machine; both engines are single-threaded.
enum class BenchClock { ThreadCpu, Wall };
/// Milliseconds on `clock` since an arbitrary origin.
double bench_clock_ms(BenchClock clock);

/// Depth (m, >= 0) of the deepest point of `x` inside the scene's static sphere or below its ground.
double scene_penetration(const ClothScene& s, const std::vector<Vec3>& x);

/// Bullet 3.24's btSoftBody in a btSoftRigidDynamicsWorld, configured as issue 5 prescribes: the cloth by
/// btSoftBodyHelpers::CreatePatch (diagonals on), the ball by CreateFromTriMesh with kPR; material kLST 1,
/// m_cfg.piterations = 10, total mass from the scene, otherwise Bullet's defaults.
ClothRun run_bullet_soft(const ClothScene& scene, int steps, BenchClock clock);

int cmd_bench_cloth(const std::vector<std::string>& args);

}  // namespace sinew::bench
