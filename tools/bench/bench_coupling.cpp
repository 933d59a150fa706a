// `sinew bench coupling` (tools/bench/bench_coupling.hpp). Each scene names one dynamic rigid body that
// rests on a soft body; it runs under one-way, two-way and hybrid coupling, stepped and timed alike
// (median thread CPU time per step, the accuracy figures read outside the timed region):
//   rest_height  the rigid body's height at the end (m);
//   carried      the soft bodies' impulses on it over the last second, over its weight times a second
//                (1: the soft body carries it; 0: it does not, e.g. it fell through to the ground);
//   ratio        ms per step over one-way's: what the coupling costs on top of the uncoupled step (one-way
//                steps both systems and sends nothing back).
// Sleeping is off, so every step of every run does the work it measures.
#include "tools/bench/bench_coupling.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "engine/world/scene.hpp"
#include "tools/bench/bench_cloth.hpp"  // BenchClock
#include "tools/bench/bench_rigid.hpp"  // median()
#include "tools/bench/results_file.hpp"
#include "tools/commands.hpp"

namespace sinew::bench {

namespace {

struct CouplingRun {
    std::string scene, strategy;
    int steps = 0;
    int substeps = 1;           ///< soft steps per step
    double rate_hz = 60;        ///< steps per simulated second
    double ms_per_step_median = 0;
    double ms_per_second = 0;   ///< median step time times the steps of a simulated second
    double ratio_to_one_way = 1;
    double rest_height = 0;
    double carried = 0;
    bool finite = true;
};

// The scene's first dynamic rigid body: the one resting on the soft body.
std::size_t dynamic_body(const SceneDesc& d) {
    for (std::size_t i = 0; i < d.bodies.size(); ++i)
        if (d.bodies[i].def.type == BodyType::Dynamic) return i;
    throw SceneError(d.file, "/bodies", "the coupling benchmark needs a dynamic rigid body resting on a soft body");
}

/// One run of `seconds` simulated time (or the scene's steps if 0) under `strategy`, with `substeps` soft
/// steps per step (0: the scene's, where the strategy allows them) and the step divided by `divide`.
CouplingRun run_one(const SceneDesc& scene, CouplingStrategy strategy, double seconds, int substeps, int divide,
                    BenchClock clock) {
    SceneDesc d = scene;
    d.coupling.settings.strategy = strategy;
    d.coupling.pairs.clear();
    if (substeps > 0) d.coupling.settings.substeps = substeps;
    if (strategy != CouplingStrategy::OneWay && strategy != CouplingStrategy::Hybrid)
        d.coupling.settings.substeps = 1;  // the others step both systems together
    d.settings.time_step /= Real(divide);
    const int steps = seconds > 0 ? int(std::lround(seconds / double(d.settings.time_step))) : scene.steps;
    // Awake throughout: a sleeping pair costs nothing and exchanges nothing, which would measure neither.
    d.settings.rigid.sleeping = false;
    d.settings.soft.sleeping = false;
    std::vector<BodyId> ids;
    const std::unique_ptr<World> w = build_world(d, &ids);
    const BodyId body = ids.at(dynamic_body(d));
    const Real h = d.settings.time_step;
    const int last_second = std::min(steps, int(std::lround(1 / h)));
    CouplingRun r;
    r.scene = d.name;
    r.strategy = coupling_strategy_name(strategy);
    r.substeps = d.coupling.settings.substeps;
    r.rate_hz = 1 / double(h);
    std::vector<double> ms;
    ms.reserve(std::size_t(steps));
    double impulse = 0;
    for (int s = 0; s < steps && r.finite; ++s) {
        const double t0 = bench_clock_ms(clock);
        w->step();
        ms.push_back(bench_clock_ms(clock) - t0);
        r.finite = w->faults().empty() && w->rigid().all_finite() && w->soft().all_finite();
        ++r.steps;
        if (s >= steps - last_second)
            for (const CouplingImpulse& c : w->coupling().impulses())
                if (c.rigid == body.index) impulse += double(c.impulse.y());
        if (s >= steps - last_second && strategy == CouplingStrategy::EmbedRigid) {
            // Embedded, the soft body pushes through its proxy's contacts in the rigid solver.
            w->coupling().embedding().for_each_proxy_contact([&](const RigidEmbedding::ProxyContact& c) {
                if (c.body == body.index) impulse += std::abs(double(c.normal.y()) * double(c.impulse));
            });
        }
    }
    r.ms_per_step_median = median(ms);
    r.ms_per_second = r.ms_per_step_median * r.rate_hz;
    r.rest_height = double(w->rigid().transform(body).p.y());
    const double weight = double(w->rigid().mass(body)) * double(-d.settings.rigid.gravity.y());
    r.carried = impulse / (weight * double(last_second) * double(h));
    return r;
}

std::string to_json_line(const CouplingRun& r) {
    const auto round4 = [](double v) { return std::isfinite(v) ? std::round(v * 1e4) / 1e4 : v; };
    nlohmann::ordered_json j;
    j["suite"] = "coupling";
    j["scene"] = r.scene;
    j["strategy"] = r.strategy;
    j["steps"] = r.steps;
    j["rate_hz"] = round4(r.rate_hz);
    j["substeps"] = r.substeps;
    j["ms_per_step_median"] = round4(r.ms_per_step_median);
    j["ms_per_second"] = round4(r.ms_per_second);
    j["ratio_to_one_way"] = round4(r.ratio_to_one_way);
    j["rest_height"] = round4(r.rest_height);
    j["carried"] = round4(r.carried);
    j["finite"] = r.finite;
    return j.dump();
}

std::string markdown_table(const std::vector<CouplingRun>& runs) {
    std::ostringstream o;
    o << "Each scene under every coupling strategy (`sinew bench coupling`; `docs/coupling.md`): median thread "
         "CPU time per step, its ratio to one-way (which steps both systems and sends nothing back), the "
         "rigid body's height at the end, and the share of its weight the soft body carried over the last "
         "second (1: carried; 0: it fell through). Sleeping off.\n\n";
    o << "| scene | strategy | ms/step | × one-way | rest height (m) | weight carried | finite |\n";
    o << "|---|---|---:|---:|---:|---:|---|\n";
    char buf[256];
    for (const CouplingRun& r : runs) {
        std::snprintf(buf, sizeof buf, "| %s | %s | %.3f | %.2f | %.3f | %.2f | %s |\n", r.scene.c_str(), r.strategy.c_str(),
                      r.ms_per_step_median, r.ratio_to_one_way, r.rest_height, r.carried, r.finite ? "yes" : "**no**");
        o << buf;
    }
    return o.str();
}

// Seed 001's Figure 4: the rigid system at its rate and the soft one at five times it (one-way and hybrid,
// sub-stepped), against two-way, which must step the whole world at the soft rate; and two-way at the
// rigid rate for reference (the soft system then runs slower than it was to).
std::string figure4_table(const std::vector<CouplingRun>& runs) {
    std::ostringstream o;
    o << "Seed 001's Figure 4 (`sinew bench coupling --figure-4`, scene `figure-4`): a 210-box pyramid that is "
         "right at 60 Hz beside a cloth trampoline that is to run at 300 Hz. One-way and hybrid step each "
         "system at its own rate (5 soft sub-steps per step); two-way steps both together, so at 300 Hz. Cost "
         "per simulated second (median thread CPU time per step times the steps of a second), the ball's "
         "height at the end and the share of its weight the cloth carried over the last second.\n\n";
    o << "| strategy | world rate (Hz) | soft sub-steps | ms per step | ms per simulated second | × one-way | ball height (m) | weight carried |\n";
    o << "|---|---:|---:|---:|---:|---:|---:|---:|\n";
    char buf[320];
    for (const CouplingRun& r : runs) {
        std::snprintf(buf, sizeof buf, "| %s | %.0f | %d | %.3f | %.1f | %.2f | %.3f | %.2f |\n", r.strategy.c_str(), r.rate_hz,
                      r.substeps, r.ms_per_step_median, r.ms_per_second, r.ratio_to_one_way, r.rest_height,
                      r.carried);
        o << buf;
    }
    return o.str();
}

}  // namespace

int cmd_bench_coupling(const std::vector<std::string>& args) {
    std::vector<std::string> scenes = {"ball-on-trampoline", "box-on-soft-block"};
    std::string markdown, scene_dir = "demos/scenes";
    int steps = 0;
    bool figure4 = false;
    for (std::size_t i = 1; i < args.size(); ++i) {
        const std::string& a = args[i];
        if (tool::is_option(a, "--scenes")) {
            scenes.clear();
            std::stringstream ss(tool::option_value(args, i, "--scenes"));
            for (std::string s; std::getline(ss, s, ',');)
                if (!s.empty()) scenes.push_back(s);
            if (scenes.empty()) throw tool::UsageError("--scenes needs at least one name");
        } else if (tool::is_option(a, "--steps")) {
            steps = int(tool::parse_int("--steps", tool::option_value(args, i, "--steps"), 1, 10000000));
        } else if (tool::is_option(a, "--markdown")) {
            markdown = tool::option_value(args, i, "--markdown");
        } else if (a == "--figure-4") {
            figure4 = true;
        } else if (tool::is_option(a, "--scene-dir")) {
            scene_dir = tool::option_value(args, i, "--scene-dir");
        } else {
            throw tool::UsageError("unknown option '" + a + "'");
        }
    }
    if (figure4) {
        const SceneDesc scene = parse_scene_file(scene_dir + "/figure-4.json");
        const double seconds = steps > 0 ? steps * double(scene.settings.time_step) : 2.0;
        std::vector<CouplingRun> runs = {
            run_one(scene, CouplingStrategy::OneWay, seconds, 5, 1, BenchClock::ThreadCpu),
            run_one(scene, CouplingStrategy::Hybrid, seconds, 5, 1, BenchClock::ThreadCpu),
            run_one(scene, CouplingStrategy::TwoWay, seconds, 1, 5, BenchClock::ThreadCpu),
            run_one(scene, CouplingStrategy::TwoWay, seconds, 1, 1, BenchClock::ThreadCpu)};
        for (CouplingRun& r : runs) {
            // Per simulated second here: the runs step at different rates.
            r.ratio_to_one_way = runs.front().ms_per_second > 0 ? r.ms_per_second / runs.front().ms_per_second : 1;
            std::cout << to_json_line(r) << std::endl;
        }
        if (!markdown.empty() && !replace_section(markdown, "bench-coupling-figure-4", figure4_table(runs))) {
            std::cerr << "sinew bench: could not write " << markdown << "\n";
            return 1;
        }
        bool finite = true;
        for (const CouplingRun& r : runs) finite = finite && r.finite;
        return finite ? 0 : 3;
    }
    std::vector<CouplingRun> runs;
    for (const std::string& name : scenes) {
        const SceneDesc scene = parse_scene_file(scene_dir + "/" + name + ".json");
        const int n = steps > 0 ? steps : scene.steps;
        double one_way_ms = 0;
        for (CouplingStrategy s : {CouplingStrategy::OneWay, CouplingStrategy::TwoWay, CouplingStrategy::Hybrid,
                                   CouplingStrategy::Interleaved, CouplingStrategy::OneSolver,
                                   CouplingStrategy::EmbedRigid}) {
            CouplingRun r = run_one(scene, s, n * double(scene.settings.time_step), 0, 1, BenchClock::ThreadCpu);
            if (s == CouplingStrategy::OneWay) one_way_ms = r.ms_per_step_median;
            r.ratio_to_one_way = one_way_ms > 0 ? r.ms_per_step_median / one_way_ms : 1;
            std::cout << to_json_line(r) << std::endl;
            runs.push_back(r);
        }
    }
    if (!markdown.empty() && !replace_section(markdown, "bench-coupling", markdown_table(runs))) {
        std::cerr << "sinew bench: could not write " << markdown << "\n";
        return 1;
    }
    bool finite = true;
    for (const CouplingRun& r : runs) finite = finite && r.finite;
    return finite ? 0 : 3;
}

}  // namespace sinew::bench
