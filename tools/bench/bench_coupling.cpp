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
#include "tools/bench/results_file.hpp"
#include "tools/commands.hpp"

namespace sinew::bench {

namespace {

struct CouplingRun {
    std::string scene, strategy;
    int steps = 0;
    double ms_per_step_median = 0;
    double ratio_to_one_way = 1;
    double rest_height = 0;
    double carried = 0;
    bool finite = true;
};

double median(std::vector<double> v) {
    if (v.empty()) return 0;
    std::sort(v.begin(), v.end());
    const std::size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// The scene's first dynamic rigid body: the one resting on the soft body.
std::size_t dynamic_body(const SceneDesc& d) {
    for (std::size_t i = 0; i < d.bodies.size(); ++i)
        if (d.bodies[i].def.type == BodyType::Dynamic) return i;
    throw SceneError(d.file, "/bodies", "the coupling benchmark needs a dynamic rigid body resting on a soft body");
}

CouplingRun run_one(const SceneDesc& scene, CouplingStrategy strategy, int steps, BenchClock clock) {
    SceneDesc d = scene;
    d.coupling.settings.strategy = strategy;
    d.coupling.pairs.clear();
    if (strategy != CouplingStrategy::OneWay) d.coupling.settings.substeps = 1;  // sub-steps are one-way's
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
    std::vector<double> ms;
    ms.reserve(std::size_t(steps));
    double impulse = 0;
    for (int s = 0; s < steps && r.finite; ++s) {
        const double t0 = bench_clock_ms(clock);
        w->step();
        ms.push_back(bench_clock_ms(clock) - t0);
        r.finite = w->rigid().all_finite() && w->soft().all_finite();
        ++r.steps;
        if (s >= steps - last_second)
            for (const CouplingImpulse& c : w->coupling().impulses())
                if (c.rigid == body.index) impulse += double(c.impulse.y());
    }
    r.ms_per_step_median = median(ms);
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
    j["ms_per_step_median"] = round4(r.ms_per_step_median);
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

}  // namespace

int cmd_bench_coupling(const std::vector<std::string>& args) {
    std::vector<std::string> scenes = {"ball-on-trampoline", "box-on-soft-block"};
    std::string markdown, scene_dir = "demos/scenes";
    int steps = 0;
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
        } else if (tool::is_option(a, "--scene-dir")) {
            scene_dir = tool::option_value(args, i, "--scene-dir");
        } else {
            throw tool::UsageError("unknown option '" + a + "'");
        }
    }
    std::vector<CouplingRun> runs;
    for (const std::string& name : scenes) {
        const SceneDesc scene = parse_scene_file(scene_dir + "/" + name + ".json");
        const int n = steps > 0 ? steps : scene.steps;
        double one_way_ms = 0;
        for (CouplingStrategy s : {CouplingStrategy::OneWay, CouplingStrategy::TwoWay, CouplingStrategy::Hybrid,
                                   CouplingStrategy::Interleaved}) {
            CouplingRun r = run_one(scene, s, n, BenchClock::ThreadCpu);
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
