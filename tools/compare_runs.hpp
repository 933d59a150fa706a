// `sinew compare` (tools/cmd_compare.cpp): one scene run under a coupling or embedding variant, recorded
// step by step, and measured against a reference run of the same scene.
#pragma once

#include <string>
#include <vector>

#include "coupling/coupling_settings.hpp"
#include "coupling/strategy_picker.hpp"
#include "engine/world/scene.hpp"

namespace sinew::tool::compare {

/// How a scene is run: its strategy, the soft sub-steps per step (one-way and hybrid), hybrid's gain,
/// two-way's exchange iterations and the step divided by `divide` (the recorded samples stay one per
/// scene step).
struct Variant {
    CouplingStrategy strategy = CouplingStrategy::TwoWay;
    int substeps = 1;
    Real gain = 1;
    int divide = 1;
    int exchange = 0;    ///< two-way: exchange iterations (0: the scene's)
    Real tolerance = 0;  ///< auto: the tolerance (m); 0: the scene's
    EmbedProxies proxies = EmbedProxies::Body;                ///< embed-rigid: one proxy per body or per element
    EmbedProxyMass proxy_mass = EmbedProxyMass::Physical;     ///< embed-rigid per element: the nodes' weights
    std::string label() const;
    Real tolerance_in(const SceneDesc& scene) const { return tolerance > 0 ? tolerance : scene.coupling.settings.tolerance; }
};

/// The state at every scene step: dynamic rigid bodies' centres (the scene's bodies, not proxies) and
/// every soft node, and what the soft bodies pushed into rigid bodies.
struct Recording {
    std::vector<std::vector<Vec3>> rigid;  ///< [sample][body]
    std::vector<std::vector<Vec3>> soft;   ///< [sample][node]
    double ms_per_step_median = 0;         ///< per scene step (a divided run's steps summed)
    double max_penetration = 0;            ///< deepest rigid-rigid or soft-rigid penetration (m)
    Vec3 exchanged = Vec3::Zero();         ///< total impulse soft bodies gave dynamic rigid bodies (N s)
    bool finite = true;
    std::vector<StrategyPick> picks;       ///< auto: what it picked (as the run ended)
};

/// Runs `scene` for `steps` scene steps under `v`. With `record_path`, also writes a playback file of every
/// scene step (tools/record.hpp; the viewer plays several side by side).
Recording run_variant(const SceneDesc& scene, const Variant& v, int steps, const std::string& record_path = "");

/// The scene's name of a soft body of a world built from it (build_world makes them in the scene's order,
/// so a body's slot is its index there), or "soft N".
std::string scene_soft_name(const SceneDesc& scene, SoftBodyId id);

/// A recording's errors against a reference recording of the same scene and steps.
struct Errors {
    double rigid_rms = 0, rigid_max = 0;  ///< m, over every sample and dynamic rigid centre
    double soft_rms = 0, soft_max = 0;    ///< m, over every sample and soft node
    double final_max = 0;                 ///< m, the last sample's largest error (centres and nodes)
    double position_rms = 0;              ///< m, over centres and nodes together: the chart's accuracy
    double exchanged = 0;                 ///< |J - J_ref| / |J_ref| (0 if the reference exchanged none)
};
Errors errors_against(const Recording& run, const Recording& reference);

}  // namespace sinew::tool::compare
