// One scene under one coupling or embedding variant, recorded, and its errors against a reference
// (tools/compare_runs.hpp).
#include "tools/compare_runs.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "tools/bench/bench_cloth.hpp"  // BenchClock
#include "tools/bench/bench_rigid.hpp"  // median()
#include "tools/record.hpp"

namespace sinew::tool::compare {

std::string Variant::label() const {
    std::ostringstream s;
    s << coupling_strategy_name(strategy);
    if (strategy == CouplingStrategy::Hybrid) s << " gain " << gain;
    if (substeps > 1) s << " x" << substeps << " soft";
    if (exchange > 0) s << " exchange " << exchange;
    if (proxies == EmbedProxies::Elements) {
        s << " elements";
        if (proxy_mass == EmbedProxyMass::WholeBody) s << " whole-body";
    }
    if (divide > 1) s << " h/" << divide;
    return s.str();
}

Recording run_variant(const SceneDesc& scene, const Variant& v, int steps, const std::string& record_path) {
    SceneDesc d = scene;
    d.coupling.settings.tolerance = v.tolerance_in(scene);
    if (v.exchange > 0) d.coupling.settings.exchange_iterations = v.exchange;
    d.coupling.settings.strategy = v.strategy;
    d.coupling.settings.gain = v.gain;
    d.coupling.settings.substeps = v.substeps;
    d.coupling.settings.embed_proxies = v.proxies;
    d.coupling.settings.embed_proxy_mass = v.proxy_mass;
    d.coupling.pairs.clear();  // the variant's strategy for every pair
    d.settings.time_step = scene.settings.time_step / Real(v.divide);
    // Sleeping off: every run does the same work, and a body asleep in one run but not another would be
    // an error of the sleep thresholds, not of the coupling.
    d.settings.rigid.sleeping = false;
    d.settings.soft.sleeping = false;
    std::vector<BodyId> ids;
    const std::unique_ptr<World> w = build_world(d, &ids);
    std::vector<BodyId> dynamic;
    for (std::size_t i = 0; i < ids.size(); ++i)
        if (d.bodies[i].def.type == BodyType::Dynamic) dynamic.push_back(ids[i]);
    const std::vector<SoftBodyId> soft = w->soft().bodies();
    std::unique_ptr<Recorder> recorder;
    if (!record_path.empty()) {
        recorder = std::make_unique<Recorder>(record_path, d, *w, ids, /*contacts=*/true);
        recorder->write_frame(*w, 0);
    }

    Recording r;
    std::vector<double> ms;
    ms.reserve(std::size_t(steps));
    const auto sample = [&] {
        std::vector<Vec3> rb, sn;
        for (BodyId id : dynamic) rb.push_back(w->rigid().state().x[id.index]);
        for (SoftBodyId id : soft) {
            const Particles& p = w->soft().body(id).p;
            sn.insert(sn.end(), p.x.begin(), p.x.end());
        }
        r.rigid.push_back(std::move(rb));
        r.soft.push_back(std::move(sn));
    };
    for (int s = 0; s < steps && r.finite; ++s) {
        double step_ms = 0;
        for (int k = 0; k < v.divide && r.finite; ++k) {
            const double t0 = bench::bench_clock_ms(bench::BenchClock::ThreadCpu);
            w->step();
            step_ms += bench::bench_clock_ms(bench::BenchClock::ThreadCpu) - t0;
            // A blow-up is contained by the step (World::faults) and ends the run as not finite.
            r.finite = w->faults().empty() && w->rigid().all_finite() && w->soft().all_finite();
            r.max_penetration = std::max(r.max_penetration, double(w->rigid().max_penetration()));
            for (const ParticleContact& c : w->soft().contacts()) r.max_penetration = std::max(r.max_penetration, double(c.depth));
            for (const CouplingImpulse& c : w->coupling().impulses()) r.exchanged += c.impulse;
            // Embedded (embed-rigid, or auto's pick), soft bodies push through their proxies' contacts.
            if (w->coupling().embedding().count() > 0)
                w->coupling().embedding().for_each_proxy_contact([&](const RigidEmbedding::ProxyContact& c) {
                    if (w->rigid().slot_type(c.body) == BodyType::Dynamic) r.exchanged += c.normal * c.impulse;
                });
        }
        ms.push_back(step_ms);
        if (r.finite) sample();
        if (recorder) recorder->write_frame(*w, std::uint64_t(s + 1));
    }
    if (recorder) recorder->finish();
    r.picks = w->coupling().picks();
    r.ms_per_step_median = bench::median(ms);
    return r;
}

std::string scene_soft_name(const SceneDesc& scene, SoftBodyId id) {
    return id.index < scene.soft_bodies.size() ? scene.soft_bodies[id.index].name : "soft " + std::to_string(id.index);
}

Errors errors_against(const Recording& run, const Recording& ref) {
    Errors e;
    const std::size_t samples = std::min(run.rigid.size(), ref.rigid.size());
    double rigid_sum = 0, soft_sum = 0;
    std::size_t rigid_n = 0, soft_n = 0;
    for (std::size_t s = 0; s < samples; ++s) {
        const bool last = s + 1 == samples;
        for (std::size_t b = 0; b < run.rigid[s].size() && b < ref.rigid[s].size(); ++b) {
            const double d = double((run.rigid[s][b] - ref.rigid[s][b]).norm());
            rigid_sum += d * d;
            ++rigid_n;
            e.rigid_max = std::max(e.rigid_max, d);
            if (last) e.final_max = std::max(e.final_max, d);
        }
        for (std::size_t i = 0; i < run.soft[s].size() && i < ref.soft[s].size(); ++i) {
            const double d = double((run.soft[s][i] - ref.soft[s][i]).norm());
            soft_sum += d * d;
            ++soft_n;
            e.soft_max = std::max(e.soft_max, d);
            if (last) e.final_max = std::max(e.final_max, d);
        }
    }
    e.rigid_rms = rigid_n ? std::sqrt(rigid_sum / double(rigid_n)) : 0;
    e.soft_rms = soft_n ? std::sqrt(soft_sum / double(soft_n)) : 0;
    e.position_rms = rigid_n + soft_n ? std::sqrt((rigid_sum + soft_sum) / double(rigid_n + soft_n)) : 0;
    const double jref = double(ref.exchanged.norm());
    e.exchanged = jref > 0 ? double((run.exchanged - ref.exchanged).norm()) / jref : 0;
    return e;
}

}  // namespace sinew::tool::compare
