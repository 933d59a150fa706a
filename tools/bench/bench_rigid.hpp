// `sinew bench rigid`: the stacking scenes run with Sinew's solver settings and with Bullet, measured in
// the same run on the same machine.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "engine/world/scene.hpp"
#include "rigid/rigid_solver.hpp"
#include "tools/bench/bench_cloth.hpp"

namespace sinew::bench {

/// One (scene, engine, variant) run.
struct RigidRun {
    std::string scene;
    std::string engine;   ///< sinew-si, sinew-newton, bullet
    std::string variant;  ///< which setting of the engine (e.g. "warm+split", "cold+split", "default")
    int bodies = 0;       ///< dynamic bodies
    int iterations = 0;   ///< velocity iterations per step
    int steps = 0;
    double ms_per_step_median = 0;
    double max_drift = 0;  ///< m: largest distance any dynamic body moved from its start, over the run
    double max_drop = 0;   ///< m: largest downward displacement of any dynamic body, over the run
    bool stood = false;    ///< max_drift < 0.05 m
    bool collapsed = false;  ///< some body dropped more than 0.5 m
    bool finite = true;
    std::string simd = "none";  ///< soft step's contact kernel (avx, sse2, portable), else "none"
};

/// Tracks drift and drop of dynamic bodies against their start positions.
class DriftMeter {
public:
    void start(const std::vector<Vec3>& positions) { start_ = positions; }
    void sample(const std::vector<Vec3>& positions);
    double max_drift() const { return max_drift_; }
    double max_drop() const { return max_drop_; }

private:
    std::vector<Vec3> start_;
    double max_drift_ = 0, max_drop_ = 0;
};

/// The median of `v` (the mean of the two middle values for an even count; 0 for none): the one every
/// tool reports its per-step times with (sinew run, bench, compare).
double median(std::vector<double> v);
/// "a,b,,c" -> {"a", "b", "c"} (the --scenes and --engines lists).
std::vector<std::string> split_list(const std::string& s);
/// Fills the summary fields of a run (median time, drift, drop, stood, collapsed) from its samples.
void finish_run(RigidRun& run, const std::vector<double>& ms, const DriftMeter& meter);
std::string to_json_line(const RigidRun& r);

/// One engine, with one setting, stepping one scene. The driver steps all contenders of a scene in
/// alternating chunks of steps, so each sees the same machine conditions (a shared VM's speed drifts
/// by tens of percent over seconds; one after the other, two runs of the same code differed by 2x).
class RigidContender {
public:
    virtual ~RigidContender() = default;
    virtual void step() = 0;
    /// Positions of the dynamic bodies, in a fixed order.
    virtual std::vector<Vec3> positions() const = 0;
    /// Poses of every body of the scene, static ones included, in the scene's body order (the robustness
    /// benchmark's checks read joint anchors and orientations from them).
    virtual std::vector<Transform> poses() const = 0;
    /// False once the last step blew up, even if the engine contained it and left the state finite
    /// (Sinew's World::faults).
    virtual bool healthy() const { return true; }
    RigidRun run;  ///< identity (scene, engine, variant, bodies, iterations) set by the maker
};

/// Bullet 3.24 (Debian's libbullet), configured as issue 3 prescribes: btDiscreteDynamicsWorld with the
/// default sequential-impulse solver, `iterations` solver iterations, stepSimulation(h, 0), per-contact
/// friction equal to Sinew's mixed friction, deactivation disabled when the scene disables sleeping.
/// Ball joints become btPoint2PointConstraint; any other joint type, and soft bodies, throw
/// std::runtime_error (the scene is one Bullet is not run on).
std::unique_ptr<RigidContender> make_bullet_contender(const SceneDesc& scene, int iterations);

int cmd_bench(const std::vector<std::string>& args);

}  // namespace sinew::bench
