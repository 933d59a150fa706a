#include "coupling/coupling_settings.hpp"

#include <cmath>

#include "engine/core/format.hpp"

namespace sinew {

namespace {
const char* const kNames[] = {"one-way", "two-way", "hybrid", "interleaved", "one-solver", "embed-rigid", "embed-fem", "auto"};
static_assert(sizeof(kNames) / sizeof(kNames[0]) == std::size_t(CouplingStrategy::Count), "one name per strategy");
const char* const kProxyNames[] = {"body", "elements"};
const char* const kProxyMassNames[] = {"physical", "whole-body"};
static_assert(sizeof(kProxyNames) / sizeof(kProxyNames[0]) == std::size_t(EmbedProxies::Count), "one name each");
static_assert(sizeof(kProxyMassNames) / sizeof(kProxyMassNames[0]) == std::size_t(EmbedProxyMass::Count), "one name each");

template <class E, std::size_t N>
bool parse_name(const std::string& text, const char* const (&names)[N], E& out) {
    for (std::size_t i = 0; i < N; ++i)
        if (text == names[i]) {
            out = E(i);
            return true;
        }
    return false;
}
}  // namespace

const char* embed_proxies_name(EmbedProxies p) {
    return std::size_t(p) < std::size_t(EmbedProxies::Count) ? kProxyNames[std::size_t(p)] : "unknown";
}
bool parse_embed_proxies(const std::string& text, EmbedProxies& out) { return parse_name(text, kProxyNames, out); }
const char* embed_proxy_mass_name(EmbedProxyMass m) {
    return std::size_t(m) < std::size_t(EmbedProxyMass::Count) ? kProxyMassNames[std::size_t(m)] : "unknown";
}
bool parse_embed_proxy_mass(const std::string& text, EmbedProxyMass& out) {
    return parse_name(text, kProxyMassNames, out);
}

const char* coupling_strategy_name(CouplingStrategy s) {
    const auto i = std::size_t(s);
    return i < std::size_t(CouplingStrategy::Count) ? kNames[i] : "unknown";
}

bool parse_coupling_strategy(const std::string& text, CouplingStrategy& out) {
    for (std::size_t i = 0; i < std::size_t(CouplingStrategy::Count); ++i)
        if (text == kNames[i]) {
            out = CouplingStrategy(i);
            return true;
        }
    return false;
}

std::string coupling_strategy_list() {
    std::string out;
    for (std::size_t i = 0; i < std::size_t(CouplingStrategy::Count); ++i) {
        if (i) out += ", ";
        out += kNames[i];
    }
    return out;
}

std::string coupling_settings_problem(const CouplingSettings& s) {
    if (std::size_t(s.strategy) >= std::size_t(CouplingStrategy::Count))
        return "coupling strategy " + std::to_string(int(s.strategy)) + " is unknown (known: " +
               coupling_strategy_list() + ")";
    if (s.exchange_iterations < 1 || s.exchange_iterations > 100)
        return "coupling exchange_iterations must be in [1, 100], got " + std::to_string(s.exchange_iterations);
    if (!std::isfinite(s.gain) || s.gain < 0 || s.gain > 1)
        return "coupling gain must be in [0, 1], got " + to_text(s.gain);
    if (s.substeps < 1 || s.substeps > 64)
        return "coupling substeps must be in [1, 64], got " + std::to_string(s.substeps);
    if (!std::isfinite(s.tolerance) || s.tolerance <= 0 || s.tolerance > kMaxCouplingTolerance)
        return "coupling tolerance must be in (0, 1000] m, got " + to_text(s.tolerance);
    if (std::size_t(s.embed_proxies) >= std::size_t(EmbedProxies::Count))
        return "coupling proxies " + std::to_string(int(s.embed_proxies)) + " is unknown (known: body, elements)";
    if (std::size_t(s.embed_proxy_mass) >= std::size_t(EmbedProxyMass::Count))
        return "coupling proxy_mass " + std::to_string(int(s.embed_proxy_mass)) +
               " is unknown (known: physical, whole-body)";
    if (s.strategy == CouplingStrategy::Auto && s.substeps > 1)
        return "coupling substeps = " + std::to_string(s.substeps) +
               " cannot go with the strategy \"auto\" (it picks two-way or embedding where the soft body pushes "
               "back; those exchange within one step of both systems)";
    if (s.substeps > 1) {
        const auto passive = [](CouplingStrategy c) { return c == CouplingStrategy::OneWay || c == CouplingStrategy::Hybrid; };
        bool ok = passive(s.strategy);
        for (const CouplingPair& p : s.pairs) ok = ok && passive(p.strategy);
        if (!ok)
            return "coupling substeps = " + std::to_string(s.substeps) +
                   " needs one-way or hybrid coupling for every pair (two-way, interleaved, one-solver, "
                   "embed-rigid and embed-fem exchange within one step of both systems)";
    }
    for (std::size_t k = 0; k < s.pairs.size(); ++k) {
        const CouplingPair& p = s.pairs[k];
        if (std::size_t(p.strategy) >= std::size_t(CouplingStrategy::Count))
            return "coupling pair " + std::to_string(k) + ": strategy " + std::to_string(int(p.strategy)) +
                   " is unknown (known: " + coupling_strategy_list() + ")";
        if (p.strategy == CouplingStrategy::Auto)
            return "coupling pair " + std::to_string(k) +
                   ": \"auto\" is a world strategy (it picks per soft body); a pair names the strategy it wants";
        if (p.soft.is_null()) return "coupling pair " + std::to_string(k) + ": no soft body";
        if (p.strategy == CouplingStrategy::EmbedRigid && !p.rigid.is_null())
            return "coupling pair " + std::to_string(k) +
                   ": embed-rigid embeds the whole soft body (its proxy meets every rigid body): name no rigid body";
    }
    return {};
}

}  // namespace sinew

namespace sinew {

CouplingStrategy coupling_strategy_of(const CouplingSettings& settings, SoftBodyId soft, BodyId rigid) {
    CouplingStrategy out = settings.strategy;
    bool exact = false;
    for (const CouplingPair& p : settings.pairs) {
        if (p.soft != soft) continue;
        if (p.rigid.is_null()) {
            if (!exact) out = p.strategy;
        } else if (p.rigid == rigid) {
            out = p.strategy;
            exact = true;
        }
    }
    return out;
}

}  // namespace sinew
