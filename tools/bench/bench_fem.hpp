// `sinew bench fem`: tetrahedral FEM (issue 13) with Sinew's element settings and with Bullet's
// btDeformableBody, measured in the same run on the same machine, on scenes both engines build from one
// description (FemScene).
#pragma once

#include <limits>
#include <string>
#include <vector>

#include "engine/core/math.hpp"
#include "soft/fem_material.hpp"
#include "soft/tet_mesh.hpp"
#include "tools/bench/bench_cloth.hpp"  // BenchClock

namespace sinew::bench {

enum class FemSceneKind {
    Beam,  ///< a beam clamped at its x = min end: accuracy from the settled tip deflection
    Drop,  ///< a block falling on the ground: accuracy from the volume
};

/// Everything both engines need to build one FEM benchmark run (one mesh refinement).
struct FemScene {
    std::string name;
    FemSceneKind kind = FemSceneKind::Beam;
    Real h = Real(1) / 60;
    int steps = 600;
    Vec3 gravity = Vec3(0, Real(-9.81), 0);
    TetMesh mesh;
    std::vector<Real> masses;          ///< lumped, per node
    std::vector<std::uint32_t> pinned;  ///< clamped nodes (Beam)
    FemMaterial material;
    bool has_ground = false;
    Real ground_y = 0;                 ///< the top of the ground box
    Real friction = Real(0.5);
    Real thickness = Real(0.01);
    int refinement = 1;                ///< cells per cell of the scene file's box
    int cg_cap = 100;                  ///< the scene's solver.iterations (Sinew's CG cap)
    Real cg_tolerance = Real(1e-3);    ///< the scene's solver.cg_tolerance
};

/// The scene file's FEM body (one tet-box) with its cells multiplied by `refinement`, its tets of `order`
/// (1 linear, 2 quadratic). Throws SceneError naming the file for anything else.
FemScene fem_scene(const std::string& name, const std::string& scene_dir, int refinement, int order = 1);

/// One (scene, refinement, engine, variant) run.
struct FemRun {
    std::string scene;
    std::string engine;   ///< sinew-implicit, bullet
    std::string variant;  ///< rotation, refinement, CG cap
    int tets = 0, nodes = 0;
    int steps = 0;
    double ms_per_step_median = 0;
    double tip_deflection = std::numeric_limits<double>::quiet_NaN();  ///< Beam: m, mean over the last second
    double accuracy = std::numeric_limits<double>::quiet_NaN();  ///< Beam: tip / reference; Drop: final volume ratio
    double min_volume_ratio = std::numeric_limits<double>::quiet_NaN();  ///< smallest volume / rest over the run
    int inverted = 0;     ///< tets with non-positive volume at the end
    double cg_iterations = std::numeric_limits<double>::quiet_NaN();  ///< Sinew: mean CG iterations per step
    bool finite = true;
};

/// Mean downward displacement of the nodes at the beam's free end (largest rest x).
double beam_tip(const FemScene& s, const std::vector<Vec3>& x);
/// Volume of the tets at x (m³) and the number with non-positive volume.
double mesh_volume(const TetMesh& mesh, const std::vector<Vec3>& x, int* inverted);

/// A run's accuracy figures, sampled step by step outside the timed region, the same for both engines:
/// the smallest volume ratio, a beam's tip deflection averaged over the last second, and at the end the
/// inverted tets and a block's final volume ratio.
struct FemTracker {
    const FemScene& s;
    double rest_volume;
    double tip_sum = 0;
    int tip_count = 0;
    double min_ratio = 1e30;
    explicit FemTracker(const FemScene& scene);
    void sample(const std::vector<Vec3>& x, int step, int steps);
    void finish(FemRun& run, const std::vector<Vec3>& x) const;
};

/// Bullet 3.24's btDeformableBody in a btDeformableMultiBodyDynamicsWorld: the same nodes, tets and lumped
/// masses, btDeformableLinearElasticityForce (its corotated linear element) with the scene's Lamé
/// parameters and Rayleigh damping, btDeformableGravityForce, its default solver, one step of h per frame.
FemRun run_bullet_fem(const FemScene& scene, int steps, BenchClock clock);

int cmd_bench_fem(const std::vector<std::string>& args);

}  // namespace sinew::bench
