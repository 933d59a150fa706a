// `sinew compare`: one scene under every coupling and embedding variant, each measured against a
// reference run of the same scene: speed against accuracy (issue 11; docs/compare.md).
//
//   sinew compare SCENE.json [--strategies LIST] [--steps N] [--reference STRATEGY] [--reference-divide N]
//                 [--chart FILE.png] [--markdown FILE.md]
//   sinew compare --all [--scene-dir DIR] [--steps N] [--repeat N] [--chart-dir DIR] [--markdown FILE.md]
//   sinew compare SCENE.json... | --all  --recommend [--tolerance T]
//
// The reference is a strategy (the scene's "compare_reference", two-way by default) run with its step
// divided by N (8); the same run at
// 2N says how far the reference itself is from converged (printed first, as "reference-check"). Every
// variant then prints one JSON line: its label and settings, median ms per scene step, and its errors
// (tools/compare_runs.hpp). Progress goes to stderr.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "tools/progress.hpp"
#include "tools/bench/results_file.hpp"
#include "tools/commands.hpp"
#include "tools/compare_runs.hpp"

namespace sinew::tool {

namespace {

using compare::Errors;
using compare::Recording;
using compare::Variant;

const char* const kComparisonScenes[] = {"ball-on-trampoline", "box-on-soft-block", "rope-tow",          "cloth-on-arm",
                                         "basketball-net",     "stack-of-soft-cubes", "soft-door"};

/// Every variant that applies to a scene: each strategy at the scene's step, the sub-stepping ones with
/// four soft steps per step, hybrid at two gains, two-way at 1 and 4 exchange iterations and at h/4,
/// embedding with one proxy per element (the nodes' masses split, and seed 001's whole-body weights), and
/// the two-way family and embedding at h/2 too.
std::vector<Variant> default_variants() {
    using S = CouplingStrategy;
    std::vector<Variant> v;
    v.push_back({S::OneWay, 1, 1, 1});
    v.push_back({S::OneWay, 4, 1, 1});
    v.push_back({S::Hybrid, 1, Real(0.5), 1});
    v.push_back({S::Hybrid, 1, 1, 1});
    v.push_back({S::Hybrid, 4, 1, 1});
    v.push_back({S::Interleaved, 1, 1, 1});
    v.push_back({S::TwoWay, 1, 1, 1});
    v.push_back({S::TwoWay, 1, 1, 1, 1});  // the rigid solve's pass of the particle rows only (the scenes': 2)
    v.push_back({S::TwoWay, 1, 1, 1, 4});
    v.push_back({S::TwoWay, 1, 1, 2});
    v.push_back({S::TwoWay, 1, 1, 4});
    v.push_back({S::OneSolver, 1, 1, 1});
    v.push_back({S::OneSolver, 1, 1, 2});
    v.push_back({S::EmbedRigid, 1, 1, 1});
    v.push_back({S::EmbedRigid, 1, 1, 2});
    v.push_back({S::EmbedRigid, 1, 1, 1, 0, 0, EmbedProxies::Elements, EmbedProxyMass::Physical});
    v.push_back({S::EmbedRigid, 1, 1, 1, 0, 0, EmbedProxies::Elements, EmbedProxyMass::WholeBody});
    v.push_back({S::EmbedFem, 1, 1, 1});
    v.push_back({S::EmbedFem, 1, 1, 2});
    v.push_back({S::Auto, 1, 1, 1});
    return v;
}

struct Row {
    Variant variant;
    Recording rec;
    Errors err;
    bool pareto = false;
};

/// Six significant digits (a 4 um error and a 4 m one keep theirs alike).
double round6(double x) {
    if (!std::isfinite(x) || x == 0) return x;
    char b[32];
    std::snprintf(b, sizeof b, "%.6g", x);
    return std::strtod(b, nullptr);
}

nlohmann::json row_json(const std::string& scene, const Row& r) {
    nlohmann::json j;
    j["suite"] = "compare";
    j["scene"] = scene;
    j["variant"] = r.variant.label();
    j["strategy"] = coupling_strategy_name(r.variant.strategy);
    j["substeps"] = r.variant.substeps;
    j["gain"] = round6(double(r.variant.gain));
    j["divide"] = r.variant.divide;
    if (r.variant.exchange > 0) j["exchange_iterations"] = r.variant.exchange;
    j["applies"] = true;
    j["ms_per_step_median"] = round6(r.rec.ms_per_step_median);
    // A run that diverged has no error to speak of (the figures would cover its finite start only).
    const auto error = [&](double x) { return r.rec.finite ? nlohmann::json(round6(x)) : nlohmann::json(nullptr); };
    j["position_rms"] = error(r.err.position_rms);
    j["rigid_rms"] = error(r.err.rigid_rms);
    j["rigid_max"] = error(r.err.rigid_max);
    j["soft_rms"] = error(r.err.soft_rms);
    j["soft_max"] = error(r.err.soft_max);
    j["final_max"] = error(r.err.final_max);
    j["exchanged_error"] = error(r.err.exchanged);
    j["max_penetration"] = round6(r.rec.max_penetration);
    j["pareto"] = r.pareto;
    j["finite"] = r.rec.finite;
    return j;
}

/// Marks the runs no other finite run beats in both time and position error.
void mark_pareto(std::vector<Row>& rows) {
    for (Row& a : rows) {
        if (!a.rec.finite) continue;
        a.pareto = true;
        for (const Row& b : rows)
            if (&a != &b && b.rec.finite && b.rec.ms_per_step_median <= a.rec.ms_per_step_median &&
                b.err.position_rms <= a.err.position_rms &&
                (b.rec.ms_per_step_median < a.rec.ms_per_step_median || b.err.position_rms < a.err.position_rms)) {
                a.pareto = false;
                break;
            }
    }
}

std::string mm(double m) {
    char b[32];
    const double x = m * 1000;
    std::snprintf(b, sizeof b, x < 0.1 ? "%.2g" : x < 100 ? "%.2f" : "%.0f", x);
    return b;
}

/// "cube1 embed-rigid, cube2 embed-rigid": what auto picked, by the scene's names.
std::string picks_text(const SceneDesc& scene, const std::vector<StrategyPick>& picks) {
    std::string out;
    for (const StrategyPick& p : picks) {
        if (!out.empty()) out += ", ";
        out += compare::scene_soft_name(scene, p.soft) + " " + coupling_strategy_name(p.strategy);
    }
    return out;
}

std::string markdown_table(const std::string& name, const std::string& reference, const Errors* check,
                           const SceneDesc& scene, const std::vector<Row>& rows, const std::string& chart_link) {
    std::ostringstream o;
    o << "### " << name << "\n\n" << "Against the reference, " << reference;
    if (check)
        o << " (halving its step again moves it by " << mm(check->position_rms) << " mm RMS, " << mm(check->final_max)
          << " mm at the end)";
    o << ". Position errors over every step of the run, rigid "
      << "centres and soft nodes; *exchanged*: the impulse soft bodies gave dynamic rigid bodies, relative to the "
      << "reference's; **bold**: on the Pareto front of time against position RMS.\n\n";
    for (const Row& r : rows)
        if (r.variant.strategy == CouplingStrategy::Auto)
            o << "*auto* (tolerance " << mm(r.variant.tolerance_in(scene))
              << " mm) picked: " << picks_text(scene, r.rec.picks) << ".\n\n";
    o << "| variant | ms/step | position RMS (mm) | rigid max (mm) | soft max (mm) | final max (mm) | exchanged error | "
         "penetration (mm) | finite |\n|---|---|---|---|---|---|---|---|---|\n";
    for (const Row& r : rows) {
        char ms[32], ex[32];
        std::snprintf(ms, sizeof ms, "%.3f", r.rec.ms_per_step_median);
        std::snprintf(ex, sizeof ex, "%.3f", r.err.exchanged);
        const std::string name = r.pareto ? "**" + r.variant.label() + "**" : r.variant.label();
        o << "| " << name << " | " << ms << " | " << (r.rec.finite ? mm(r.err.position_rms) : "-") << " | "
          << (r.rec.finite ? mm(r.err.rigid_max) : "-") << " | " << (r.rec.finite ? mm(r.err.soft_max) : "-") << " | "
          << (r.rec.finite ? mm(r.err.final_max) : "-") << " | " << (r.rec.finite ? ex : "-") << " | "
          << mm(r.rec.max_penetration) << " | " << (r.rec.finite ? "yes" : "**no**") << " |\n";
    }
    if (!chart_link.empty()) o << "\n![" << name << ": position error against time](" << chart_link << ")\n";
    o << "\n";
    return o.str();
}

bool write_chart(const std::string& scene, const std::vector<Row>& rows, double noise, const std::string& png) {
    const std::string dat = png + ".dat", gp = png + ".gp";
    {
        std::ofstream out(dat);
        out << "# all\n";
        for (const Row& r : rows)
            if (r.rec.finite)
                out << std::max(r.rec.ms_per_step_median, 1e-3) << " " << std::max(r.err.position_rms, 1e-6) << " \""
                    << r.variant.label() << "\"\n";
        out << "\n\n# pareto\n";
        std::vector<const Row*> front;
        for (const Row& r : rows)
            if (r.pareto) front.push_back(&r);
        std::sort(front.begin(), front.end(),
                  [](const Row* a, const Row* b) { return a->rec.ms_per_step_median < b->rec.ms_per_step_median; });
        for (const Row* r : front)
            out << std::max(r->rec.ms_per_step_median, 1e-3) << " " << std::max(r->err.position_rms, 1e-6) << "\n";
        if (front.empty()) out << "nan nan\n";
    }
    {
        std::ofstream g(gp);
        g << "set terminal pngcairo size 900,600\nset output '" << png << "'\nset grid\nset logscale xy\n"
          << "set datafile missing 'nan'\nset key outside below\nset title '" << scene
          << ": position error against the reference, against time'\nset xlabel 'median ms per step'\n"
          << "set ylabel 'position RMS error (m)'\n";
        // Errors below the reference's own (its step halved again) are not resolved; no line if not measured.
        if (noise >= 0)
            g << "set arrow 1 from graph 0, first " << std::max(noise, 1e-6) << " to graph 1, first "
              << std::max(noise, 1e-6) << " nohead dt 2 lc rgb 'gray'\nset label 1 'reference check' at graph 0.01, first "
              << std::max(noise, 1e-6) * 1.2 << " font ',8' tc rgb 'gray'\n";
        g << "plot '" << dat << "' index 0 using 1:2 with points pt 7 ps 1.3 lc rgb '#1f77b4' title 'variants', "
          << "'' index 0 using 1:2:3 with labels offset 0,0.9 font ',8' notitle, "
          << "'' index 1 using 1:2 with linespoints lw 2 pt 6 ps 2 lc rgb '#d62728' title 'Pareto front'\n";
    }
    const int rc = std::system(("gnuplot '" + gp + "' 2>/dev/null").c_str());
    std::remove(dat.c_str());
    std::remove(gp.c_str());
    return rc == 0;
}

std::vector<std::string> split_list(const std::string& s) {
    std::vector<std::string> out;
    std::stringstream ss(s);
    for (std::string item; std::getline(ss, item, ',');)
        if (!item.empty()) out.push_back(item);
    return out;
}

/// Compares one scene; returns its markdown section, or "" if nothing ran. Sets `all_finite`.
/// A file name for a variant's recording: "two-way h/2" -> "two-way-h2".
std::string slug(const std::string& label) {
    std::string out;
    for (char c : label) {
        if (std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-') out += c;
        else if (c == ' ' && !out.empty() && out.back() != '-') out += '-';
    }
    return out;
}

/// `sinew compare --check-auto`: did auto stay within the scene's tolerance, and pick nothing costlier than
/// the reference's strategy? One JSON line; false if not.
bool check_auto(const std::string& name, const SceneDesc& scene, CouplingStrategy reference, const std::vector<Row>& rows,
                bool table) {
    const Row* run = nullptr;
    for (const Row& r : rows)
        if (r.variant.strategy == CouplingStrategy::Auto) run = &r;
    nlohmann::json j;
    j["suite"] = "compare";
    j["scene"] = name;
    j["variant"] = "auto-check";
    const Real tolerance = run ? run->variant.tolerance_in(scene) : scene.coupling.settings.tolerance;
    j["tolerance"] = round6(double(tolerance));
    bool ok = run && run->rec.finite && run->err.position_rms <= double(tolerance);
    bool cheap = run != nullptr;
    nlohmann::json picks = nlohmann::json::array();
    if (run)
        for (const StrategyPick& p : run->rec.picks) {
            picks.push_back(coupling_strategy_name(p.strategy));
            cheap = cheap && strategy_cost_rank(p.strategy) <= strategy_cost_rank(reference);
        }
    j["picks"] = picks;
    j["position_rms"] = run && run->rec.finite ? nlohmann::json(round6(run->err.position_rms)) : nlohmann::json(nullptr);
    j["within_tolerance"] = ok;
    j["reference_strategy"] = coupling_strategy_name(reference);
    j["not_costlier_than_reference"] = cheap;
    if (!table) std::cout << j.dump() << std::endl;
    if (!ok || !cheap)
        std::cerr << "sinew compare: " << name << ": auto "
                  << (!run ? "did not run"
                           : !ok ? "is " + mm(run->err.position_rms) + " mm RMS off, over the tolerance of " + mm(tolerance) + " mm"
                                 : std::string("picked a strategy costlier than the reference's ") + coupling_strategy_name(reference))
                  << "\n";
    return ok && cheap;
}

std::string compare_scene(const std::string& path, const std::vector<Variant>& variants, int steps_arg,
                          const CouplingStrategy* reference_override, int reference_divide, const std::string& chart,
                          const std::string& markdown, const std::string& record_dir, bool table, bool reference_check,
                          bool check, int repeat, bool& all_finite, bool& auto_ok) {
    const SceneDesc scene = parse_scene_file(path);
    const CouplingStrategy reference_strategy = reference_override ? *reference_override : scene.coupling.compare_reference;
    const int steps = steps_arg > 0 ? steps_arg : scene.steps;
    const std::string name = scene.name.empty() ? std::filesystem::path(path).stem().string() : scene.name;
    const Variant ref{reference_strategy, 1, 1, reference_divide};
    const Variant ref2{reference_strategy, 1, 1, 2 * reference_divide};
    const auto record_path = [&](const std::string& what) {
        return record_dir.empty() ? std::string() : record_dir + "/" + name + "-" + slug(what) + ".jsonl";
    };
    Progress progress("compare " + name, (long long)variants.size() + 2, "variants");
    progress.set_detail("reference " + ref.label());
    const Recording reference = compare::run_variant(scene, ref, steps, record_path("reference " + ref.label()));
    progress.update(1);
    if (!reference.finite) throw std::runtime_error(name + ": the reference run (" + ref.label() + ") is not finite");
    Errors noise;  // the reference against itself at half its step
    if (reference_check) {
        progress.set_detail("reference check " + ref2.label());
        const Recording finer = compare::run_variant(scene, ref2, steps);
        noise = compare::errors_against(finer, reference);
        nlohmann::json cj;
        cj["suite"] = "compare";
        cj["scene"] = name;
        cj["variant"] = "reference-check";
        cj["reference"] = ref.label();
        cj["finer"] = ref2.label();
        cj["position_rms"] = round6(noise.position_rms);
        cj["final_max"] = round6(noise.final_max);
        cj["finite"] = finer.finite;
        if (!table) std::cout << cj.dump() << std::endl;
    }
    progress.update(2);

    std::vector<Row> rows;
    for (const Variant& v : variants) {
        progress.set_detail(v.label());
        Row r;
        r.variant = v;
        try {
            r.rec = compare::run_variant(scene, v, steps, record_path(v.label()));
            progress.update(2 + (long long)(&v - variants.data()) + 1);
        } catch (const std::exception& e) {
            // A strategy the scene cannot run (a joint on a soft body needs it embedded; a world the
            // strategy refuses): said, not run.
            nlohmann::json j;
            j["suite"] = "compare";
            j["scene"] = name;
            j["variant"] = v.label();
            j["applies"] = false;
            j["why"] = e.what();
            if (!table) std::cout << j.dump() << std::endl;
            continue;
        }
        r.err = compare::errors_against(r.rec, reference);
        all_finite = all_finite && r.rec.finite;
        rows.push_back(std::move(r));
    }
    // Timed again, every variant in turn, `repeat` times in all: the least of each one's medians. The
    // median over a run's steps removes an odd slow step, not a stretch of a shared machine running slow,
    // which turns would spread over the variants. The runs are deterministic: the errors stay.
    for (int k = 1; k < repeat; ++k)
        for (Row& r : rows) {
            progress.set_detail(r.variant.label() + " timed again");
            r.rec.ms_per_step_median =
                std::min(r.rec.ms_per_step_median, compare::run_variant(scene, r.variant, steps).ms_per_step_median);
        }
    progress.finish();
    mark_pareto(rows);
    if (!table)
        for (const Row& r : rows) std::cout << row_json(name, r).dump() << std::endl;
    if (check) auto_ok = check_auto(name, scene, reference_strategy, rows, table) && auto_ok;
    bool charted = false;
    if (!chart.empty()) {
        charted = write_chart(name, rows, reference_check ? noise.position_rms : -1, chart);
        if (!charted) std::cerr << "sinew compare: gnuplot failed; no chart\n";
    }
    const std::string link = charted && !markdown.empty() ? bench::relative_to(chart, markdown) : "";
    const std::string md = markdown_table(name, ref.label(), reference_check ? &noise : nullptr, scene, rows, link);
    if (table) std::cout << md;
    return md;
}

/// `sinew compare --recommend`: what auto picks for each soft body of the scene, and why (no run).
void recommend_scene(const std::string& path, double tolerance) {
    SceneDesc scene = parse_scene_file(path);
    scene.coupling.settings.strategy = CouplingStrategy::Auto;
    scene.coupling.settings.substeps = 1;
    scene.coupling.pairs.clear();
    if (tolerance > 0) scene.coupling.settings.tolerance = Real(tolerance);
    const std::unique_ptr<World> w = build_world(scene);
    const std::string name = scene.name.empty() ? std::filesystem::path(path).stem().string() : scene.name;
    std::cout << name << " (tolerance " << mm(scene.coupling.settings.tolerance) << " mm):\n";
    for (const StrategyPick& p : w->coupling().picks())
        std::cout << "  " << picks_text(scene, {p}) << ": " << p.reason << "\n";
}

int run_compare(const std::vector<std::string>& args) {
    std::vector<std::string> scenes;
    std::vector<std::string> strategies;
    std::string chart, chart_dir, markdown, record_dir, scene_dir = "demos/scenes";
    int steps = 0, reference_divide = 8, repeat = 1;
    double tolerance = 0;
    CouplingStrategy reference = CouplingStrategy::TwoWay;
    bool all = false, reference_given = false, table = false, recommend = false, check = false, reference_check = true;
    for (std::size_t i = 0; i < args.size(); ++i) {
        const std::string& a = args[i];
        if (a == "--all") all = true;
        else if (a == "--table") table = true;
        else if (a == "--recommend") recommend = true;
        else if (a == "--check-auto") check = true;
        else if (a == "--no-reference-check") reference_check = false;
        else if (is_option(a, "--tolerance")) {
            const std::string t = option_value(args, i, "--tolerance");
            char* end = nullptr;
            tolerance = std::strtod(t.c_str(), &end);
            if (t.empty() || *end != 0 || !(Real(tolerance) > 0 && tolerance <= double(kMaxCouplingTolerance)))
                throw UsageError("--tolerance: a length in (0, 1000] m, got \"" + t + "\"");
        }
        else if (is_option(a, "--strategies")) strategies = split_list(option_value(args, i, "--strategies"));
        else if (is_option(a, "--repeat")) repeat = int(parse_int("--repeat", option_value(args, i, "--repeat"), 1, 20));
        else if (is_option(a, "--steps")) steps = int(parse_int("--steps", option_value(args, i, "--steps"), 1, 1000000));
        else if (is_option(a, "--reference-divide"))
            reference_divide = int(parse_int("--reference-divide", option_value(args, i, "--reference-divide"), 1, 64));
        else if (is_option(a, "--reference")) {
            const std::string s = option_value(args, i, "--reference");
            if (!parse_coupling_strategy(s, reference) || reference == CouplingStrategy::Auto)
                throw UsageError("--reference: unknown strategy \"" + s + "\" (known: " + coupling_strategy_list() +
                                 "; the reference cannot be auto)");
            reference_given = true;
        } else if (is_option(a, "--chart")) chart = option_value(args, i, "--chart");
        else if (is_option(a, "--chart-dir")) chart_dir = option_value(args, i, "--chart-dir");
        else if (is_option(a, "--markdown")) markdown = option_value(args, i, "--markdown");
        else if (is_option(a, "--scene-dir")) scene_dir = option_value(args, i, "--scene-dir");
        else if (is_option(a, "--record-dir")) {
            record_dir = option_value(args, i, "--record-dir");
            if (record_dir.empty()) throw UsageError("--record-dir needs a folder");
        } else if (!a.empty() && a[0] == '-') throw UsageError("unknown option " + a);
        else scenes.push_back(a);
    }
    if (all) {
        if (!scenes.empty()) throw UsageError("give scene files or --all, not both");
        for (const char* s : kComparisonScenes) scenes.push_back(scene_dir + "/" + s + ".json");
    }
    if (scenes.empty()) throw UsageError("no scene given (a scene file, or --all)");
    if (scenes.size() > 1 && !chart.empty()) throw UsageError("--chart names one file: with several scenes use --chart-dir");
    if (!record_dir.empty()) {
        std::error_code ec;
        std::filesystem::create_directories(record_dir, ec);
        if (ec) throw UsageError("--record-dir: cannot create " + record_dir + ": " + ec.message());
    }
    if (recommend) {
        for (const std::string& path : scenes) recommend_scene(path, tolerance);
        return kExitOk;
    }
    std::vector<Variant> variants;
    for (Variant v : default_variants()) {
        v.tolerance = Real(tolerance);
        if (strategies.empty()) {
            variants.push_back(v);
            continue;
        }
        for (const std::string& s : strategies) {
            CouplingStrategy c;
            if (!parse_coupling_strategy(s, c))
                throw UsageError("--strategies: unknown strategy \"" + s + "\" (known: " + coupling_strategy_list() + ")");
            if (c == v.strategy) variants.push_back(v);
        }
    }
    if (check && std::none_of(variants.begin(), variants.end(), [](const Variant& v) { return v.strategy == CouplingStrategy::Auto; }))
        throw UsageError("--check-auto needs the auto variant (--strategies without auto leaves it out)");
    bool auto_ok = true;
    bool all_finite = true;
    std::string body;
    for (const std::string& path : scenes) {
        std::string png = chart;
        if (!chart_dir.empty()) png = chart_dir + "/compare-" + std::filesystem::path(path).stem().string() + ".png";
        body += compare_scene(path, variants, steps, reference_given ? &reference : nullptr, reference_divide, png,
                              markdown, record_dir, table, reference_check, check, repeat, all_finite, auto_ok);
    }
    if (!markdown.empty() && !bench::replace_section(markdown, "compare", body,
                                                        repeat > 1 ? "sinew compare --all --repeat " + std::to_string(repeat)
                                                                   : std::string("sinew compare --all"))) {
        std::cerr << "sinew compare: could not write " << markdown << "\n";
        return kExitFailure;
    }
    if (!auto_ok) return kExitFailure;
    return all_finite ? kExitOk : kExitNonFinite;
}

}  // namespace

extern const Command compare_command = {
    "compare", run_compare, "run a scene under every coupling and embedding strategy against a reference",
    "usage: sinew compare SCENE.json... [--strategies LIST] [--steps N] [--reference STRATEGY]\n"
    "                     [--reference-divide N] [--chart FILE.png] [--chart-dir DIR] [--markdown FILE.md]\n"
    "                     [--record-dir DIR]\n"
    "       sinew compare --all [--scene-dir DIR] [...]\n\n"
    "Runs each scene under every coupling and embedding variant (one-way, one-way with 4 soft sub-steps,\n"
    "hybrid at gains 0.5 and 1, interleaved, two-way at h (1, 2 and 4 exchange iterations), h/2 and h/4,\n"
    "one-solver, embed-rigid and embed-fem at h and h/2, auto)\n"
    "and measures each against a reference: STRATEGY (default: the scene's coupling.compare_reference,\n"
    "else two-way) with the step divided by N (8),\n"
    "itself checked against the same at 2N. Prints one JSON line per run: median ms per scene step,\n"
    "position errors (RMS and maximum over every step, rigid centres and soft nodes; the last step's),\n"
    "the error of the impulse soft bodies gave rigid bodies, the deepest penetration, the Pareto front.\n"
    "Sleeping is off in every run.\n\n"
    "  --strategies LIST      only these strategies (comma-separated names)\n"
    "  --steps N              scene steps per run (default: the scene's)\n"
    "  --repeat N             time each variant N times, keep the least median (default 1)\n"
    "  --all                  the comparison scenes of demos/scenes (--scene-dir DIR)\n"
    "  --chart FILE.png       error against time, Pareto front marked (gnuplot); --chart-dir DIR for --all\n"
    "  --markdown FILE.md     rewrite the compare section of FILE (docs/RESULTS.md)\n"
    "  --table                print each scene's table (markdown) instead of the JSON lines\n"
    "  --recommend            print what the \"auto\" strategy picks for each soft body, and why (runs nothing)\n"
    "  --tolerance T          auto's position tolerance in m (default: the scene's coupling.tolerance, else 0.01)\n"
    "  --check-auto           exit 1 unless auto's position RMS is within the tolerance and it picked nothing\n"
    "                         costlier than the reference's strategy\n"
    "  --no-reference-check   skip the run at half the reference's step\n"
    "  --record-dir DIR       write each run's playback file, contacts included, to DIR/SCENE-VARIANT.jsonl\n"
    "                         (the reference's too),\n"
    "                         to watch side by side: scripts/dev view DIR/SCENE-*.jsonl\n"
    "Progress is shown on stderr when it is a terminal and CI is not set.\n"
    "Exit status: 0, 1 on a bad scene or output, 2 on bad arguments, 3 if a run was not finite.\n"};

}  // namespace sinew::tool
