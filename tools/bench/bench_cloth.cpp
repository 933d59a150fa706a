// `sinew bench cloth [--scenes a,b] [--engines e,e/variant] [--steps N] [--chart FILE.png] [--markdown FILE.md]`
//
// Runs the soft-body scenes of issue 5 with every Sinew soft method, several settings each, and with
// Bullet's btSoftBody, in the same process; one JSON line per (scene, engine, variant) on stdout, progress
// on stderr. --markdown rewrites the cloth section of a results file (between <!-- bench-cloth:begin -->
// and <!-- bench-cloth:end -->); --chart draws stretch against time with gnuplot.
#include "tools/bench/peers.hpp"
#include "tools/bench/bench_cloth.hpp"

#include <algorithm>
#include <ctime>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>

#include "engine/core/pipeline.hpp"
#include "engine/core/shape.hpp"
#include "soft/soft_builders.hpp"
#include "soft/soft_system.hpp"
#include "tools/bench/bench_rigid.hpp"  // median()
#include "tools/bench/results_file.hpp"
#include "tools/commands.hpp"

namespace sinew::bench {

// ---- scenes: one description per scene, read by both engines --------------------------------------

ClothScene cloth_scene_from(const SceneDesc& scene) {
    // The scene file is the one description (demos/scenes/NAME.json); Bullet's and Sinew's bodies are
    // both built from what it says. The bench varies only the method, iterations and stiffness.
    auto fail = [&](const std::string& what) {
        throw SceneError(scene.file, "", "not a cloth benchmark scene: " + what);
    };
    if (scene.soft_bodies.size() != 1) fail("it must hold exactly one soft body");
    const SceneSoftBody& body = scene.soft_bodies[0];
    ClothScene s;
    s.name = scene.name;
    s.h = scene.settings.time_step;
    s.steps = scene.steps;
    s.gravity = scene.settings.rigid.gravity;
    s.friction = body.def.friction;
    s.thickness = body.def.thickness;
    s.pressure = body.def.pressure;
    if (body.builder == "cloth") {
        const ClothGridDesc& c = body.cloth;
        if (c.nx != c.ny) fail("the cloth must be square (nodes [n, n])");
        s.n = c.nx;
        s.total_mass = c.total_mass;
        s.corner00 = c.origin;
        s.corner10 = c.origin + c.edge_u;
        s.corner01 = c.origin + c.edge_v;
        const std::vector<std::uint32_t> corners = {cloth_node(c, 0, 0), cloth_node(c, c.nx - 1, 0)};
        if (!body.cloth_pinned_corners.empty() && body.cloth_pinned_corners != corners)
            fail("a cloth may pin nothing or exactly nodes [0, 0] and [n-1, 0] (as Bullet's CreatePatch fixeds 1+2)");
        s.pin_corners = !body.cloth_pinned_corners.empty();
        s.kind = s.pin_corners ? ClothSceneKind::HangingCloth : ClothSceneKind::ClothDrop;
    } else if (body.builder == "icosphere") {
        s.kind = ClothSceneKind::PressureBall;
        s.ball_centre = body.icosphere_center;
        s.ball_radius = body.icosphere_radius;
        s.ball_subdivisions = body.icosphere_subdivisions;
        Real m = 0;
        for (Real mi : body.def.masses) m += mi;
        s.total_mass = m;
    } else {
        fail("its soft body must be a cloth or an icosphere, got " + body.builder);
    }
    for (const SceneBody& b : scene.bodies) {
        if (b.def.type != BodyType::Static) fail("only static colliders are supported, \"" + b.name + "\" is not");
        const Shape& shape = b.def.shape;
        if (shape.type == ShapeType::Sphere) {
            if (s.has_sphere) fail("at most one sphere");
            s.has_sphere = true;
            s.sphere_centre = b.def.pose.p;
            s.sphere_radius = shape.radius;
        } else if (shape.type == ShapeType::Box && b.def.pose.q.isApprox(Quat::Identity())) {
            if (s.has_ground) fail("at most one ground");
            s.has_ground = true;
            s.ground_y = b.def.pose.p.y() + shape.half_extents.y();  // the top face
        } else {
            fail("colliders must be a sphere and an axis-aligned ground box, got \"" + b.name + "\"");
        }
    }
    return s;
}

ClothScene cloth_scene(const std::string& name, const std::string& scene_dir) {
    return cloth_scene_from(parse_scene_file(scene_dir + "/" + name + ".json"));  // SceneError: exit 1
}

void scene_ball_mesh(const ClothScene& s, std::vector<Vec3>& vertices, std::vector<std::uint32_t>& triangles) {
    SoftBodyDef def = make_icosphere(s.ball_centre, s.ball_radius, s.ball_subdivisions, s.total_mass, LinkMaterial{});
    vertices = std::move(def.positions);
    triangles = std::move(def.triangles);
}

double scene_penetration(const ClothScene& s, const std::vector<Vec3>& x) {
    double deepest = 0;
    for (const Vec3& p : x) {
        if (s.has_sphere) deepest = std::max(deepest, double(s.sphere_radius - (p - s.sphere_centre).norm()));
        if (s.has_ground) deepest = std::max(deepest, double(s.ground_y - p.y()));
    }
    return deepest;
}

namespace {

const char* kDefaultScenes[] = {"cloth-32", "cloth-64", "cloth-drop", "pressure-ball"};

// ---- Sinew settings ----------------------------------------------------------------------------------

struct SinewSetting {
    std::string engine;
    std::string variant;
    SoftMethod method = SoftMethod::Verlet;
    int iterations = 10;
    bool lra = false;
    double stiffness = 0;  ///< N/m for the spring methods
    SoftRelaxation relaxation = SoftRelaxation::InOrder;  ///< Verlet's sweep order
};

std::string compact(double k) {
    char buf[32];
    const double e = std::round(std::log10(k));
    if (k >= 1000 && std::fabs(k - std::pow(10.0, e)) < 1e-9 * k) std::snprintf(buf, sizeof buf, "1e%d", int(e));
    else std::snprintf(buf, sizeof buf, "%.3g", k);
    return buf;
}

SoftBodyDef build_body(const ClothScene& s, const SinewSetting& v) {
    SoftBodyDef base;
    base.method = v.method;
    base.iterations = v.iterations;
    base.long_range_attachments = v.lra;
    base.relaxation = v.relaxation;
    base.pressure = Real(s.pressure);
    base.friction = s.friction;
    base.thickness = s.thickness;
    base.drag = 0;  // Bullet's kDP is 0 by default: no velocity damping on either side
    base.allow_sleep = false;
    LinkMaterial m;
    const Real k = v.stiffness > 0 ? Real(v.stiffness) : Real(1000);
    m.stretch = m.shear = m.bend = k;
    m.damping = 0;
    m.fraction = 1;  // Verlet: full correction per relaxation, as Bullet's kLST = 1
    if (s.kind == ClothSceneKind::PressureBall)
        return make_icosphere(s.ball_centre, s.ball_radius, s.ball_subdivisions, s.total_mass, m, base);
    ClothGridDesc d;
    d.nx = d.ny = s.n;
    d.origin = s.corner00;
    d.edge_u = s.corner10 - s.corner00;
    d.edge_v = s.corner01 - s.corner00;
    d.total_mass = s.total_mass;
    d.shear = true;
    d.bend = false;  // CreatePatch makes no bending links either
    d.material = m;
    SoftBodyDef def = make_cloth_grid(d, base);
    if (s.pin_corners) def.pinned = {cloth_node(d, 0, 0), cloth_node(d, s.n - 1, 0)};
    return def;
}

// The largest spring stiffness semi-implicit Euler is guaranteed stable with at this step. Gershgorin's
// theorem bounds the largest eigenvalue of M^-1 K by max_i 2 k deg_i / m_i (each spring's Hessian block
// has norm <= k, also when stretched), and the method is stable iff omega h < 2 (docs/theory.md#euler),
// i.e. omega^2 < 4 / h^2. We take 90 % of that: k = 0.9 * min_i 2 m_i / (deg_i h^2).
double semi_implicit_stiffness(const ClothScene& s) {
    SoftBodyDef def = build_body(s, SinewSetting{"", "", SoftMethod::SemiImplicitEuler, 1, false, 1});
    std::vector<int> degree(def.positions.size(), 0);
    for (const Link& l : def.links) {
        ++degree[l.a];
        ++degree[l.b];
    }
    std::vector<bool> pinned(def.positions.size(), false);
    for (std::uint32_t p : def.pinned) pinned[p] = true;
    double k = 1e30;
    for (std::size_t i = 0; i < degree.size(); ++i)
        if (!pinned[i] && degree[i] > 0) k = std::min(k, 2 * double(def.masses[i]) / (degree[i] * double(s.h) * double(s.h)));
    return 0.9 * k;
}

// Stiffness and iteration choices:
//  - Verlet: stiffness fraction 1 (rigid links, as Bullet's kLST = 1), 10 and 20 relaxations, with and
//    without long-range attachments where something is pinned (Kim et al. 2012); 10 relaxations by
//    colour (+colour: each colour's links independent, a large body's split among the workers);
//  - semi-implicit Euler: the stability bound above (any stiffer and it explodes; this soft, the hanging
//    cloth stretches by several times: the method's known failure at game time steps);
//  - implicit Euler and fast mass-spring: k = 1e4 N/m. A corner link of the hanging 1 kg cloth carries at
//    most about half the weight, ~5 N: 0.5 mm of extension at 1e4 N/m, 1.5 % of the shortest rest length
//    (3.2 cm, cloth-64); we measured 0.4-3 % once CG / local-global converge. Both methods are stable at
//    any k, so what varies is the work per step. Implicit: the CG cap (a 64 x 64 cloth at k = 1e4 needs
//    ~100-200 iterations; capped at 20 it diverged in our runs, so the table starts at 50 iterations for
//    the softer 1e3 N/m). Fast mass-spring: 1, 3 and 10 local/global iterations on the matrix factored
//    once (Liu et al. 2013).
std::vector<SinewSetting> sinew_settings(const ClothScene& s) {
    std::vector<SinewSetting> out;
    for (int it : {10, 20}) {
        out.push_back({"sinew-verlet", "it" + std::to_string(it), SoftMethod::Verlet, it, false, 0});
        if (s.pin_corners)
            out.push_back({"sinew-verlet", "it" + std::to_string(it) + "+lra", SoftMethod::Verlet, it, true, 0});
    }
    // The sweeps by colour (SoftRelaxation::ByColour), at 10 iterations.
    out.push_back({"sinew-verlet", "it10+colour", SoftMethod::Verlet, 10, false, 0, SoftRelaxation::ByColour});
    if (s.pin_corners)
        out.push_back({"sinew-verlet", "it10+lra+colour", SoftMethod::Verlet, 10, true, 0, SoftRelaxation::ByColour});
    const double k_semi = semi_implicit_stiffness(s);
    out.push_back({"sinew-semi-implicit", "k" + compact(k_semi), SoftMethod::SemiImplicitEuler, 1, false, k_semi});
    struct KI {
        double k;
        int it;
    };
    for (KI c : {KI{1e3, 50}, KI{1e4, 100}, KI{1e4, 200}})
        out.push_back({"sinew-implicit", "k" + compact(c.k) + "-cg" + std::to_string(c.it), SoftMethod::ImplicitEuler,
                       c.it, false, c.k});
    for (KI c : {KI{1e4, 1}, KI{1e4, 3}, KI{1e4, 10}})
        out.push_back({"sinew-fast-ms", "k" + compact(c.k) + "-it" + std::to_string(c.it), SoftMethod::FastMassSpring,
                       c.it, false, c.k});
    return out;
}

// Largest current/rest length ratio over every link but bend links (structural, shear, surface edges),
// the set Bullet's m_links holds for the same scene.
double link_stretch(const SoftBody& b, int* count) {
    double worst = 1;
    int n = 0;
    for (const Link& l : b.links) {
        if (l.kind == LinkKind::Bend) continue;
        ++n;
        worst = std::max(worst, double((b.p.x[l.a] - b.p.x[l.b]).norm() / l.rest));
    }
    if (count) *count = n;
    return worst;
}

Collider static_collider(const Shape& shape, const Transform& xf, Real friction) {
    Collider c;
    c.shape = &shape;
    c.xf = xf;
    c.com = xf.p;
    c.box = shape.bounds(xf);
    c.friction = friction;
    c.restitution = 0;
    return c;
}

ClothRun run_sinew(const ClothScene& s, const SinewSetting& v, int steps, BenchClock clock) {
    SoftSettings settings;
    settings.gravity = s.gravity;
    settings.sleeping = false;
    SoftSystem soft(settings);
    // Static colliders, stepped through the pipeline with the soft system alone.
    const Shape sphere = make_sphere(s.sphere_radius);
    const Shape ground = make_plane(Vec3::UnitY(), s.ground_y);
    Transform at;
    at.p = s.sphere_centre;
    if (s.has_sphere) soft.colliders().push_back(static_collider(sphere, at, s.friction));
    if (s.has_ground) soft.colliders().push_back(static_collider(ground, Transform::identity(), s.friction));
    const SoftBodyId id = soft.create_body(build_body(s, v));
    Pipeline pipeline;
    pipeline.add_system(&soft);

    ClothRun run;
    run.scene = s.name;
    run.engine = v.engine;
    run.variant = v.variant;
    run.iterations = v.iterations;
    run.stiffness = v.stiffness;
    run.lra = v.lra;
    run.nodes = int(soft.body(id).p.size());
    std::vector<double> ms;
    ms.reserve(steps);
    for (int i = 0; i < steps; ++i) {
        const double t0 = bench_clock_ms(clock);
        pipeline.step(s.h);
        ms.push_back(bench_clock_ms(clock) - t0);
        ++run.steps;
        // A finite position can still be 1e30 (an exploded cloth in float): its stretch overflows, so an
        // infinite stretch counts as not finite too.
        const double stretch = link_stretch(soft.body(id), nullptr);
        if (!soft.faults().empty() || !soft.all_finite() || !std::isfinite(stretch)) {
            run.finite = false;
            break;
        }
        run.peak_stretch = std::max(run.peak_stretch, stretch);
    }
    const SoftBody& b = soft.body(id);
    run.ms_per_step_median = median(ms);
    run.max_stretch = link_stretch(b, &run.links);
    if (b.rest_volume > 0) run.volume_ratio = double(b.volume()) / double(b.rest_volume);
    run.max_penetration = scene_penetration(s, b.p.x);
    return run;
}

// ---- output ------------------------------------------------------------------------------------------


std::string fmt(const char* f, double x) {
    if (!std::isfinite(x)) return "-";
    char buf[64];
    std::snprintf(buf, sizeof buf, f, x);
    return buf;
}

std::string markdown_table(const std::vector<ClothRun>& runs, BenchClock clock) {
    std::ostringstream md;
    md << "Times are medians of per-step " << (clock == BenchClock::ThreadCpu ? "thread CPU time" : "wall time")
       << "; stretch is current/rest length over structural, shear and surface links.\n\n";
    md << "| scene | engine | variant | nodes | iterations | k (N/m) | ms/step (median) | max stretch (last step) "
          "| peak stretch (run) | volume ratio | max penetration (m) | finite |\n";
    md << "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|\n";
    for (const ClothRun& r : runs)
        md << "| " << r.scene << " | " << r.engine << " | " << r.variant << " | " << r.nodes << " | " << r.iterations
           << " | " << (r.stiffness > 0 ? compact(r.stiffness) : "-") << " | " << fmt("%.3f", r.ms_per_step_median)
           << " | " << fmt("%.3f", r.max_stretch) << " | " << fmt("%.3f", r.peak_stretch) << " | "
           << fmt("%.3f", r.volume_ratio) << " | " << fmt("%.4f", r.max_penetration) << " | " << (r.finite ? "yes" : "no")
           << " |\n";
    // Issue 5's target, per scene: the fastest Sinew setting with max_stretch <= 1.10, against Bullet.
    md << "\n| scene | Bullet ms | Bullet stretch | fastest Sinew with stretch <= 1.10 | ms | stretch | "
          "meets target (stretch <= 1.10, ms <= Bullet's) |\n|---|---:|---:|---|---:|---:|---|\n";
    for (const ClothRun& b : runs) {
        if (b.engine != "bullet") continue;
        const ClothRun* best = nullptr;
        for (const ClothRun& r : runs)
            if (r.scene == b.scene && r.engine != "bullet" && r.finite && r.max_stretch <= 1.10 &&
                (!best || r.ms_per_step_median < best->ms_per_step_median))
                best = &r;
        md << "| " << b.scene << " | " << fmt("%.3f", b.ms_per_step_median) << " | " << fmt("%.3f", b.max_stretch) << " | ";
        if (best)
            md << best->engine << " " << best->variant << " | " << fmt("%.3f", best->ms_per_step_median) << " | "
               << fmt("%.3f", best->max_stretch) << " | "
               << (best->ms_per_step_median <= b.ms_per_step_median ? "yes" : "no") << " |\n";
        else
            md << "none | - | - | no |\n";
    }
    return md.str();
}

const char* engine_colour(const std::string& engine) {
    if (engine == "sinew-verlet") return "#7b2cbf";
    if (engine == "sinew-semi-implicit") return "#2a9d8f";
    if (engine == "sinew-implicit") return "#1f77b4";
    if (engine == "sinew-fast-ms") return "#e76f00";
    if (engine == "bullet") return "#d62728";
    return "#555555";
}

bool write_chart(const std::vector<ClothRun>& runs, const std::string& png) {
    // One panel per scene; one series per engine (colour), one point per setting labelled with its
    // variant; x = median ms per step, y = max stretch - 1 (both log scale), dashed line at the 10 % target.
    std::vector<std::string> scenes, engines;
    for (const ClothRun& r : runs) {
        if (std::find(scenes.begin(), scenes.end(), r.scene) == scenes.end()) scenes.push_back(r.scene);
        if (std::find(engines.begin(), engines.end(), r.engine) == engines.end()) engines.push_back(r.engine);
    }
    const std::string dat = png + ".dat", gp = png + ".gp";
    std::ofstream out(dat);
    for (const std::string& sc : scenes)
        for (const std::string& e : engines) {
            out << "# " << sc << " " << e << "\n";
            bool any = false;
            for (const ClothRun& r : runs)
                if (r.scene == sc && r.engine == e && std::isfinite(r.max_stretch) && r.finite) {
                    out << std::max(r.ms_per_step_median, 1e-4) << " " << std::max(r.max_stretch - 1, 1e-4) << " "
                        << r.variant << "\n";
                    any = true;
                }
            if (!any) out << "nan nan -\n";  // keeps the index numbering regular
            out << "\n\n";
        }
    out.close();
    std::ofstream g(gp);
    const int cols = scenes.size() > 1 ? 2 : 1, rows = int((scenes.size() + 1) / 2);
    g << "set terminal pngcairo size " << 700 * cols << "," << 520 * rows << "\nset output '" << png << "'\n"
      << "set logscale xy\nset grid\nset key bottom left font ',8'\nset datafile missing 'nan'\n"
      << "set multiplot layout " << rows << "," << cols
      << " title 'Soft bodies: stretch against time (lower left is better; dashed: the 10 % target)'\n";
    for (std::size_t si = 0; si < scenes.size(); ++si) {
        // Keep the 10 % line in view: the y axis starts at or below 0.05.
        double lowest = 0.05;
        for (const ClothRun& r : runs)
            if (r.scene == scenes[si] && r.finite && std::isfinite(r.max_stretch))
                lowest = std::min(lowest, std::max(r.max_stretch - 1, 1e-4));
        g << "set title '" << scenes[si] << "'\nset xlabel 'median ms per step'\nset ylabel 'max stretch - 1 (last step)'\n"
          << "set yrange [" << lowest / 2 << ":*]\n"
          << "unset arrow\nset arrow from graph 0, first 0.1 to graph 1, first 0.1 nohead dt 2 lc rgb 'red'\nplot ";
        for (std::size_t ei = 0; ei < engines.size(); ++ei) {
            const std::size_t index = si * engines.size() + ei;
            const std::string colour = engine_colour(engines[ei]);
            g << (ei ? ", " : "") << "'" << dat << "' index " << index << " using 1:2 with points pt " << (5 + 2 * int(ei))
              << " ps 1.4 lc rgb '" << colour << "' title '" << engines[ei] << "', '' index " << index
              << " using 1:2:3 with labels offset 0,0.7 font ',7' tc rgb '" << colour << "' notitle";
        }
        g << "\n";
    }
    g << "unset multiplot\n";
    g.close();
    const int rc = std::system(("gnuplot '" + gp + "' 2>/dev/null").c_str());
    std::remove(dat.c_str());
    std::remove(gp.c_str());
    return rc == 0;
}

}  // namespace

double bench_clock_ms(BenchClock clock) {
    timespec t{};
    clock_gettime(clock == BenchClock::ThreadCpu ? CLOCK_THREAD_CPUTIME_ID : CLOCK_MONOTONIC, &t);
    return double(t.tv_sec) * 1e3 + double(t.tv_nsec) * 1e-6;
}

std::string to_json_line(const ClothRun& r) {
    auto num = [](double x, const char* f) { return std::isfinite(x) ? fmt(f, x) : std::string("null"); };
    std::ostringstream o;
    o << "{\"scene\":\"" << r.scene << "\",\"engine\":\"" << r.engine << "\",\"variant\":\"" << r.variant
      << "\",\"nodes\":" << r.nodes << ",\"links\":" << r.links << ",\"iterations\":" << r.iterations
      << ",\"stiffness\":" << num(r.stiffness, "%.6g") << ",\"lra\":" << (r.lra ? "true" : "false")
      << ",\"steps\":" << r.steps << ",\"ms_per_step_median\":" << num(r.ms_per_step_median, "%.4f")
      << ",\"max_stretch\":" << num(r.max_stretch, "%.5f") << ",\"peak_stretch\":" << num(r.peak_stretch, "%.5f")
      << ",\"volume_ratio\":" << num(r.volume_ratio, "%.5f")
      << ",\"max_penetration\":" << num(r.max_penetration, "%.5f") << ",\"finite\":" << (r.finite ? "true" : "false")
      << "}";
    return o.str();
}

int cmd_bench_cloth(const std::vector<std::string>& args) {
    using tool::UsageError;
    std::vector<std::string> scenes(std::begin(kDefaultScenes), std::end(kDefaultScenes));
    int steps = -1;
    std::string chart, markdown, scene_dir = "demos/scenes";
    BenchClock clock = BenchClock::ThreadCpu;
    std::vector<std::string> only;  // engine or engine/variant names; empty = all
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
    std::vector<ClothScene> descs;
    for (const std::string& name : scenes) descs.push_back(cloth_scene(name, scene_dir));  // bad files fail first
    auto wanted = [&](const std::string& engine, const std::string& variant) {
        if (only.empty()) return true;
        for (const std::string& o : only)
            if (o == engine || o == engine + "/" + variant) return true;
        return false;
    };
    std::vector<ClothRun> runs;
    int failed = 0;
    for (const ClothScene& scene : descs) {
        const int n = steps > 0 ? steps : scene.steps;
        std::vector<SinewSetting> settings;
        bool any_sinew = only.empty();
        for (const std::string& o : only) any_sinew = any_sinew || o.rfind("sinew-", 0) == 0;
        try {
            if (any_sinew) settings = sinew_settings(scene);
        } catch (const std::exception& e) {
            std::cerr << "bench: " << scene.name << ": cannot build the Sinew body: " << e.what() << "\n";
            ++failed;
        }
        for (const SinewSetting& v : settings) {
            if (!wanted(v.engine, v.variant)) continue;
            std::cerr << "bench: " << scene.name << " " << v.engine << " " << v.variant << " (" << n << " steps)...\n";
            try {
                runs.push_back(run_sinew(scene, v, n, clock));
            } catch (const std::exception& e) {
                // A method not written yet, or a bad setting: say so and go on with the others.
                std::cerr << "bench: " << scene.name << " " << v.engine << " " << v.variant << " failed: " << e.what() << "\n";
                ++failed;
                continue;
            }
            std::cout << to_json_line(runs.back()) << std::endl;
        }
        if (!wanted("bullet", "pi10") || !bullet_peer_available()) continue;
        std::cerr << "bench: " << scene.name << " bullet (" << n << " steps)...\n";
        try {
            runs.push_back(run_bullet_soft(scene, n, clock));
        } catch (const std::exception& e) {
            std::cerr << "bench: " << scene.name << " bullet failed: " << e.what() << "\n";
            ++failed;
            continue;
        }
        std::cout << to_json_line(runs.back()) << std::endl;
    }
    if (!chart.empty() && !write_chart(runs, chart)) std::cerr << "sinew bench: gnuplot failed; no chart\n";
    if (!markdown.empty()) {
        std::string body = markdown_table(runs, clock);
        if (!chart.empty()) body += "\n![stretch against time](" + relative_to(chart, markdown) + ")\n";
        if (!replace_section(markdown, "bench-cloth", body)) {
            std::cerr << "sinew bench: could not write " << markdown << "\n";
            return 1;
        }
    }
    return failed ? 1 : 0;
}

}  // namespace sinew::bench
