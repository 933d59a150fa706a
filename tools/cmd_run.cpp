// `sinew run SCENE.json`: step a scene headless and print one JSON line of measurements.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>

#include "engine/world/scene.hpp"
#include "soft/soft_stability.hpp"
#include "tools/bench/bench_rigid.hpp"  // median()
#include "tools/commands.hpp"
#include "tools/compare_runs.hpp"  // scene_soft_name
#include "tools/progress.hpp"
#include "tools/record.hpp"

namespace sinew::tool {

namespace {

struct RunOptions {
    std::string scene;
    std::optional<long long> steps;
    std::optional<double> dt;
    std::string record;
    bool record_contacts = false;
    std::string save;
    std::optional<CouplingStrategy> coupling;
    std::optional<EmbedProxies> proxies;
    std::optional<EmbedProxyMass> proxy_mass;
    std::optional<int> substeps;
    std::optional<int> exchange;
    std::optional<double> gain;
    int workers = 1;
};

RunOptions parse_options(const std::vector<std::string>& args) {
    RunOptions o;
    for (std::size_t i = 0; i < args.size(); ++i) {
        const std::string& a = args[i];
        if (is_option(a, "--steps")) {
            o.steps = parse_int("--steps", option_value(args, i, "--steps"), 0, 100000000);
        } else if (is_option(a, "--dt")) {
            o.dt = parse_positive("--dt", option_value(args, i, "--dt"));
        } else if (is_option(a, "--workers")) {
            o.workers = int(parse_int("--workers", option_value(args, i, "--workers"), 1, kMaxWorkers));
        } else if (is_option(a, "--record")) {
            o.record = option_value(args, i, "--record");
            if (o.record.empty()) throw UsageError("--record needs a file name");
        } else if (a == "--record-contacts") {
            o.record_contacts = true;
        } else if (is_option(a, "--save")) {
            o.save = option_value(args, i, "--save");
            if (o.save.empty()) throw UsageError("--save needs a file name");
        } else if (is_option(a, "--coupling")) {
            const std::string name = option_value(args, i, "--coupling");
            CouplingStrategy c;
            if (!parse_coupling_strategy(name, c))
                throw UsageError("unknown coupling strategy '" + name + "' (expected one of: " + coupling_strategy_list() + ")");
            o.coupling = c;
        } else if (is_option(a, "--substeps")) {
            o.substeps = int(parse_int("--substeps", option_value(args, i, "--substeps"), 1, 64));
        } else if (is_option(a, "--exchange")) {
            o.exchange = int(parse_int("--exchange", option_value(args, i, "--exchange"), 1, 100));
        } else if (is_option(a, "--gain")) {
            const std::string text = option_value(args, i, "--gain");
            char* end = nullptr;
            const double g = std::strtod(text.c_str(), &end);
            if (text.empty() || *end != '\0' || !(g >= 0 && g <= 1))
                throw UsageError("--gain expects a number in [0, 1], got '" + text + "'");
            o.gain = g;
        } else if (is_option(a, "--proxies")) {
            const std::string name = option_value(args, i, "--proxies");
            EmbedProxies p;
            if (!parse_embed_proxies(name, p)) throw UsageError("--proxies: unknown '" + name + "' (expected body or elements)");
            o.proxies = p;
        } else if (is_option(a, "--proxy-mass")) {
            const std::string name = option_value(args, i, "--proxy-mass");
            EmbedProxyMass m;
            if (!parse_embed_proxy_mass(name, m))
                throw UsageError("--proxy-mass: unknown '" + name + "' (expected physical or whole-body)");
            o.proxy_mass = m;
        } else if (!a.empty() && a[0] == '-') {
            throw UsageError("unknown option '" + a + "'");
        } else if (o.scene.empty()) {
            o.scene = a;
        } else {
            throw UsageError("only one scene file may be given (got '" + o.scene + "' and '" + a + "')");
        }
    }
    if (o.scene.empty()) throw UsageError("no scene file given");
    if (o.record_contacts && o.record.empty()) throw UsageError("--record-contacts needs --record FILE");
    return o;
}

// "rigid body 'crate'" / "soft body 'cloth'": the scene's name of the body a fault names (the world was
// built from the scene: rigid ids in `ids`, soft bodies in file order).
std::string body_name(const SceneDesc& scene, const std::vector<BodyId>& ids, const World& world, const StepFault& f) {
    const bool soft = f.system == StepFault::System::Soft;
    std::string name;
    if (soft) {
        const std::vector<SoftBodyId> soft_ids = world.soft().bodies();
        for (std::size_t i = 0; i < soft_ids.size() && i < scene.soft_bodies.size(); ++i)
            if (soft_ids[i].index == f.index) name = scene.soft_bodies[i].name;
    } else {
        for (std::size_t i = 0; i < ids.size() && i < scene.bodies.size(); ++i)
            if (ids[i].index == f.index) name = scene.bodies[i].name;
    }
    return std::string(f.system_name()) + " body '" + (name.empty() ? "#" + std::to_string(f.index) : name) + "'";
}

// Measurements are printed to a sensible number of significant digits rather than as 17-digit doubles.
double round_sig(double v, int digits) {
    if (!std::isfinite(v) || v == 0) return v;
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.*g", digits, v);
    return std::strtod(buf, nullptr);
}

int run(const std::vector<std::string>& args) {
    const RunOptions opt = parse_options(args);
    SceneDesc scene = parse_scene_file(opt.scene);
    if (opt.dt) {
        if (!(std::abs(*opt.dt) <= double(kRealMax))) throw UsageError("--dt is out of range");
        scene.settings.time_step = Real(*opt.dt);
    }
    const long long steps = opt.steps ? *opt.steps : scene.steps;
    if (opt.coupling) {
        // The strategy for every pair: the scene's per-pair overrides are dropped with it.
        scene.coupling.settings.strategy = *opt.coupling;
        scene.coupling.pairs.clear();
        // Sub-steps are one-way's and hybrid's; the others step both systems together.
        if (*opt.coupling != CouplingStrategy::OneWay && *opt.coupling != CouplingStrategy::Hybrid)
            scene.coupling.settings.substeps = 1;
    }
    if (opt.substeps) scene.coupling.settings.substeps = *opt.substeps;
    if (opt.exchange) scene.coupling.settings.exchange_iterations = *opt.exchange;
    if (opt.gain) scene.coupling.settings.gain = Real(*opt.gain);
    if (opt.substeps || opt.coupling) {
        // Sub-steps the strategy cannot take are a wrong argument here, not a wrong scene.
        const std::string problem = coupling_settings_problem(scene.coupling.settings);
        if (!problem.empty()) throw UsageError(problem);
        // The scene's per-pair overrides join the settings only when the world is built: sub-steps need
        // every one of them one-way or hybrid too.
        if (scene.coupling.settings.substeps > 1)
            for (const auto& pair : scene.coupling.pairs)
                if (pair.strategy != CouplingStrategy::OneWay && pair.strategy != CouplingStrategy::Hybrid)
                    throw UsageError("--substeps " + std::to_string(scene.coupling.settings.substeps) +
                                     " needs one-way or hybrid coupling for every pair; the scene's " + pair.json_path +
                                     " is " + coupling_strategy_name(pair.strategy));
    }
    if (opt.proxies) scene.coupling.settings.embed_proxies = *opt.proxies;
    if (opt.proxy_mass) scene.coupling.settings.embed_proxy_mass = *opt.proxy_mass;

    std::vector<BodyId> ids;
    const std::unique_ptr<World> world = build_world(scene, &ids);
    world->set_threads(opt.workers);
    // A body past its method's documented stability limit at this step is run, with a warning first.
    {
        const std::vector<SoftBodyId> soft_ids = world->soft().bodies();
        for (std::size_t i = 0; i < soft_ids.size() && i < scene.soft_bodies.size(); ++i) {
            const Real h = world->settings().time_step / Real(world->soft().substeps());  // the step it takes
            const std::string w = stability_warning(world->soft().body(soft_ids[i]), h);
            if (!w.empty()) std::cerr << "sinew run: warning: soft body '" << scene.soft_bodies[i].name << "': " << w << '\n';
        }
    }
    RigidSystem& rigid = world->rigid();
    std::unique_ptr<Recorder> recorder;
    if (!opt.record.empty()) {
        recorder = std::make_unique<Recorder>(opt.record, scene, *world, ids, opt.record_contacts);
        recorder->write_frame(*world, 0);
    }

    // Each step is timed on its own and the median reported: robust to the odd slow step caused by the
    // OS or a shared machine, which a mean would absorb.
    std::vector<double> step_ms;
    step_ms.reserve(static_cast<std::size_t>(steps));
    double max_penetration = 0;
    const SoftSystem& soft = world->soft();
    bool finite = rigid.all_finite() && soft.all_finite();
    long long done = 0;
    Progress progress(scene.name.empty() ? opt.scene : scene.name, steps);
    while (finite && done < steps) {
        const auto t0 = std::chrono::steady_clock::now();
        world->step();
        const auto t1 = std::chrono::steady_clock::now();
        step_ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
        ++done;
        // Stop at the first blow-up: later steps would measure a body put back at rest (World::faults).
        if (!world->faults().empty()) progress.finish();
        for (const StepFault& f : world->faults())
            std::cerr << "sinew run: step " << f.step << ": " << body_name(scene, ids, *world, f) << ": " << f.outcome()
                      << '\n';
        finite = world->faults().empty() && rigid.all_finite() && soft.all_finite();
        max_penetration = std::max(max_penetration, static_cast<double>(rigid.max_penetration()));
        if (recorder) recorder->write_frame(*world, static_cast<std::uint64_t>(done));
        progress.update(done);
    }
    progress.finish();
    if (recorder) recorder->finish();
    if (!opt.save.empty()) save_scene_file(*world, opt.save);  // SceneError (exit 1) if it cannot be written

    // An embedded soft body's rigid proxies move with its nodes, whose energy the soft system counts: the
    // proxies are left out (with seed 001's whole-body weights each would count the whole body again).
    double energy = rigid.kinetic_energy() + soft.kinetic_energy();
    for (std::uint32_t s = 0; s < rigid.slot_count(); ++s) {
        if (!rigid.slot_alive(s)) continue;
        const BodyId id = rigid.id_of_slot(s);
        if (rigid.type(id) != BodyType::Dynamic || !world->coupling().embedding().is_proxy(id)) continue;
        const Mat3 r = rigid.state().q[s].toRotationMatrix();
        const Vec3& v = rigid.state().v[s];
        const Vec3& w = rigid.state().w[s];
        energy -= 0.5 * double(rigid.mass(id)) * double(v.squaredNorm()) +
                  0.5 * double(w.dot(r * rigid.inertia_local(id) * r.transpose() * w));
    }
    double max_stretch = 1;
    for (SoftBodyId id : soft.bodies()) max_stretch = std::max(max_stretch, double(soft.body(id).max_stretch()));
    nlohmann::ordered_json out;
    out["scene"] = scene.name;
    out["steps"] = done;
    out["bodies"] = rigid.body_count();
    out["soft_bodies"] = soft.body_count() - world->coupling().fem_embedding().count();  // not embed-fem's proxies
    out["particles"] = soft.particle_count();
    if (opt.workers > 1) out["workers"] = opt.workers;
    out["coupling"] = coupling_strategy_name(world->coupling().settings().strategy);
    if (!world->coupling().settings().pairs.empty()) out["coupling_pairs"] = world->coupling().settings().pairs.size();
    if (world->coupling().settings().strategy == CouplingStrategy::Auto) {
        // What "auto" picked for each soft body of the scene.
        nlohmann::ordered_json picks = nlohmann::ordered_json::object();
        for (const StrategyPick& p : world->coupling().picks())
            picks[compare::scene_soft_name(scene, p.soft)] = coupling_strategy_name(p.strategy);
        out["coupling_picks"] = std::move(picks);
    }
    if (world->coupling().settings().embed_proxies == EmbedProxies::Elements) {
        out["coupling_proxies"] = embed_proxies_name(EmbedProxies::Elements);
        out["coupling_proxy_mass"] = embed_proxy_mass_name(world->coupling().settings().embed_proxy_mass);
    }
    const CouplingSettings& cs = world->coupling().settings();
    if (cs.substeps > 1) out["coupling_substeps"] = cs.substeps;
    const auto in_use = [&](CouplingStrategy s) {
        if (cs.strategy == s) return true;
        for (const CouplingPair& p : cs.pairs)
            if (p.strategy == s) return true;
        return false;
    };
    if (in_use(CouplingStrategy::Hybrid)) out["coupling_gain"] = round_sig(double(cs.gain), 6);
    if (in_use(CouplingStrategy::TwoWay)) out["coupling_exchange_iterations"] = cs.exchange_iterations;
    out["ms_per_step_median"] = round_sig(bench::median(step_ms), 4);
    out["max_penetration"] = std::isfinite(max_penetration) ? nlohmann::ordered_json(round_sig(max_penetration, 4))
                                                            : nlohmann::ordered_json(nullptr);
    out["kinetic_energy"] = finite && std::isfinite(energy) ? nlohmann::ordered_json(round_sig(energy, 6))
                                                            : nlohmann::ordered_json(nullptr);
    out["max_stretch"] = finite ? nlohmann::ordered_json(round_sig(max_stretch, 4)) : nlohmann::ordered_json(nullptr);
    out["finite"] = finite;
    std::cout << out.dump() << std::endl;
    return finite ? kExitOk : kExitNonFinite;
}

}  // namespace

const Command run_command = {
    "run", run, "step a scene headless and print one JSON line of measurements",
    "usage: sinew run SCENE.json [--steps N] [--dt H] [--coupling STRATEGY] [--substeps K] [--gain G]\n"
    "                [--exchange N] [--proxies body|elements] [--proxy-mass physical|whole-body]\n"
    "                [--workers N] [--record FILE] [--record-contacts] [--save FILE]\n"
    "\n"
    "Steps the scene N times (default: the scene's settings.steps) with the fixed step H seconds\n"
    "(default: settings.time_step) and prints one JSON line:\n"
    "  {\"scene\", \"steps\" (taken), \"bodies\", \"soft_bodies\", \"particles\", \"workers\" (if more than one), \"coupling\" (the world's\n"
    "   strategy; \"coupling_pairs\": how many pairs override it; \"coupling_substeps\": soft steps per\n"
    "   step, if more than one; \"coupling_gain\" if a pair is hybrid; \"coupling_exchange_iterations\" if\n"
    "   one is two-way; \"coupling_proxies\" and \"coupling_proxy_mass\" with element proxies),\n"
    "   \"ms_per_step_median\" (wall time), \"max_penetration\" (m, deepest rigid contact over the run),\n"
    "   \"kinetic_energy\" (J, rigid and soft, at the end; embedded soft bodies' proxies left out),\n"
    "   \"max_stretch\" (largest current/rest length of a soft link at the end), \"finite\"}\n"
    "A step that leaves any body state NaN or infinite stops the run with \"finite\": false.\n"
    "\n"
    "  --steps N       number of steps (0 allowed: only build the world)\n"
    "  --dt H          fixed step in seconds, overrides the scene's time_step\n"
    "  --coupling S    rigid-soft coupling for every pair: one-way, two-way, hybrid, interleaved or\n"
    "                  one-solver, embed-rigid or embed-fem (overrides the scene's \"coupling\" section, its pairs included;\n"
    "                  docs/coupling.md)\n"
    "  --substeps K    one-way's and hybrid's soft steps per rigid step, in [1, 64] (the scene's\n"
    "                  coupling.substeps; --coupling with another strategy sets it to 1)\n"
    "  --gain G        hybrid's share of the reaction sent back, in [0, 1] (coupling.gain)\n"
    "  --exchange N    two-way's passes of the particle rows per step, in [1, 100]\n"
    "                  (coupling.exchange_iterations)\n"
    "  --proxies P     embed-rigid's proxies: one per soft body (body) or one per element (elements)\n"
    "  --proxy-mass M  element proxies' node weights: physical (masses split, momentum exact) or\n"
    "                  whole-body (seed 001's: each element weighs the whole body)\n"
    "  --workers N     threads for each step, this one included (default 1; results are bit-identical\n"
    "                  for every N)\n"
    "  --record FILE   write every frame's body transforms and particle positions to FILE\n"
    "                  (docs/record-format.md): JSON lines, or float32 frames if FILE ends in .sinrec\n"
    "                  (compact, for large runs); watch it with: scripts/dev view FILE\n"
    "  --record-contacts  also record every frame's contact points and normals (the viewer's overlay)\n"
    "  --save FILE     write the world at the end as a scene file that reproduces it (bodies, joints,\n"
    "                  soft bodies as their particles, velocities; docs/scene-format.md)\n"
    "\n"
    "Progress (steps, rate, time left) is shown on stderr when it is a terminal and CI is not set.\n"
    "\n"
    "Exit status: 0 ok, 1 bad scene or unwritable record, 2 bad arguments, 3 the run was not finite.\n"};

}  // namespace sinew::tool
