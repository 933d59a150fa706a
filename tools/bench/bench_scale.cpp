// `sinew bench scale`: see bench_scale.hpp.
#include "tools/bench/bench_scale.hpp"

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include <cmath>
#include <cstdio>
#include <iostream>
#include <sstream>

#include "engine/world/scene.hpp"
#include "engine/world/world.hpp"
#include "tools/bench/bench_cloth.hpp"
#include "tools/bench/bench_rigid.hpp"
#include "tools/bench/results_file.hpp"
#include "tools/commands.hpp"

namespace sinew::bench {

namespace {

struct ScaleRun {
    int grid = 0;  // grid x grid pyramids
    int bodies = 0;
    bool sleeping = false;
    int steps = 0;
    double ms_per_step_median = 0;
    double us_per_body = 0;
    double ratio_to_5k = 0;
    double us_detect = 0, us_solve = 0, us_positions = 0;  // per body per step, mean over the timed steps
    double bytes_per_body = -1;  // heap the settled world took, per body (-1: not measured on this C library)
    int awake = 0;
    bool finite = true;
};

/// Heap bytes in use (glibc: small blocks and mmapped ones), or -1 where the C library does not say.
double heap_bytes() {
#if defined(__GLIBC__) && (__GLIBC__ > 2 || (__GLIBC__ == 2 && __GLIBC_MINOR__ >= 33))
    const struct mallinfo2 m = mallinfo2();
    return double(m.uordblks) + double(m.hblkhd);
#else
    return -1;
#endif
}

std::string grid_scene(int grid, bool sleeping) {
    // many-pyramids' pyramids (10 rows of unit boxes, 12 m apart), with sleeping off or on: on, every
    // pyramid is asleep within a second (since contacts against the ground stopped rocking them).
    const int rows = 10, count = grid;
    const double pitch = 12.0;
    const double half = count * pitch / 2 + 10.0;  // the generator centres the grid on its base, (0, 0, 0)
    char buf[2048];
    std::snprintf(buf, sizeof buf,
                  R"({"format":"sinew-scene","version":1,"name":"scale-%d",
"settings":{"time_step":0.016666666666666666,"gravity":[0,-9.81,0],
"solver":{"kind":"soft_step","velocity_iterations":10},"sleeping":{"enabled":%s}},
"materials":{"box":{"density":1000,"friction":0.6,"restitution":0}},
"generators":[{"type":"pyramid","rows":%d,"half_extent":0.5,"spacing":1.0,"base":[0,0,0],"mass":1,
"material":"box","count":[%d,%d],"grid_spacing":%.1f}],
"bodies":[{"name":"ground","type":"static","shape":{"type":"box","half_extents":[%.1f,0.5,%.1f]},
"position":[0,-0.5,0],"material":"box"}]})",
                  grid, sleeping ? "true" : "false", rows, count, count, pitch, half, half);
    return buf;
}

std::string to_json_line(const ScaleRun& r) {
    char buf[512];
    std::snprintf(buf, sizeof buf,
                  "{\"grid\":%d,\"bodies\":%d,\"sleeping\":%s,\"steps\":%d,\"ms_per_step_median\":%.4f,"
                  "\"us_per_body\":%.4f,\"ratio_to_5k\":%.3f,\"us_detect\":%.4f,\"us_solve\":%.4f,"
                  "\"us_positions\":%.4f,\"bytes_per_body\":%.0f,\"awake\":%d,\"finite\":%s}",
                  r.grid, r.bodies, r.sleeping ? "true" : "false", r.steps, r.ms_per_step_median, r.us_per_body,
                  r.ratio_to_5k, r.us_detect, r.us_solve, r.us_positions, r.bytes_per_body, r.awake,
                  r.finite ? "true" : "false");
    return buf;
}

std::string markdown_table(const std::vector<ScaleRun>& runs, int warmup) {
    std::ostringstream md;
    md << "Square grids of 10-row pyramids (55 unit boxes each, many-pyramids' layout), with sleeping off "
          "and on (on, every pyramid is asleep within a second). One static ground, soft step, 10 iterations, one worker. Each world is stepped "
       << warmup << " steps (sleeping: at least 240)"
       << " past its first impacts, then timed (wall clock, median); `detect`, `solve` and `positions` "
          "are the rigid system's stages in µs per body per step (mean); `vs 5k` is µs/body over the grid "
          "nearest 5,000 bodies with the same sleeping setting; bytes/body is the heap the world took once settled. The sizes are timed in alternating chunks of 5 steps.\n\n";
    md << "| bodies | sleeping | awake | ms/step (median) | µs/body | vs 5k | detect | solve | positions | bytes/body |\n";
    md << "|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|\n";
    char buf[256];
    for (const ScaleRun& r : runs) {
        std::snprintf(buf, sizeof buf, "| %d | %s | %d | %.2f | %.3f | %.2f | %.3f | %.3f | %.3f | %.0f |\n", r.bodies,
                      r.sleeping ? "on" : "off", r.awake, r.ms_per_step_median, r.us_per_body, r.ratio_to_5k,
                      r.us_detect, r.us_solve, r.us_positions, r.bytes_per_body);
        md << (r.finite ? buf : "| (not finite) |\n");
    }
    return md.str();
}

/// One grid's world, built and stepped past its first impacts, with its heap and timers at that point.
struct GridWorld {
    std::unique_ptr<World> world;
    ScaleRun run;
    std::vector<double> ms;
    double detect0 = 0, solve0 = 0, positions0 = 0;
};

double rigid_stage_ms(const World& world, Stage s) {
    const int rs = world.pipeline().find_system("rigid");
    return rs >= 0 ? world.pipeline().timer(rs, s).total_ms : 0.0;
}

GridWorld warm_grid(int grid, bool sleeping, int warmup) {
    GridWorld g;
    g.run.grid = grid;
    g.run.sleeping = sleeping;
    const double heap0 = heap_bytes();
    g.world = build_world(parse_scene_string(grid_scene(grid, sleeping), "bench-scale"));
    g.run.bodies = int(g.world->rigid().body_count());
    for (int i = 0; i < warmup; ++i) g.world->step();
    const double heap1 = heap_bytes();
    if (heap0 >= 0 && heap1 >= 0) g.run.bytes_per_body = (heap1 - heap0) / double(g.run.bodies);
    g.detect0 = rigid_stage_ms(*g.world, Stage::DetectCollisions);
    g.solve0 = rigid_stage_ms(*g.world, Stage::SolveVelocities);
    g.positions0 = rigid_stage_ms(*g.world, Stage::IntegratePositions);
    return g;
}

void finish_grid(GridWorld& g) {
    ScaleRun& r = g.run;
    const World& w = *g.world;
    r.steps = int(g.ms.size());
    r.ms_per_step_median = median(g.ms);
    const double per = 1000.0 / double(std::max(1, r.steps)) / double(r.bodies);
    r.us_per_body = r.ms_per_step_median * 1000.0 / double(r.bodies);
    r.us_detect = (rigid_stage_ms(w, Stage::DetectCollisions) - g.detect0) * per;
    r.us_solve = (rigid_stage_ms(w, Stage::SolveVelocities) - g.solve0) * per;
    r.us_positions = (rigid_stage_ms(w, Stage::IntegratePositions) - g.positions0) * per;
    r.awake = int(w.rigid().awake_count());
    r.finite = w.rigid().all_finite() && w.faults().empty();
}

}  // namespace

int cmd_bench_scale(const std::vector<std::string>& args) {
    using tool::UsageError;
    std::vector<int> grids = {4, 10, 20, 30};
    int steps = 60, warmup = 60;
    bool with_sleeping = false;
    std::string markdown;
    for (std::size_t i = 1; i < args.size(); ++i) {
        const std::string& a = args[i];
        if (tool::is_option(a, "--grids")) {
            grids.clear();
            for (const std::string& g : split_list(tool::option_value(args, i, "--grids")))
                grids.push_back(int(tool::parse_int("--grids", g, 1, 60)));
        } else if (tool::is_option(a, "--steps"))
            steps = int(tool::parse_int("--steps", tool::option_value(args, i, "--steps"), 1, 100000));
        else if (tool::is_option(a, "--warmup"))
            warmup = int(tool::parse_int("--warmup", tool::option_value(args, i, "--warmup"), 0, 100000));
        else if (a == "--sleeping") with_sleeping = true;
        else if (tool::is_option(a, "--markdown")) markdown = tool::option_value(args, i, "--markdown");
        else throw UsageError("unknown option '" + a + "'");
    }
    if (grids.empty()) throw UsageError("--grids is empty");
    std::vector<ScaleRun> runs;
    for (bool sleeping : {false, true}) {
        if (sleeping && !with_sleeping) continue;
        // A world at rest needs time to fall asleep (seed 001 ch.2: half a second below the thresholds).
        const int warm = sleeping ? std::max(warmup, 240) : warmup;
        const std::size_t first = runs.size();
        std::vector<GridWorld> worlds;
        for (int g : grids) {
            std::cerr << "bench scale: about " << g * g * 55 << (sleeping ? " boxes in pyramids, sleeping on" : " boxes in pyramids, sleeping off")
                      << ", " << warm << " steps to settle...\n";
            worlds.push_back(warm_grid(g, sleeping, warm));
        }
        // Timed in alternating chunks (as bench threads does), so a busy moment of a shared machine falls
        // on every size alike instead of on one row of the table.
        std::cerr << "bench scale: " << steps << " timed steps each, in alternating chunks...\n";
        constexpr int kChunk = 5;
        for (int begin = 0; begin < steps; begin += kChunk)
            for (GridWorld& g : worlds)
                for (int i = begin; i < std::min(steps, begin + kChunk); ++i) {
                    const double t0 = bench_clock_ms(BenchClock::Wall);
                    g.world->step();
                    g.ms.push_back(bench_clock_ms(BenchClock::Wall) - t0);
                }
        for (GridWorld& g : worlds) {
            finish_grid(g);
            runs.push_back(g.run);
        }
        worlds.clear();
        // The reference row: the grid nearest 5,000 bodies.
        std::size_t ref = first;
        for (std::size_t k = first; k < runs.size(); ++k)
            if (std::abs(runs[k].bodies - 5000) < std::abs(runs[ref].bodies - 5000)) ref = k;
        for (std::size_t k = first; k < runs.size(); ++k) {
            runs[k].ratio_to_5k = runs[ref].us_per_body > 0 ? runs[k].us_per_body / runs[ref].us_per_body : 0;
            std::cout << to_json_line(runs[k]) << std::endl;
        }
    }
    if (!markdown.empty() && !replace_section(markdown, "bench-scale", markdown_table(runs, warmup))) {
        std::cerr << "sinew bench: could not write " << markdown << "\n";
        return 1;
    }
    return 0;
}

}  // namespace sinew::bench
