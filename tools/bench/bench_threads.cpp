// `sinew bench threads`: see bench_threads.hpp. Worlds of one scene at each worker count are stepped in
// alternating chunks (as the rigid race does), so a busy moment of a shared machine falls on all of them.
// Times are wall clock: the helpers' work is on other threads.
#include "tools/bench/bench_threads.hpp"

#include <cstdio>
#include <iostream>
#include <memory>
#include <sstream>
#include <thread>

#include "engine/world/scene.hpp"
#include "engine/world/world.hpp"
#include "tools/bench/bench_cloth.hpp"
#include "tools/bench/bench_rigid.hpp"
#include "tools/bench/results_file.hpp"
#include "tools/commands.hpp"

namespace sinew::bench {

namespace {

const char* kDefaultScenes[] = {"pyramid-40", "many-pyramids", "cloth-64", "fem-block-20k", "many-soft-bodies", "many-chains"};

struct ThreadRun {
    std::string scene;
    int workers = 1;
    int bodies = 0;
    std::size_t particles = 0;
    int steps = 0;
    double ms_per_step_median = 0;
    double speedup = 1;
    double ms_per_step_best_chunk = 0;  ///< the fastest chunk's mean: what the machine gives when no other guest interferes
    double speedup_best_chunk = 1;
    bool identical = true;
    bool finite = true;
};


std::string to_json_line(const ThreadRun& r) {
    char buf[512];
    std::snprintf(buf, sizeof buf,
                  "{\"scene\":\"%s\",\"workers\":%d,\"bodies\":%d,\"particles\":%zu,\"steps\":%d,"
                  "\"ms_per_step_median\":%.4f,\"speedup\":%.3f,\"ms_per_step_best_chunk\":%.4f,"
                  "\"speedup_best_chunk\":%.3f,\"identical\":%s,\"finite\":%s}",
                  r.scene.c_str(), r.workers, r.bodies, r.particles, r.steps, r.ms_per_step_median, r.speedup,
                  r.ms_per_step_best_chunk, r.speedup_best_chunk,
                  r.identical ? "true" : "false", r.finite ? "true" : "false");
    return buf;
}

std::string markdown_table(const std::vector<ThreadRun>& runs, int warmup) {
    std::ostringstream md;
    md << "Wall time per step (median) after " << warmup
       << " untimed steps (a stack settling from where the scene placed it changes its contacts every "
          "step), the same scene on each worker count in one run, stepped in alternating chunks; `speed-up` is over the first worker count, `identical` whether the end "
          "state is bit-identical to it. `best chunk` is the fastest chunk's mean time per step and its "
          "speed-up: on a machine shared with other guests, what the step costs when none interferes. "
          "The machine has "
       << std::thread::hardware_concurrency() << " hardware threads.\n\n";
    md << "| scene | bodies | particles | workers | steps | ms/step (median) | speed-up | ms/step (best chunk) "
          "| speed-up (best chunk) | identical |\n";
    md << "|---|---:|---:|---:|---:|---:|---:|---:|---:|---|\n";
    char buf[320];
    for (const ThreadRun& r : runs) {
        std::snprintf(buf, sizeof buf, "| %s | %d | %zu | %d | %d | %.3f | %.2f | %.3f | %.2f | %s |\n", r.scene.c_str(),
                      r.bodies, r.particles, r.workers, r.steps, r.ms_per_step_median, r.speedup,
                      r.ms_per_step_best_chunk, r.speedup_best_chunk,
                      !r.finite ? "not finite" : r.identical ? "yes" : "**no**");
        md << buf;
    }
    return md.str();
}

}  // namespace

int cmd_bench_threads(const std::vector<std::string>& args) {
    using tool::UsageError;
    std::vector<std::string> scenes(std::begin(kDefaultScenes), std::end(kDefaultScenes));
    std::vector<int> worker_counts = {1, 2};
    int steps = 300, warmup = 60;
    std::string markdown, scene_dir = "demos/scenes";
    for (std::size_t i = 1; i < args.size(); ++i) {
        const std::string& a = args[i];
        if (tool::is_option(a, "--scenes")) scenes = split_list(tool::option_value(args, i, "--scenes"));
        else if (tool::is_option(a, "--workers")) {
            worker_counts.clear();
            for (const std::string& w : split_list(tool::option_value(args, i, "--workers")))
                worker_counts.push_back(int(tool::parse_int("--workers", w, 1, kMaxWorkers)));
        } else if (tool::is_option(a, "--steps"))
            steps = int(tool::parse_int("--steps", tool::option_value(args, i, "--steps"), 1, 10000000));
        else if (tool::is_option(a, "--warmup"))
            warmup = int(tool::parse_int("--warmup", tool::option_value(args, i, "--warmup"), 0, 10000000));
        else if (tool::is_option(a, "--markdown")) markdown = tool::option_value(args, i, "--markdown");
        else if (tool::is_option(a, "--scene-dir")) scene_dir = tool::option_value(args, i, "--scene-dir");
        else throw UsageError("unknown option '" + a + "'");
    }
    if (scenes.empty()) throw UsageError("--scenes is empty");
    if (worker_counts.empty()) throw UsageError("--workers is empty");
    std::vector<ThreadRun> runs;
    for (const std::string& name : scenes) {
        SceneDesc scene = parse_scene_file(scene_dir + "/" + name + ".json");  // SceneError: exit 1
        // Sleeping off: every step does the scene's whole work (fem-block-20k fell asleep half way through
        // the run, and the median then fell between its awake and its sleeping steps).
        scene.settings.rigid.sleeping = false;
        scene.settings.soft.sleeping = false;
        std::vector<std::unique_ptr<World>> worlds;
        std::vector<ThreadRun> here;
        for (int workers : worker_counts) {
            worlds.push_back(build_world(scene));
            worlds.back()->set_threads(workers);
            ThreadRun r;
            r.scene = name;
            r.workers = workers;
            r.bodies = int(worlds.back()->rigid().body_count());
            r.particles = worlds.back()->soft().particle_count();
            here.push_back(r);
        }
        std::cerr << "bench threads: " << name << ": workers";
        for (int w : worker_counts) std::cerr << ' ' << w;
        std::cerr << ", " << warmup << " untimed steps, then " << steps << " each, stepped in alternating chunks...\n";
        for (std::size_t k = 0; k < worlds.size(); ++k)
            for (int i = 0; i < warmup && here[k].finite; ++i) {
                worlds[k]->step();
                if (!worlds[k]->faults().empty()) here[k].finite = false;
            }
        constexpr int kChunk = 20;
        std::vector<std::vector<double>> ms(worlds.size());
        std::vector<double> best(worlds.size(), 0);
        for (int begin = 0; begin < steps; begin += kChunk) {
            const int end = std::min(steps, begin + kChunk);
            for (std::size_t k = 0; k < worlds.size(); ++k) {
                double chunk = 0;
                int taken = 0;
                for (int i = begin; i < end && here[k].finite; ++i) {
                    const double t0 = bench_clock_ms(BenchClock::Wall);
                    worlds[k]->step();
                    ms[k].push_back(bench_clock_ms(BenchClock::Wall) - t0);
                    chunk += ms[k].back();
                    ++taken;
                    if (!worlds[k]->faults().empty()) here[k].finite = false;
                    else ++here[k].steps;
                }
                // Whole chunks only (the last may be short).
                if (taken == kChunk && (best[k] == 0 || chunk / taken < best[k])) best[k] = chunk / taken;
            }
        }
        const std::uint64_t first_hash = worlds[0]->state_hash();
        for (std::size_t k = 0; k < worlds.size(); ++k) {
            ThreadRun& r = here[k];
            r.finite = r.finite && worlds[k]->rigid().all_finite() && worlds[k]->soft().all_finite();
            r.ms_per_step_median = median(ms[k]);
            r.speedup = r.ms_per_step_median > 0 ? median(ms[0]) / r.ms_per_step_median : 0;
            r.ms_per_step_best_chunk = best[k];
            r.speedup_best_chunk = best[k] > 0 ? best[0] / best[k] : 0;
            r.identical = worlds[k]->state_hash() == first_hash;
            runs.push_back(r);
            std::cout << to_json_line(r) << std::endl;
        }
    }
    if (!markdown.empty() && !replace_section(markdown, "bench-threads", markdown_table(runs, warmup))) {
        std::cerr << "sinew bench: could not write " << markdown << "\n";
        return 1;
    }
    return 0;
}

}  // namespace sinew::bench
