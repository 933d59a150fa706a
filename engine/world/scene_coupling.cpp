// The "coupling" section of scene files (docs/scene-format.md, "Coupling"): the world's strategy, its
// settings, and overrides per soft-rigid pair naming the bodies.
#include <unordered_map>

#include "engine/world/scene_json.hpp"

namespace sinew::scene_json {

namespace {
CouplingStrategy read_strategy(const Node& obj, const char* key, CouplingStrategy fallback) {
    return read_enum_named(obj, key, fallback, int(CouplingStrategy::Count), coupling_strategy_name);
}
}  // namespace

void parse_coupling(const Node& node, SceneDesc& desc) {
    // Files written before the section existed may hold the reserved empty array: the default, one-way.
    if (node.json().is_array() && node.json().empty()) return;
    node.expect_object();
    node.allow_keys({"strategy", "exchange_iterations", "gain", "substeps", "tolerance", "proxies", "proxy_mass", "pairs",
                     "compare_reference"});
    desc.coupling.compare_reference = read_strategy(node, "compare_reference", desc.coupling.compare_reference);
    if (desc.coupling.compare_reference == CouplingStrategy::Auto)
        node.get("compare_reference").fail("the reference must be a strategy that runs as it is, not \"auto\"");
    CouplingSettings& s = desc.coupling.settings;
    s.strategy = read_strategy(node, "strategy", s.strategy);
    s.exchange_iterations = read_int(node, "exchange_iterations", s.exchange_iterations, 1, 100);
    s.gain = read_real(node, "gain", s.gain, Range::UnitInterval);
    s.substeps = read_int(node, "substeps", s.substeps, 1, 64);
    if (std::optional<Node> t = node.find("tolerance")) {
        s.tolerance = checked(*t, Range::Positive);
        if (s.tolerance > kMaxCouplingTolerance) t->fail("tolerance must be in (0, 1000] m, got " + t->json().dump());
    }
    s.embed_proxies = read_enum_named(node, "proxies", s.embed_proxies, int(EmbedProxies::Count), embed_proxies_name);
    s.embed_proxy_mass =
        read_enum_named(node, "proxy_mass", s.embed_proxy_mass, int(EmbedProxyMass::Count), embed_proxy_mass_name);
    if (s.substeps > 1 && s.strategy != CouplingStrategy::OneWay && s.strategy != CouplingStrategy::Hybrid)
        node.get("substeps").fail("substeps = " + std::to_string(s.substeps) + " needs the one-way or hybrid strategy, got \"" +
                                  coupling_strategy_name(s.strategy) + "\"");
    std::optional<Node> pairs = node.find("pairs");
    if (!pairs) return;
    std::unordered_map<std::string, std::size_t> soft_index, rigid_index;
    for (std::size_t i = 0; i < desc.soft_bodies.size(); ++i) soft_index.emplace(desc.soft_bodies[i].name, i);
    for (std::size_t i = 0; i < desc.bodies.size(); ++i) rigid_index.emplace(desc.bodies[i].name, i);
    const std::size_t count = pairs->array_size();
    for (std::size_t k = 0; k < count; ++k) {
        const Node p = pairs->item(k);
        p.allow_keys({"soft", "rigid", "strategy"});
        SceneCoupling::Pair out;
        out.json_path = p.path();
        const Node soft = p.get("soft");
        const auto si = soft_index.find(soft.string());
        if (si == soft_index.end()) soft.fail("unknown soft body \"" + soft.string() + "\"");
        out.soft = si->second;
        if (std::optional<Node> rigid = p.find("rigid")) {
            const auto ri = rigid_index.find(rigid->string());
            if (ri == rigid_index.end()) rigid->fail("unknown body \"" + rigid->string() + "\"");
            out.every_rigid = false;
            out.rigid = ri->second;
        }
        out.strategy = read_strategy(p, "strategy", CouplingStrategy::Count);
        if (out.strategy == CouplingStrategy::Count) p.get("strategy");  // required: fails naming it
        if (out.strategy == CouplingStrategy::Auto)
            p.get("strategy").fail("\"auto\" is a world strategy (it picks per soft body); a pair names the strategy it wants");
        desc.coupling.pairs.push_back(out);
    }
}

}  // namespace sinew::scene_json
