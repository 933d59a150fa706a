// `sinew bench fem [--scenes a,b] [--engines e,e/variant] [--steps N] [--chart FILE.png] [--markdown FILE.md]`
//
// Issue 13's FEM scenes, each run with Sinew's element settings (rotation method, mesh refinement) and
// with Bullet's btDeformableBody in the same process; one JSON line per run on stdout, progress on stderr.
// Beams: accuracy = the settled tip deflection over a converged reference of our own, the finest Sinew
// run of the same invocation (corotational quadratic tets, the scene's cells x 2 along each axis); the cantilever's
// reference is also checked against Euler-Bernoulli in the table. Blocks: accuracy = the final volume
// ratio. --markdown rewrites the section between <!-- bench-fem:begin --> and <!-- bench-fem:end -->;
// --chart draws accuracy error against time and time against tets with gnuplot.
#include "tools/bench/peers.hpp"
#include "tools/bench/bench_fem.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>

#include "engine/core/pipeline.hpp"
#include "engine/core/shape.hpp"
#include "engine/world/scene.hpp"
#include "soft/fem_elements.hpp"
#include "soft/soft_builders.hpp"
#include "soft/soft_system.hpp"
#include "soft/solver_caches.hpp"
#include "tools/bench/bench_rigid.hpp"  // median(), split_list()
#include "tools/bench/results_file.hpp"
#include "tools/commands.hpp"

namespace sinew::bench {

namespace {

const char* const kDefaultScenes[] = {"beam-cantilever", "beam-large", "ball-drop", "fem-block-1k", "fem-block-5k",
                                      "fem-block-20k", "fem-block-50k"};
// The beams' reference: quadratic tets on the scene's cells x 2 (3,840 tets, 6,561 nodes for the
// cantilever). Converged: the static cantilever on cells x 2 and x 4 differ by 0.1% (docs/fem.md).
constexpr int kReferenceRefinement = 2;
const char* const kReferenceVariant = "polar q2 r2 rest-factor";

}  // namespace

FemScene fem_scene(const std::string& name, const std::string& scene_dir, int refinement, int order) {
    const SceneDesc scene = parse_scene_file(scene_dir + "/" + name + ".json");
    auto fail = [&](const std::string& what) { throw SceneError(scene.file, "", "not an FEM benchmark scene: " + what); };
    if (scene.soft_bodies.size() != 1 || (scene.soft_bodies[0].builder != "tet-box" && scene.soft_bodies[0].builder != "tet-mesh"))
        fail("it must hold exactly one soft body, built by tet-box or tet-mesh");
    const SceneSoftBody& body = scene.soft_bodies[0];
    FemScene s;
    s.name = scene.name;
    s.h = scene.settings.time_step;
    s.steps = scene.steps;
    s.gravity = scene.settings.rigid.gravity;
    s.material = body.def.fem;
    s.friction = body.def.friction;
    s.thickness = body.def.thickness;
    s.refinement = refinement;
    s.cg_cap = body.def.iterations;
    s.cg_tolerance = body.def.cg_tolerance;
    const SceneSoftBody::TetBox& box = body.tet_box;
    if (body.builder == "tet-box") {
        s.mesh = make_tet_box(box.min_corner, box.size, box.cells[0] * refinement, box.cells[1] * refinement,
                              box.cells[2] * refinement, box.split == 6 ? HexSplit::Six : HexSplit::Five);
        if (body.def.tet_order == 2) s.mesh = make_quadratic(s.mesh);  // a scene of quadratic tets
    } else {
        if (refinement != 1) fail("a tet-mesh body cannot be refined");
        if (!body.def.pinned.empty()) fail("a tet-mesh body may not be pinned");
        s.mesh.nodes = body.def.positions;
        s.mesh.tets = body.def.tets;
        s.mesh.order = body.def.tet_order;
    }
    if (order == 2 && s.mesh.order == 1) s.mesh = make_quadratic(s.mesh);
    s.masses = lumped_masses(s.mesh.nodes, s.mesh.tets, s.material.density, s.mesh.order);
    // A beam is clamped at its x = min face (the scene pins exactly those nodes); a block or ball is free.
    const Real x0 = box.min_corner.x() + Real(1e-6) * box.size.x();
    for (const std::uint32_t i : body.def.pinned)
        if (body.def.positions[i].x() > x0) fail("it may pin only the nodes of the box's x = min face");
    s.kind = body.def.pinned.empty() ? FemSceneKind::Drop : FemSceneKind::Beam;
    if (s.kind == FemSceneKind::Beam)
        for (std::uint32_t i = 0; i < s.mesh.nodes.size(); ++i)
            if (s.mesh.nodes[i].x() <= x0) s.pinned.push_back(i);
    for (const SceneBody& b : scene.bodies) {
        if (b.def.type != BodyType::Static || b.def.shape.type != ShapeType::Box || !b.def.pose.q.isApprox(Quat::Identity()))
            fail("its only rigid body may be an axis-aligned static ground box, \"" + b.name + "\" is not");
        if (s.has_ground) fail("at most one ground");
        s.has_ground = true;
        s.ground_y = b.def.pose.p.y() + b.def.shape.half_extents.y();
    }
    return s;
}

double beam_tip(const FemScene& s, const std::vector<Vec3>& x) {
    Real far = -kRealMax;
    for (const Vec3& p : s.mesh.nodes) far = std::max(far, p.x());
    double sum = 0;
    int count = 0;
    for (std::size_t i = 0; i < x.size(); ++i)
        if (s.mesh.nodes[i].x() >= far - Real(1e-6)) sum += double(s.mesh.nodes[i].y() - x[i].y()), ++count;
    return count ? sum / count : 0;
}

FemTracker::FemTracker(const FemScene& scene) : s(scene), rest_volume(mesh_volume(scene.mesh, scene.mesh.nodes, nullptr)) {}

void FemTracker::sample(const std::vector<Vec3>& x, int step, int steps) {
    min_ratio = std::min(min_ratio, mesh_volume(s.mesh, x, nullptr) / rest_volume);
    const int window = int(std::lround(1.0 / double(s.h)));  // the last second: a few periods of the beam
    if (s.kind == FemSceneKind::Beam && step >= steps - window) {
        tip_sum += beam_tip(s, x);
        ++tip_count;
    }
}

void FemTracker::finish(FemRun& run, const std::vector<Vec3>& x) const {
    run.min_volume_ratio = min_ratio;
    const double v = mesh_volume(s.mesh, x, &run.inverted);
    if (s.kind == FemSceneKind::Beam) {
        if (tip_count) run.tip_deflection = tip_sum / tip_count;
    } else {
        run.accuracy = v / rest_volume;
    }
}

double mesh_volume(const TetMesh& mesh, const std::vector<Vec3>& x, int* inverted) {
    double v = 0;
    int bad = 0;
    for (std::size_t e = 0; e < mesh.tet_count(); ++e) {
        const std::uint32_t* t = &mesh.tets[std::size_t(tet_nodes(mesh.order)) * e];
        const double ve = double(tet_volume(x[t[0]], x[t[1]], x[t[2]], x[t[3]]));
        v += ve;
        bad += ve <= 0;
    }
    if (inverted) *inverted = bad;
    return v;
}

namespace {

struct SinewSetting {
    std::string variant;
    int refinement = 1;
    FemRotation rotation = FemRotation::Polar;
    int min_cg_cap = 0;  ///< the scene's CG cap, raised to this (the reference must converge)
    int order = 1;       ///< 2: quadratic tets
    SoftPreconditioner preconditioner = SoftPreconditioner::BlockJacobi;
    int pd_iterations = 0;  ///< > 0: projective dynamics (method fast-ms) with this many iterations a step
};

const char* engine_of(const SinewSetting& v) { return v.pd_iterations > 0 ? "sinew-pd" : "sinew-implicit"; }

std::vector<SinewSetting> sinew_settings(FemSceneKind kind) {
    std::vector<SinewSetting> out;
    for (const FemRotation r : {FemRotation::Polar, FemRotation::QR, FemRotation::Linear})
        out.push_back({std::string(fem_rotation_name(r)) + " r1", 1, r});
    if (kind == FemSceneKind::Beam) {
        out.push_back({"polar r2", 2, FemRotation::Polar});
        out.push_back({"polar q2 r1", 1, FemRotation::Polar, 0, 2});
        out.push_back({"polar q2 r1 rest-factor", 1, FemRotation::Polar, 0, 2, SoftPreconditioner::RestFactor});
        out.push_back({"polar r2 rest-factor", 2, FemRotation::Polar, 0, 1, SoftPreconditioner::RestFactor});
        // Its cap at least 1000.
        out.push_back({kReferenceVariant, kReferenceRefinement, FemRotation::Polar, 1000, 2, SoftPreconditioner::RestFactor});
    } else {
        out.push_back({"polar q2 r1", 1, FemRotation::Polar, 0, 2});
    }
    // Projective dynamics (Bouaziz 2014) on the same linear tets: the fast solver of the same energy.
    for (const int iterations : {10, 30})
        out.push_back({"pd " + std::to_string(iterations) + " r1", 1, FemRotation::Polar, 0, 1, SoftPreconditioner::BlockJacobi, iterations});
    return out;
}

FemRun run_sinew(const FemScene& s, const SinewSetting& v, int steps, BenchClock clock) {
    SoftSettings settings;
    settings.gravity = s.gravity;
    settings.sleeping = false;
    SoftSystem soft(settings);
    const Shape ground = make_plane(Vec3::UnitY(), s.ground_y);
    if (s.has_ground) {
        Collider c;
        c.shape = &ground;
        c.xf = Transform::identity();
        c.box = ground.bounds(c.xf);
        c.friction = s.friction;
        soft.colliders().push_back(c);
    }
    SoftBodyDef d;
    d.method = v.pd_iterations > 0 ? SoftMethod::FastMassSpring : SoftMethod::ImplicitEuler;
    d.fem = s.material;
    d.fem.rotation = v.rotation;
    d.iterations = v.pd_iterations > 0 ? v.pd_iterations : std::max(s.cg_cap, v.min_cg_cap);
    if (v.pd_iterations > 0) {
        // Projective dynamics has no Rayleigh damping: the scene's β (a fraction of the stiffness) is left out.
        d.fem.stiffness_damping = 0;
        d.fem.mass_damping = 0;
    }
    d.cg_tolerance = s.cg_tolerance;
    d.friction = s.friction;
    d.thickness = s.thickness;
    d.allow_sleep = false;
    d.positions = s.mesh.nodes;
    d.masses = s.masses;
    d.tets = s.mesh.tets;
    d.tet_order = s.mesh.order;
    d.preconditioner = v.preconditioner;
    d.pinned = s.pinned;
    const SoftBodyId id = soft.create_body(std::move(d));
    Pipeline pipeline;
    pipeline.add_system(&soft);

    FemRun run;
    run.scene = s.name;
    run.engine = engine_of(v);
    run.variant = v.variant;
    run.cg_iterations = 0;
    run.tets = int(s.mesh.tet_count());
    run.nodes = int(s.mesh.nodes.size());
    FemTracker track(s);
    std::vector<double> ms;
    ms.reserve(steps);
    for (int i = 0; i < steps; ++i) {
        const double t0 = bench_clock_ms(clock);
        pipeline.step(s.h);
        ms.push_back(bench_clock_ms(clock) - t0);
        ++run.steps;
        if (!soft.faults().empty() || !soft.all_finite()) {  // a blow-up the step contained, or not
            run.finite = false;
            break;
        }
        track.sample(soft.body(id).p.x, i, steps);
        if (soft.body(id).implicit_cache) run.cg_iterations += soft.body(id).implicit_cache->cg_iterations;
    }
    if (run.steps) run.cg_iterations /= run.steps;
    run.ms_per_step_median = median(ms);
    if (run.finite) track.finish(run, soft.body(id).p.x);
    return run;
}

std::string fmt(const char* f, double x) {
    if (!std::isfinite(x)) return "-";
    char buf[64];
    std::snprintf(buf, sizeof buf, f, x);
    return buf;
}

std::string to_json_line(const FemRun& r) {
    auto num = [](double x, const char* f) { return std::isfinite(x) ? fmt(f, x) : std::string("null"); };
    std::ostringstream o;
    o << "{\"scene\":\"" << r.scene << "\",\"engine\":\"" << r.engine << "\",\"variant\":\"" << r.variant
      << "\",\"tets\":" << r.tets << ",\"nodes\":" << r.nodes << ",\"steps\":" << r.steps
      << ",\"ms_per_step_median\":" << num(r.ms_per_step_median, "%.4f") << ",\"tip_deflection\":" << num(r.tip_deflection, "%.6g")
      << ",\"accuracy\":" << num(r.accuracy, "%.5f") << ",\"min_volume_ratio\":" << num(r.min_volume_ratio, "%.5f")
      << ",\"cg_iterations\":" << num(r.cg_iterations, "%.1f") << ",\"inverted\":" << r.inverted << ",\"finite\":" << (r.finite ? "true" : "false") << "}";
    return o.str();
}

// Euler-Bernoulli's static tip deflection q L⁴ / (8 E I) of a clamped beam along x, q = ρ g A.
double euler_bernoulli(const FemScene& s) {
    Vec3 lo = s.mesh.nodes[0], hi = s.mesh.nodes[0];
    for (const Vec3& p : s.mesh.nodes) {
        lo = lo.cwiseMin(p);
        hi = hi.cwiseMax(p);
    }
    const Vec3 size = hi - lo;
    const double b = size.z(), t = size.y(), L = size.x();
    const double q = double(s.material.density) * double(-s.gravity.y()) * b * t, I = b * t * t * t / 12;
    return q * L * L * L * L / (8 * double(s.material.young) * I);
}

std::string markdown_table(const std::vector<FemRun>& runs, const std::vector<std::pair<std::string, double>>& eb, BenchClock clock) {
    std::ostringstream md;
    md << "Times are medians of per-step " << (clock == BenchClock::ThreadCpu ? "thread CPU time" : "wall time")
       << ", h from each scene (1/60 s), the CG cap and tolerance from each scene's solver settings. Beams: accuracy = tip deflection (mean over the last second) / the reference (Sinew, polar, quadratic tets, cells x "
       << kReferenceRefinement << "). Blocks: accuracy = final volume / rest volume.\n\n";
    md << "| scene | engine | variant | tets | nodes | ms/step (median) | tip deflection (m) | accuracy | min volume ratio | "
          "inverted at end | finite |\n|---|---|---|---:|---:|---:|---:|---:|---:|---:|---|\n";
    for (const FemRun& r : runs)
        md << "| " << r.scene << " | " << r.engine << " | " << r.variant << " | " << r.tets << " | " << r.nodes << " | "
           << fmt("%.3f", r.ms_per_step_median) << " | " << fmt("%.5f", r.tip_deflection) << " | " << fmt("%.3f", r.accuracy)
           << " | " << fmt("%.3f", r.min_volume_ratio) << " | " << r.inverted << " | " << (r.finite ? "yes" : "no") << " |\n";
    if (!eb.empty()) {
        md << "\n| beam | reference tip (m) | Euler-Bernoulli qL^4/(8EI) (m) | reference / Euler-Bernoulli |\n|---|---:|---:|---:|\n";
        for (const auto& e : eb) {
            double ref = std::nan("");
            for (const FemRun& r : runs)
                if (r.scene == e.first && r.engine == "sinew-implicit" && r.variant == kReferenceVariant) ref = r.tip_deflection;
            md << "| " << e.first << " | " << fmt("%.5f", ref) << " | " << fmt("%.5f", e.second) << " | " << fmt("%.3f", ref / e.second)
               << " |\n";
        }
    }
    // Issue 13's target on the cantilever: a Sinew setting within 5% of the reference in at most half of
    // Bullet's time for its most accurate stable setting.
    for (const FemRun& b : runs) {
        if (b.engine != "bullet" || b.scene != "beam-cantilever") continue;
        // Stable: finite with every tet positive at the end (Bullet's refined beam stays finite but folds).
        const FemRun* best_bullet = nullptr;
        for (const FemRun& o : runs)
            if (o.engine == "bullet" && o.scene == b.scene && o.finite && o.inverted == 0 && std::isfinite(o.accuracy) &&
                (!best_bullet || std::abs(o.accuracy - 1) < std::abs(best_bullet->accuracy - 1)))
                best_bullet = &o;
        if (!best_bullet) {
            md << "\nCantilever target: no Bullet run is stable.\n";
            break;
        }
        const FemRun* best = nullptr;
        for (const FemRun& r : runs)
            if (r.scene == b.scene && r.engine != "bullet" && r.finite && std::abs(r.accuracy - 1) <= 0.05 && r.variant != kReferenceVariant &&
                (!best || r.ms_per_step_median < best->ms_per_step_median))
                best = &r;
        md << "\nCantilever target: Bullet's most accurate stable run (" << best_bullet->variant << ") reaches "
           << fmt("%.3f", best_bullet->accuracy) << " in " << fmt("%.3f", best_bullet->ms_per_step_median) << " ms; ";
        if (best)
            md << "the fastest Sinew run within 5% of the reference (" << best->variant << ", " << fmt("%.3f", best->accuracy)
               << ") takes " << fmt("%.3f", best->ms_per_step_median) << " ms: "
               << (best->ms_per_step_median <= 0.5 * best_bullet->ms_per_step_median ? "met" : "not met") << ".\n";
        else
            md << "no Sinew run other than the reference is within 5%: not met.\n";
        break;
    }
    return md.str();
}

bool write_chart(const std::vector<FemRun>& runs, const std::string& png) {
    // Left: beams, |accuracy - 1| against ms per step; right: blocks, ms per step against tets (log-log).
    const std::string dat = png + ".dat", gp = png + ".gp";
    std::ofstream out(dat);
    const std::vector<std::string> engines = {"sinew-implicit", "bullet", "sinew-pd"};
    for (const std::string& e : engines) {  // index 0, 1, 2: beams
        out << "# beams " << e << "\n";
        bool any = false;
        for (const FemRun& r : runs)
            if (r.engine == e && std::isfinite(r.tip_deflection) && r.finite && std::isfinite(r.accuracy) && r.variant != kReferenceVariant) {
                out << std::max(r.ms_per_step_median, 1e-3) << " " << std::max(std::abs(r.accuracy - 1), 1e-4) << " \"" << r.scene
                    << " " << r.variant << "\"\n";
                any = true;
            }
        if (!any) out << "nan nan -\n";
        out << "\n\n";
    }
    for (const std::string& e : engines) {  // index 3, 4, 5: blocks
        out << "# blocks " << e << "\n";
        bool any = false;
        for (const FemRun& r : runs)
            if (r.engine == e && !std::isfinite(r.tip_deflection) && r.finite &&
                (e == "bullet" || r.variant == "polar r1" || r.variant == "pd 10 r1")) {
                out << r.tets << " " << r.ms_per_step_median << " \"" << r.variant << "\"\n";
                any = true;
            }
        if (!any) out << "nan nan -\n";
        out << "\n\n";
    }
    out.close();
    std::ofstream g(gp);
    g << "set terminal pngcairo size 1400,520\nset output '" << png << "'\nset grid\nset key top left font ',9'\n"
      << "set datafile missing 'nan'\nset multiplot layout 1,2 title 'FEM: accuracy against time, time against size'\n"
      << "set logscale xy\nset title 'beams: error against the converged reference'\nset xlabel 'median ms per step'\n"
      << "set ylabel '|tip / reference - 1|'\nset arrow 1 from graph 0, first 0.05 to graph 1, first 0.05 nohead dt 2 lc rgb 'red'\n"
      << "plot '" << dat << "' index 0 using 1:2 with points pt 7 ps 1.4 lc rgb '#1f77b4' title 'sinew-implicit', '' index 0 using 1:2:3 "
      << "with labels offset 0,0.8 font ',7' notitle, '' index 1 using 1:2 with points pt 5 ps 1.4 lc rgb '#d62728' title 'bullet', "
      << "'' index 1 using 1:2:3 with labels offset 0,-0.8 font ',7' notitle, '' index 2 using 1:2 with points pt 9 ps 1.4 "
      << "lc rgb '#2ca02c' title 'sinew-pd', '' index 2 using 1:2:3 with labels offset 0,0.8 font ',7' notitle\n"
      << "unset arrow 1\nset title 'falling blocks: time against tets'\nset xlabel 'tets'\nset ylabel 'median ms per step'\n"
      << "plot '" << dat << "' index 3 using 1:2 with linespoints pt 7 lc rgb '#1f77b4' title 'sinew-implicit (polar)', '' index 4 "
      << "using 1:2 with linespoints pt 5 lc rgb '#d62728' title 'bullet', '' index 5 using 1:2 with linespoints pt 9 "
      << "lc rgb '#2ca02c' title 'sinew-pd (10 iterations)', 10 with lines dt 2 lc rgb 'gray' title '10 ms'\n"
      << "unset multiplot\n";
    g.close();
    const int rc = std::system(("gnuplot '" + gp + "' 2>/dev/null").c_str());
    std::remove(dat.c_str());
    std::remove(gp.c_str());
    return rc == 0;
}

}  // namespace

int cmd_bench_fem(const std::vector<std::string>& args) {
    using tool::UsageError;
    std::vector<std::string> scenes(std::begin(kDefaultScenes), std::end(kDefaultScenes));
    int steps = -1;
    std::string chart, markdown, scene_dir = "demos/scenes";
    BenchClock clock = BenchClock::ThreadCpu;
    std::vector<std::string> only;
    for (std::size_t i = 1; i < args.size(); ++i) {
        const std::string& a = args[i];
        if (tool::is_option(a, "--scenes")) scenes = split_list(tool::option_value(args, i, "--scenes"));
        else if (tool::is_option(a, "--steps"))
            steps = int(tool::parse_int("--steps", tool::option_value(args, i, "--steps"), 1, 10000000));
        else if (tool::is_option(a, "--chart")) chart = tool::option_value(args, i, "--chart");
        else if (tool::is_option(a, "--markdown")) markdown = tool::option_value(args, i, "--markdown");
        else if (tool::is_option(a, "--engines")) only = split_list(tool::option_value(args, i, "--engines"));
        else if (tool::is_option(a, "--scene-dir")) scene_dir = tool::option_value(args, i, "--scene-dir");
        else if (tool::is_option(a, "--clock")) {
            const std::string c = tool::option_value(args, i, "--clock");
            if (c == "cpu") clock = BenchClock::ThreadCpu;
            else if (c == "wall") clock = BenchClock::Wall;
            else throw UsageError("--clock must be 'cpu' or 'wall', got '" + c + "'");
        } else throw UsageError("unknown option '" + a + "'");
    }
    if (scenes.empty()) throw UsageError("--scenes is empty");
    std::vector<FemScene> descs;
    for (const std::string& name : scenes) descs.push_back(fem_scene(name, scene_dir, 1));  // bad files fail first
    auto wanted = [&](const std::string& engine, const std::string& variant) {
        if (only.empty()) return true;
        for (const std::string& o : only)
            if (o == engine || o == engine + "/" + variant) return true;
        return false;
    };
    std::vector<FemRun> runs;
    std::vector<std::pair<std::string, double>> eb;
    int failed = 0;
    for (std::size_t k = 0; k < descs.size(); ++k) {
        const FemScene& base = descs[k];
        const int n = steps > 0 ? steps : base.steps;
        const std::size_t first = runs.size();
        auto report = [&](const FemRun& r) { std::cout << to_json_line(r) << std::endl; };
        for (const SinewSetting& v : sinew_settings(base.kind)) {
            if (!wanted(engine_of(v), v.variant)) continue;
            std::cerr << "bench: " << base.name << " " << engine_of(v) << " " << v.variant << " (" << n << " steps)...\n";
            try {
                runs.push_back(run_sinew(v.refinement == 1 && v.order == 1 ? base : fem_scene(scenes[k], scene_dir, v.refinement, v.order),
                                        v, n, clock));
            } catch (const std::exception& e) {
                std::cerr << "bench: " << base.name << " " << v.variant << " failed: " << e.what() << "\n";
                ++failed;
            }
        }
        const int bullet_refinements = base.kind == FemSceneKind::Beam ? 2 : 1;
        for (int r = 1; r <= bullet_refinements; ++r) {
            const std::string variant = "corotated r" + std::to_string(r);
            if (!wanted("bullet", variant) || !bullet_peer_available()) continue;
            std::cerr << "bench: " << base.name << " bullet " << variant << " (" << n << " steps)...\n";
            try {
                runs.push_back(run_bullet_fem(r == 1 ? base : fem_scene(scenes[k], scene_dir, r), n, clock));
            } catch (const std::exception& e) {
                std::cerr << "bench: " << base.name << " bullet failed: " << e.what() << "\n";
                ++failed;
            }
        }
        // Beams: accuracy against the reference run of this invocation.
        if (base.kind == FemSceneKind::Beam) {
            double reference = std::nan("");
            for (std::size_t i = first; i < runs.size(); ++i)
                if (runs[i].engine == "sinew-implicit" && runs[i].variant == kReferenceVariant && runs[i].finite) reference = runs[i].tip_deflection;
            for (std::size_t i = first; i < runs.size(); ++i) runs[i].accuracy = runs[i].tip_deflection / reference;
            eb.emplace_back(base.name, euler_bernoulli(base));
        }
        for (std::size_t i = first; i < runs.size(); ++i) report(runs[i]);
    }
    if (!chart.empty() && !write_chart(runs, chart)) std::cerr << "sinew bench: gnuplot failed; no chart\n";
    if (!markdown.empty()) {
        std::string body = markdown_table(runs, eb, clock);
        if (!chart.empty()) body += "\n![FEM accuracy against time, time against tets](" + relative_to(chart, markdown) + ")\n";
        if (!replace_section(markdown, "bench-fem", body)) {
            std::cerr << "sinew bench: could not write " << markdown << "\n";
            return 1;
        }
    }
    return failed ? 1 : 0;
}

}  // namespace sinew::bench
