// `sinew bench rigid [--scenes a,b] [--steps N] [--chart FILE.png] [--markdown FILE.md]`
//
// Runs every stacking scene under each Sinew solver setting and under Bullet in the same process, prints
// one JSON line per (scene, engine, variant) on stdout and progress on stderr. --markdown rewrites the
// rigid section of a results file (between <!-- bench-rigid:begin --> and <!-- bench-rigid:end -->);
// --chart draws time against drift with gnuplot.
#include "tools/bench/peers.hpp"
#include "tools/bench/bench_rigid.hpp"

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>

#include "tools/bench/bench_cloth.hpp"
#include "tools/bench/bench_coupling.hpp"
#include "tools/bench/bench_fem.hpp"
#include "tools/bench/bench_robustness.hpp"
#include "tools/bench/bench_scale.hpp"
#include "tools/bench/bench_threads.hpp"
#include "tools/bench/results_file.hpp"
#include "tools/commands.hpp"
#include "tools/progress.hpp"

namespace sinew::bench {

namespace {

const char* kDefaultScenes[] = {"pyramid-10", "pyramid-20", "pyramid-40", "tower-10", "tower-20", "many-pyramids"};

struct SinewVariant {
    const char* engine;
    const char* variant;
    RigidSolverKind solver;
    bool warm;
    SimdKernel simd = SimdKernel::Auto;  ///< soft step's contact kernel
};

// Soft step runs iterations/2 sub-steps: each sub-step makes two passes over the contacts (solve and
// relax), so its cost per step matches `iterations` passes of the others.
const SinewVariant kVariants[] = {
    {"sinew-si", "soft-step", RigidSolverKind::SoftStep, true},
    // The same arithmetic in the x86-64 baseline's four lanes, for machines without AVX (bit-identical).
    {"sinew-si", "soft-step-sse2", RigidSolverKind::SoftStep, true, SimdKernel::Sse2},
    {"sinew-si", "warm+split", RigidSolverKind::SplitImpulse, true},
    {"sinew-si", "cold+split", RigidSolverKind::SplitImpulse, false},
    {"sinew-si", "warm+baumgarte", RigidSolverKind::Baumgarte, true},
    {"sinew-newton", "shock", RigidSolverKind::Newton, false},
};

class SinewContender final : public RigidContender {
public:
    SinewContender(const SceneDesc& scene, const SinewVariant& v, int iterations, int workers) : simd_(v.simd) {
        SceneDesc s = scene;
        s.settings.rigid.solver = v.solver;
        s.settings.rigid.warm_starting = v.warm;
        s.settings.rigid.velocity_iterations = iterations;
        s.settings.rigid.substeps = 0;  // soft step: iterations / 2 sub-steps of two passes each
        s.settings.rigid.newton_contact_iterations = iterations;
        std::vector<BodyId> ids;
        world_ = build_world(s, &ids);
        world_->set_threads(workers);
        all_ = ids;
        for (std::size_t i = 0; i < ids.size(); ++i)
            if (s.bodies[i].def.type == BodyType::Dynamic) dyn_.push_back(ids[i]);
        run.scene = scene.name;
        run.engine = v.engine;
        run.variant = v.variant;
        run.bodies = int(dyn_.size());
        run.iterations = iterations;
        if (v.solver == RigidSolverKind::SoftStep) {
            set_simd_kernel(simd_);
            run.simd = simd_kernel_name(active_simd_kernel());
            set_simd_kernel(SimdKernel::Auto);
        }
    }
    void step() override {
        // The kernel choice is process-wide: forced around this contender's step only.
        set_simd_kernel(simd_);
        world_->step();
        set_simd_kernel(SimdKernel::Auto);
    }
    bool healthy() const override { return world_->faults().empty(); }
    std::vector<Vec3> positions() const override {
        std::vector<Vec3> p;
        p.reserve(dyn_.size());
        for (BodyId id : dyn_) p.push_back(world_->rigid().transform(id).p);
        return p;
    }
    std::vector<Transform> poses() const override {
        std::vector<Transform> p;
        p.reserve(all_.size());
        for (BodyId id : all_) p.push_back(world_->rigid().transform(id));
        return p;
    }

private:
    std::unique_ptr<World> world_;
    std::vector<BodyId> dyn_, all_;
    SimdKernel simd_;
};

/// Steps every contender `steps` times, in alternating chunks of kChunk steps, timing each step with
/// `clock`; fills each contender's run (median time, drift, stood, collapsed, finite).
void race(std::vector<std::unique_ptr<RigidContender>>& contenders, int steps, BenchClock clock, const std::string& label) {
    tool::Progress progress(label, steps);
    constexpr int kChunk = 20;  // long enough to keep each engine's caches warm, short next to the drift
    const std::size_t n = contenders.size();
    std::vector<DriftMeter> meters(n);
    std::vector<std::vector<double>> ms(n);
    for (std::size_t c = 0; c < n; ++c) {
        meters[c].start(contenders[c]->positions());
        ms[c].reserve(std::size_t(steps));
    }
    for (int begin = 0; begin < steps; begin += kChunk) {
        const int end = std::min(steps, begin + kChunk);
        for (std::size_t c = 0; c < n; ++c) {
            RigidContender& k = *contenders[c];
            for (int i = begin; i < end && k.run.finite; ++i) {
                const double t0 = bench_clock_ms(clock);
                k.step();
                ms[c].push_back(bench_clock_ms(clock) - t0);
                const std::vector<Vec3> p = k.positions();
                if (!k.healthy()) k.run.finite = false;
                for (const Vec3& x : p)
                    if (!is_finite(x)) k.run.finite = false;
                if (!k.run.finite) break;
                meters[c].sample(p);
                ++k.run.steps;
            }
        }
        progress.update(end);
    }
    progress.finish();
    for (std::size_t c = 0; c < n; ++c) finish_run(contenders[c]->run, ms[c], meters[c]);
}

std::string markdown_table(const std::vector<RigidRun>& runs, BenchClock clock) {
    std::ostringstream md;
    md << "Times are medians of per-step " << (clock == BenchClock::ThreadCpu ? "thread CPU time" : "wall time")
       << "; `simd` is the soft step's contact kernel.\n\n";
    md << "| scene | engine | variant | simd | bodies | iterations | ms/step (median) | max drift (m) | stood | collapsed |\n";
    md << "|---|---|---|---|---:|---:|---:|---:|---|---|\n";
    char buf[512];
    for (const RigidRun& r : runs) {
        std::snprintf(buf, sizeof buf, "| %s | %s | %s | %s | %d | %d | %.3f | %.4f | %s | %s |\n", r.scene.c_str(),
                      r.engine.c_str(), r.variant.c_str(), r.simd.c_str(), r.bodies, r.iterations, r.ms_per_step_median,
                      r.max_drift, r.stood ? "yes" : "no", r.collapsed ? "yes" : "no");
        md << buf;
    }
    // Speed ratio against Bullet from the same run, per scene, with the widest kernel and with SSE2.
    md << "\n| scene | Sinew default (soft-step) ms | stood | SSE2 kernel ms | Bullet ms | stood | Bullet / Sinew | "
          "Bullet / Sinew SSE2 |\n|---|---:|---|---:|---:|---|---:|---:|\n";
    auto find = [&](const std::string& scene, const char* engine, const char* variant) -> const RigidRun* {
        for (const RigidRun& r : runs)
            if (r.scene == scene && r.engine == engine && r.variant == variant) return &r;
        return nullptr;
    };
    for (const RigidRun& s : runs) {
        if (s.engine != "sinew-si" || s.variant != "soft-step" || s.ms_per_step_median <= 0) continue;
        const RigidRun* b = find(s.scene, "bullet", "default");
        if (!b) continue;
        const RigidRun* sse = find(s.scene, "sinew-si", "soft-step-sse2");
        char sse_ms[32] = "-", sse_ratio[32] = "-";
        if (sse && sse->ms_per_step_median > 0) {
            std::snprintf(sse_ms, sizeof sse_ms, "%.3f", sse->ms_per_step_median);
            std::snprintf(sse_ratio, sizeof sse_ratio, "%.2f", b->ms_per_step_median / sse->ms_per_step_median);
        }
        std::snprintf(buf, sizeof buf, "| %s | %.3f | %s | %s | %.3f | %s | %.2f | %s |\n", s.scene.c_str(),
                      s.ms_per_step_median, s.stood ? "yes" : "no", sse_ms, b->ms_per_step_median,
                      b->stood ? "yes" : "no", b->ms_per_step_median / s.ms_per_step_median, sse_ratio);
        md << buf;
    }
    return md.str();
}

bool write_chart(const std::vector<RigidRun>& runs, const std::string& png) {
    // One series per engine/variant; x = median ms per step, y = max drift (both log scale).
    std::string dat = png + ".dat";
    std::ofstream out(dat);
    std::vector<std::string> series;
    for (const RigidRun& r : runs) {
        std::string key = r.engine + " " + r.variant;
        if (std::find(series.begin(), series.end(), key) == series.end()) series.push_back(key);
    }
    for (const std::string& key : series) {
        out << "# " << key << "\n";
        for (const RigidRun& r : runs)
            if (r.engine + " " + r.variant == key)
                out << std::max(r.ms_per_step_median, 1e-4) << " " << std::max(r.max_drift, 1e-5) << " " << r.scene << "\n";
        out << "\n\n";
    }
    out.close();
    std::string gp = png + ".gp";
    std::ofstream g(gp);
    g << "set terminal pngcairo size 1000,650\nset output '" << png << "'\n"
      << "set logscale xy\nset xlabel 'median ms per step (lower is faster)'\n"
      << "set ylabel 'max drift over the run, m (lower is more accurate)'\n"
      << "set title 'Rigid stacking: time against drift, one point per scene'\nset key outside right\n"
      << "set grid\nset arrow from graph 0, first 0.05 to graph 1, first 0.05 nohead dt 2 lc rgb 'red'\n"
      << "plot ";
    for (std::size_t i = 0; i < series.size(); ++i)
        g << (i ? ", " : "") << "'" << dat << "' index " << i << " using 1:2 with points pt " << (5 + int(i))
          << " ps 1.6 title '" << series[i] << "', '' index " << i
          << " using 1:2:3 with labels offset 0,0.8 font ',7' notitle";
    g << "\n";
    g.close();
    int rc = std::system(("gnuplot '" + gp + "'").c_str());
    std::remove(dat.c_str());
    std::remove(gp.c_str());
    return rc == 0;
}

}  // namespace

std::vector<std::string> split_list(const std::string& s) {
    std::vector<std::string> out;
    std::stringstream ss(s);
    std::string item;
    while (std::getline(ss, item, ','))
        if (!item.empty()) out.push_back(item);
    return out;
}

int cmd_bench(const std::vector<std::string>& args) {
    using tool::UsageError;
    if (!args.empty() && args[0] == "cloth") return cmd_bench_cloth(args);  // tools/bench/bench_cloth.cpp
    if (!args.empty() && args[0] == "fem") return cmd_bench_fem(args);  // tools/bench/bench_fem.cpp
    if (!args.empty() && args[0] == "coupling") return cmd_bench_coupling(args);  // tools/bench/bench_coupling.cpp
    if (!args.empty() && args[0] == "threads") return cmd_bench_threads(args);  // tools/bench/bench_threads.cpp
    if (!args.empty() && args[0] == "scale") return cmd_bench_scale(args);  // tools/bench/bench_scale.cpp
    if (!args.empty() && args[0] == "robustness") return cmd_bench_robustness(args);  // tools/bench/bench_robustness.cpp
    if (args.empty() || args[0] != "rigid")
        throw UsageError("which suite? 'rigid', 'cloth', 'fem', 'coupling', 'threads', 'scale' or 'robustness'");
    std::vector<std::string> scenes(std::begin(kDefaultScenes), std::end(kDefaultScenes));
    int steps = -1, iterations = 10, workers = 1;
    bool clock_given = false;
    std::string chart, markdown, scene_dir = "demos/scenes";
    std::vector<std::string> only;  // engine or engine/variant names; empty = all
    BenchClock clock = BenchClock::ThreadCpu;
    for (std::size_t i = 1; i < args.size(); ++i) {
        const std::string& a = args[i];
        if (tool::is_option(a, "--scenes")) scenes = split_list(tool::option_value(args, i, "--scenes"));
        else if (tool::is_option(a, "--clock")) {
            const std::string c = tool::option_value(args, i, "--clock");
            clock_given = true;
            if (c == "cpu") clock = BenchClock::ThreadCpu;
            else if (c == "wall") clock = BenchClock::Wall;
            else throw UsageError("--clock must be 'cpu' or 'wall', got '" + c + "'");
        }
        else if (tool::is_option(a, "--steps"))
            steps = int(tool::parse_int("--steps", tool::option_value(args, i, "--steps"), 1, 10000000));
        else if (tool::is_option(a, "--workers"))
            workers = int(tool::parse_int("--workers", tool::option_value(args, i, "--workers"), 1, kMaxWorkers));
        else if (tool::is_option(a, "--iterations"))
            iterations = int(tool::parse_int("--iterations", tool::option_value(args, i, "--iterations"), 1, 1000));
        else if (tool::is_option(a, "--chart")) chart = tool::option_value(args, i, "--chart");
        else if (tool::is_option(a, "--markdown")) markdown = tool::option_value(args, i, "--markdown");
        else if (tool::is_option(a, "--scene-dir")) scene_dir = tool::option_value(args, i, "--scene-dir");
        else if (tool::is_option(a, "--engines")) only = split_list(tool::option_value(args, i, "--engines"));
        else throw UsageError("unknown option '" + a + "'");
    }
    if (scenes.empty()) throw UsageError("--scenes is empty");
    // The helpers' work is on other threads: the calling thread's CPU time would leave it out.
    if (workers > 1 && clock == BenchClock::ThreadCpu) {
        if (clock_given) throw UsageError("--workers above 1 needs --clock wall (the helpers run on other threads)");
        clock = BenchClock::Wall;
    }
    std::vector<RigidRun> runs;
    for (const std::string& name : scenes) {
        const SceneDesc scene = parse_scene_file(scene_dir + "/" + name + ".json");  // SceneError: exit 1
        int n = steps > 0 ? steps : scene.steps;
        auto wanted = [&](const std::string& engine, const std::string& variant) {
            if (only.empty()) return true;
            for (const std::string& o : only)
                if (o == engine || o == engine + "/" + variant) return true;
            return false;
        };
        std::vector<std::unique_ptr<RigidContender>> contenders;
        for (const SinewVariant& v : kVariants)
            if (wanted(v.engine, v.variant) && simd_kernel_available(v.simd))
                contenders.push_back(std::make_unique<SinewContender>(scene, v, iterations, workers));
        if (wanted("bullet", "default") && bullet_peer_available()) contenders.push_back(make_bullet_contender(scene, iterations));
        std::cerr << "bench: " << name << ": " << contenders.size() << " engine settings, " << n
                  << " steps each, stepped in alternating chunks...\n";
        race(contenders, n, clock, "bench " + name);
        for (const auto& c : contenders) {
            runs.push_back(c->run);
            std::cout << to_json_line(runs.back()) << std::endl;
        }
    }
    if (!chart.empty() && !write_chart(runs, chart)) std::cerr << "sinew bench: gnuplot failed; no chart\n";
    if (!markdown.empty()) {
        std::string body = markdown_table(runs, clock);
        if (!chart.empty()) body += "\n![time against drift](" + relative_to(chart, markdown) + ")\n";
        if (!replace_section(markdown, "bench-rigid", body)) {
            std::cerr << "sinew bench: could not write " << markdown << "\n";
            return 1;
        }
    }
    return 0;
}

void DriftMeter::sample(const std::vector<Vec3>& p) {
    for (std::size_t i = 0; i < p.size() && i < start_.size(); ++i) {
        max_drift_ = std::max(max_drift_, double((p[i] - start_[i]).norm()));
        max_drop_ = std::max(max_drop_, double(start_[i].y() - p[i].y()));
    }
}

void finish_run(RigidRun& run, const std::vector<double>& ms, const DriftMeter& meter) {
    run.ms_per_step_median = median(ms);
    run.max_drift = meter.max_drift();
    run.max_drop = meter.max_drop();
    run.stood = run.finite && run.max_drift < 0.05;      // issue 3: stood = drift under 5 cm
    run.collapsed = !run.finite || run.max_drop > 0.5;   // issue 3: a box dropped more than 0.5 m
}

double median(std::vector<double> v) {
    if (v.empty()) return 0;
    const std::size_t mid = v.size() / 2;
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid), v.end());
    const double hi = v[mid];
    if (v.size() % 2) return hi;
    // An even count: the mean of the two middle values (the largest of those below the upper one).
    const double lo = *std::max_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid));
    return 0.5 * (lo + hi);
}

std::string to_json_line(const RigidRun& r) {
    char buf[640];
    std::snprintf(buf, sizeof buf,
                  "{\"scene\":\"%s\",\"engine\":\"%s\",\"variant\":\"%s\",\"bodies\":%d,\"iterations\":%d,"
                  "\"steps\":%d,\"ms_per_step_median\":%.4f,\"max_drift\":%.5f,\"stood\":%s,\"collapsed\":%s,"
                  "\"finite\":%s,\"simd\":\"%s\"}",
                  r.scene.c_str(), r.engine.c_str(), r.variant.c_str(), r.bodies, r.iterations, r.steps,
                  r.ms_per_step_median, r.max_drift, r.stood ? "true" : "false", r.collapsed ? "true" : "false",
                  r.finite ? "true" : "false", r.simd.c_str());
    return buf;
}

}  // namespace sinew::bench

namespace sinew::tool {
const Command bench_command = {
    "bench", bench::cmd_bench, "benchmark Sinew's solvers against Bullet in the same run",
    "usage: sinew bench rigid [--scenes a,b,...] [--engines e,e/variant,...] [--steps N] [--iterations N]\n"
    "                         [--workers N] [--chart FILE.png] [--markdown FILE.md] [--clock cpu|wall]\n"
    "                         [--scene-dir DIR]\n"
    "\n"
    "Runs each scene (default: pyramid-10/20/40, tower-10/20, many-pyramids from demos/scenes) under\n"
    "every Sinew solver setting and under Bullet 3.24, in this process. Progress goes to stderr; one JSON\n"
    "line per (scene, engine, variant) to stdout: scene, engine, variant, bodies, iterations, steps,\n"
    "ms_per_step_median, max_drift (m, largest distance any box moved from its start during the run),\n"
    "stood (max_drift < 0.05 m), collapsed (a box dropped > 0.5 m), finite, simd (the soft step's\n"
    "contact kernel: avx, sse2 or portable; variant soft-step-sse2 forces SSE2; none for other solvers).\n"
    "--chart draws time against drift (gnuplot); --markdown rewrites the bench-rigid section of a results\n"
    "file such as docs/RESULTS.md. --clock: per-step time as thread CPU time (default) or wall time.\n"
    "--workers N: Sinew's worlds step on N threads (the calling one included; Bullet stays on one), timed\n"
    "by wall clock.\n"
    "\n"
    "usage: sinew bench cloth [--scenes a,b,...] [--engines e,e/variant,...] [--steps N]\n"
    "                         [--chart FILE.png] [--markdown FILE.md] [--clock cpu|wall] [--scene-dir DIR]\n"
    "\n"
    "Runs the soft-body scenes (default: cloth-32, cloth-64, cloth-drop, pressure-ball from demos/scenes)\n"
    "with every Sinew soft method and setting (engines sinew-verlet, sinew-semi-implicit, sinew-implicit,\n"
    "sinew-fast-ms) and with Bullet's btSoftBody (engine bullet, variant pi10), in this process. One JSON\n"
    "line per (scene, engine, variant): scene, engine, variant, nodes, links, iterations, stiffness, lra,\n"
    "steps, ms_per_step_median, max_stretch (largest current/rest length over the links at the last\n"
    "step), peak_stretch (the same over the whole run), volume_ratio (closed bodies: volume / rest\n"
    "volume), max_penetration (m, into the sphere or ground at the last step), finite.\n"
    "--chart draws stretch against time per scene (gnuplot); --markdown rewrites the bench-cloth section.\n"
    "--clock: per-step time as thread CPU time (default, robust on a busy machine) or wall time.\n"
    "\n"
    "usage: sinew bench fem [--scenes a,b,...] [--engines e,e/variant,...] [--steps N]\n"
    "                       [--chart FILE.png] [--markdown FILE.md] [--clock cpu|wall] [--scene-dir DIR]\n"
    "\n"
    "Runs the FEM scenes (default: beam-cantilever, beam-large, ball-drop, fem-block-1k/5k/20k/50k)\n"
    "with Sinew's implicit Euler FEM (engine sinew-implicit; variants: rotation polar, qr or linear, and\n"
    "for beams the mesh refined 2x and 4x along each axis, r4 being the converged reference) and with\n"
    "Bullet's btDeformableBody (engine bullet, variant corotated r1, and r2 for beams), in this process.\n"
    "One JSON line per run: scene, engine, variant, tets, nodes, steps, ms_per_step_median,\n"
    "tip_deflection (beams: m, mean over the last second), accuracy (beams: tip / reference; blocks:\n"
    "final volume ratio), min_volume_ratio (over the run), inverted (tets at the end), finite.\n"
    "--chart draws beam error against time and block time against tets; --markdown rewrites bench-fem.\n"
    "\n"
    "usage: sinew bench coupling [--scenes a,b,...] [--steps N] [--markdown FILE] [--figure-4]\n"
    "\n"
    "Runs the coupling scenes (default: ball-on-trampoline, box-on-soft-block) under one-way, two-way,\n"
    "hybrid and interleaved coupling; one JSON line per run: ms_per_step_median (thread CPU), ratio_to_one_way,\n"
    "rest_height (m, the scene's first dynamic rigid body at the end), carried (the soft impulses on it\n"
    "over the last second / its weight times a second), finite. --markdown rewrites bench-coupling.\n"
    "--figure-4 runs the scene figure-4 instead (seed 001's Figure 4: one-way and hybrid with 5 soft\n"
    "sub-steps at 60 Hz against two-way at 300 Hz and at 60 Hz, 2 simulated seconds or --steps at 60 Hz),\n"
    "adding ms_per_second, and --markdown rewrites bench-coupling-figure-4.\n"
    "\n"
    "usage: sinew bench threads [--scenes a,b,...] [--workers 1,2,...] [--steps N] [--warmup N]\n"
    "                           [--markdown FILE]\n"
    "\n"
    "Steps each scene (default: pyramid-40, many-pyramids, cloth-64, fem-block-20k, many-soft-bodies,\n"
    "many-chains; 300 steps after 60 untimed ones) in one world per worker count (default 1,2), sleeping\n"
    "off, in alternating chunks; one JSON line per run:\n"
    "scene, workers,\n"
    "bodies, particles, steps, ms_per_step_median (wall), speedup (over the first worker count),\n"
    "ms_per_step_best_chunk and speedup_best_chunk (the fastest chunk of 20 steps: the step's cost when no\n"
    "other load interferes), identical (end state bit-identical to the first's), finite. --markdown\n"
    "rewrites bench-threads.\n"
    "\n"
    "usage: sinew bench scale [--grids 4,10,20,30] [--steps N] [--warmup N] [--sleeping] [--markdown FILE]\n"
    "\n"
    "Cost per body as the world grows: G x G grids of 10-row pyramids (55 boxes each; default 880 to 49,500\n"
    "boxes) on one ground, sleeping off, stepped --warmup steps (60) and then timed for --steps (60), all\n"
    "sizes in alternating chunks; --sleeping adds as many single boxes resting on the ground with sleeping\n"
    "on, timed once they sleep (at least 240 steps). One JSON\n"
    "line per grid: bodies, ms_per_step_median (wall), us_per_body, ratio_to_5k (over the grid nearest\n"
    "5,000 bodies), us_detect/us_solve/us_positions (the rigid stages per body), bytes_per_body (heap the\n"
    "settled world took), awake, finite. --markdown rewrites bench-scale.\n"
    "\n"
    "usage: sinew bench robustness [--scenes a,b,...] [--engines e,e/variant,...] [--iterations N]\n"
    "                              [--markdown FILE] [--scene-dir DIR]\n"
    "\n"
    "Runs the hard scenes (default: hard-heavy-on-pyramid, hard-heavy-on-light, hard-chain, hard-fast,\n"
    "hard-overlap, hard-arch, hard-ramp-stack, hard-spin; written by scripts/hard_scenes.py) under each\n"
    "Sinew solver (engine sinew; variants soft-step, split-impulse, baumgarte, newton) and Bullet (where\n"
    "it can build the scene: rigid bodies and ball joints); and the soft ones (hard-soft-drape,\n"
    "hard-soft-pressure, hard-soft-collide, hard-soft-fold, hard-soft-tunnel) under each soft method\n"
    "(variants verlet-it10, semi-implicit, implicit-cg100, fast-ms-it3; semi-implicit's links capped at\n"
    "its stability limit) and Bullet's btSoftBody (variant btSoftBody, on drape and pressure). Each\n"
    "scene has one physical figure checked against a limit from its analytic answer (the scene's\n"
    "description). One JSON line per run: scene, engine, variant, steps, ms_per_step_median (thread\n"
    "CPU), figure, value, limit, pass, finite, note. --markdown rewrites the bench-robustness and\n"
    "bench-robustness-soft sections: pass/fail matrices.\n"};
}  // namespace sinew::tool
