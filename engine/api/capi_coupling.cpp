// The C API's coupling settings (sinew.h, "How rigid and soft bodies act on each other"): the world's
// strategy and per-pair overrides, through World::set_coupling (coupling/coupling_layer.hpp).
#include <algorithm>
#include <limits>
#include <string>

#include "engine/api/capi_internal.hpp"

using namespace sinew;
using namespace sinew::capi;

namespace {

// From the enum's int value (enum_value reads the argument's bytes: loading an out-of-range value into
// the enum type, as passing it by value would, is undefined behaviour in C++).
bool strategy_of(int c, CouplingStrategy& out) {
    switch (c) {
        case SINEW_COUPLING_ONE_WAY: out = CouplingStrategy::OneWay; return true;
        case SINEW_COUPLING_TWO_WAY: out = CouplingStrategy::TwoWay; return true;
        case SINEW_COUPLING_HYBRID: out = CouplingStrategy::Hybrid; return true;
        case SINEW_COUPLING_INTERLEAVED: out = CouplingStrategy::Interleaved; return true;
        case SINEW_COUPLING_ONE_SOLVER: out = CouplingStrategy::OneSolver; return true;
        case SINEW_COUPLING_EMBED_RIGID: out = CouplingStrategy::EmbedRigid; return true;
        case SINEW_COUPLING_EMBED_FEM: out = CouplingStrategy::EmbedFem; return true;
        case SINEW_COUPLING_AUTO: out = CouplingStrategy::Auto; return true;
        default: return false;
    }
}

// The soft body `soft` names in world `w` (SINEW_ERROR_STALE_ID if none).
sinew_status soft_of(World* w, sinew_world_id world, sinew_soft_body_id soft, const char* fn, SoftBodyId& out) {
    out = SoftBodyId{soft.index, soft.generation};
    if (soft.world != pack_world(world) || !w->soft().valid(out))
        return fail(SINEW_ERROR_STALE_ID, std::string(fn) + ": soft body {index " + std::to_string(soft.index) +
                                              ", generation " + std::to_string(soft.generation) +
                                              "} is null, destroyed or not in this world");
    return SINEW_OK;
}

// The rigid body `rigid` names in world `w`, or a null id for the null handle ("every rigid body").
sinew_status rigid_of(World* w, sinew_body_id rigid, const char* fn, BodyId& out) {
    out = BodyId{};
    if (rigid.generation == 0) return SINEW_OK;
    World* owner = nullptr;
    out = find_body(rigid, fn, &owner);
    if (out.is_null()) return SINEW_ERROR_STALE_ID;
    if (owner != w) return invalid(fn, "the rigid body is not in this world");
    return SINEW_OK;
}

}  // namespace

sinew_status sinew_world_set_coupling(sinew_world_id world, sinew_coupling strategy, float gain) {
    const char* fn = "sinew_world_set_coupling";
    return guarded(fn, [&] {
        World* w = find_world(world, fn);
        if (!w) return SINEW_ERROR_STALE_ID;
        if (sinew_status s = check_not_stepping(w, fn)) return s;
        CouplingSettings c = w->coupling().settings();
        if (!strategy_of(enum_value(strategy), c.strategy))
            return invalid(fn, "strategy = " + std::to_string(enum_value(strategy)) + " is not a sinew_coupling");
        c.gain = Real(gain);
        w->set_coupling(c);  // CouplingError names a bad gain; nothing changes then
        return SINEW_OK;
    });
}

sinew_status sinew_world_get_coupling(sinew_world_id world, sinew_coupling* strategy) {
    const char* fn = "sinew_world_get_coupling";
    return guarded(fn, [&] {
        if (!strategy) return null_arg(fn, "strategy");
        World* w = find_world(world, fn);
        if (!w) return SINEW_ERROR_STALE_ID;
        *strategy = static_cast<sinew_coupling>(int(w->coupling().settings().strategy));
        return SINEW_OK;
    });
}

sinew_status sinew_world_set_coupling_tolerance(sinew_world_id world, float meters) {
    const char* fn = "sinew_world_set_coupling_tolerance";
    return guarded(fn, [&] {
        World* w = find_world(world, fn);
        if (!w) return SINEW_ERROR_STALE_ID;
        if (sinew_status s = check_not_stepping(w, fn)) return s;
        CouplingSettings c = w->coupling().settings();
        c.tolerance = Real(meters);
        w->set_coupling(c);  // CouplingError names a tolerance out of range; nothing changes then
        return SINEW_OK;
    });
}

sinew_status sinew_world_set_coupling_steps(sinew_world_id world, int substeps, int exchange_iterations) {
    const char* fn = "sinew_world_set_coupling_steps";
    return guarded(fn, [&] {
        World* w = find_world(world, fn);
        if (!w) return SINEW_ERROR_STALE_ID;
        if (sinew_status s = check_not_stepping(w, fn)) return s;
        CouplingSettings c = w->coupling().settings();
        c.substeps = substeps;
        c.exchange_iterations = exchange_iterations;
        w->set_coupling(c);  // CouplingError names a count out of range or sub-steps a strategy cannot take
        return SINEW_OK;
    });
}

sinew_status sinew_world_get_coupling_steps(sinew_world_id world, int* substeps, int* exchange_iterations) {
    const char* fn = "sinew_world_get_coupling_steps";
    return guarded(fn, [&] {
        if (!substeps) return null_arg(fn, "substeps");
        if (!exchange_iterations) return null_arg(fn, "exchange_iterations");
        World* w = find_world(world, fn);
        if (!w) return SINEW_ERROR_STALE_ID;
        *substeps = w->coupling().settings().substeps;
        *exchange_iterations = w->coupling().settings().exchange_iterations;
        return SINEW_OK;
    });
}

sinew_status sinew_world_set_embed_proxies(sinew_world_id world, sinew_embed_proxies proxies, sinew_embed_mass mass) {
    const char* fn = "sinew_world_set_embed_proxies";
    return guarded(fn, [&] {
        World* w = find_world(world, fn);
        if (!w) return SINEW_ERROR_STALE_ID;
        if (sinew_status s = check_not_stepping(w, fn)) return s;
        // Compared as ints: a value out of the enum's range is not loaded as one (it would be undefined).
        const int p = enum_value(proxies), m = enum_value(mass);
        if (p < 0 || p >= int(EmbedProxies::Count))
            return invalid(fn, "proxies = " + std::to_string(p) + " is not SINEW_EMBED_BODY (0) or SINEW_EMBED_ELEMENTS (1)");
        if (m < 0 || m >= int(EmbedProxyMass::Count))
            return invalid(fn, "mass = " + std::to_string(m) +
                                   " is not SINEW_EMBED_MASS_PHYSICAL (0) or SINEW_EMBED_MASS_WHOLE_BODY (1)");
        CouplingSettings c = w->coupling().settings();
        c.embed_proxies = EmbedProxies(p);
        c.embed_proxy_mass = EmbedProxyMass(m);
        w->set_coupling(c);
        return SINEW_OK;
    });
}

sinew_status sinew_world_get_soft_element_proxies(sinew_world_id world, sinew_soft_body_id soft, sinew_body_id* out,
                                                  int capacity, int* count) {
    const char* fn = "sinew_world_get_soft_element_proxies";
    return guarded(fn, [&] {
        if (!count) return null_arg(fn, "count");
        if (capacity < 0) return invalid(fn, "capacity = " + std::to_string(capacity) + " must be >= 0");
        if (!out && capacity > 0) return null_arg(fn, "out");
        World* w = find_world(world, fn);
        if (!w) return SINEW_ERROR_STALE_ID;
        SoftBodyId id;
        if (sinew_status st = soft_of(w, world, soft, fn, id)) return st;
        if (sinew_status st = check_not_stepping(w, fn)) return st;  // proxies may be made or dropped
        w->coupling().refresh_embedding();  // a body created or pinned since the last step has its proxies now
        const std::vector<BodyId>& proxies = w->coupling().embedding().element_proxies(id);
        const std::size_t n = std::min(proxies.size(), std::size_t(capacity));
        for (std::size_t k = 0; k < n; ++k) out[k] = {pack_world(world), proxies[k].index, proxies[k].generation};
        *count = int(std::min(proxies.size(), std::size_t(std::numeric_limits<int>::max())));
        return SINEW_OK;
    });
}

sinew_status sinew_world_get_pair_coupling(sinew_world_id world, sinew_soft_body_id soft, sinew_body_id rigid,
                                           sinew_coupling* strategy) {
    const char* fn = "sinew_world_get_pair_coupling";
    return guarded(fn, [&] {
        if (!strategy) return null_arg(fn, "strategy");
        World* w = find_world(world, fn);
        if (!w) return SINEW_ERROR_STALE_ID;
        SoftBodyId id;
        if (sinew_status st = soft_of(w, world, soft, fn, id)) return st;
        BodyId rid;
        if (sinew_status st = rigid_of(w, rigid, fn, rid)) return st;
        *strategy = static_cast<sinew_coupling>(int(w->coupling().strategy(id, rid)));
        return SINEW_OK;
    });
}

sinew_status sinew_world_set_pair_coupling(sinew_world_id world, sinew_soft_body_id soft, sinew_body_id rigid,
                                           sinew_coupling strategy) {
    const char* fn = "sinew_world_set_pair_coupling";
    return guarded(fn, [&] {
        World* w = find_world(world, fn);
        if (!w) return SINEW_ERROR_STALE_ID;
        if (sinew_status s = check_not_stepping(w, fn)) return s;
        CouplingPair pair;
        if (!strategy_of(enum_value(strategy), pair.strategy))
            return invalid(fn, "strategy = " + std::to_string(enum_value(strategy)) + " is not a sinew_coupling");
        if (sinew_status st = soft_of(w, world, soft, fn, pair.soft)) return st;
        if (sinew_status st = rigid_of(w, rigid, fn, pair.rigid)) return st;
        CouplingSettings c = w->coupling().settings();
        // A later call for the same pair replaces the earlier one.
        for (std::size_t k = 0; k < c.pairs.size();)
            if (c.pairs[k].soft == pair.soft && c.pairs[k].rigid == pair.rigid)
                c.pairs.erase(c.pairs.begin() + std::ptrdiff_t(k));
            else
                ++k;
        c.pairs.push_back(pair);
        w->set_coupling(c);
        return SINEW_OK;
    });
}

sinew_status sinew_world_get_soft_proxy(sinew_world_id world, sinew_soft_body_id soft, sinew_body_id* out) {
    const char* fn = "sinew_world_get_soft_proxy";
    return guarded(fn, [&] {
        if (!out) return null_arg(fn, "out");
        World* w = find_world(world, fn);
        if (!w) return SINEW_ERROR_STALE_ID;
        SoftBodyId id;
        if (sinew_status st = soft_of(w, world, soft, fn, id)) return st;
        if (sinew_status s = check_not_stepping(w, fn)) return s;  // a proxy may be made or dropped
        // A body created since the last step has its proxy now; under auto a joint is to hold it, so it
        // is embedded.
        w->coupling().need_proxy(id);
        const BodyId proxy = w->coupling().embedding().proxy(id);
        if (proxy.is_null() && w->coupling().embedding().embedded_by_elements(id))
            return invalid(fn, "soft body {index " + std::to_string(soft.index) +
                                   "} is embedded with one proxy per element (SINEW_EMBED_ELEMENTS): it has no "
                                   "whole-body proxy (sinew_world_get_soft_element_proxies lists the elements')");
        if (proxy.is_null())
            return invalid(fn, "soft body {index " + std::to_string(soft.index) +
                                   "} is not embedded (its coupling strategy is not SINEW_COUPLING_EMBED_RIGID)");
        *out = {pack_world(world), proxy.index, proxy.generation};
        return SINEW_OK;
    });
}
