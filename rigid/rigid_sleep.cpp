// Islands and sleeping (seed 001 ch.2): bodies connected by contacts and joints sleep together once all
// have stayed slow for the sleep time, and wake together.
#include "rigid/rigid_system.hpp"

#include <algorithm>
#include <string>

#include "rigid/joint_set.hpp"

namespace sinew {

// ---- islands and sleeping (seed 001 ch.2) -----------------------------------------------------------

std::uint32_t RigidSystem::find_root(std::uint32_t s) {
    while (island_[s] != s) {
        island_[s] = island_[island_[s]];  // path halving
        s = island_[s];
    }
    return s;
}

void RigidSystem::wake_island(std::uint32_t s) {
    if (type_[s] != BodyType::Dynamic || !enabled_[s]) return;  // a disabled body stays out until enabled
    if (awake_[s]) {  // an awake body's island is awake (update_sleep keeps islands uniform)
        sleep_timer_[s] = 0;
        return;
    }
    // Islands are from the last update_sleep(); waking is rare, so a linear scan is fine.
    active_stale_ = true;  // between detection and the solve, the island's manifolds join this step's
    std::uint32_t root = find_root(s);
    for (std::uint32_t i = 0; i < slots_.size(); ++i)
        if (slots_.alive(i) && type_[i] == BodyType::Dynamic && !awake_[i] && enabled_[i] && find_root(i) == root) {
            awake_[i] = true;
            sleep_timer_[i] = 0;
            // Woken mid-step: it takes part in this step's solve with its real mass.
            Mat3 r = state_.q[i].toRotationMatrix();
            state_.inv_mass[i] = body_inv_mass_[i];
            state_.inv_inertia_world[i] = r * inv_inertia_local_[i] * r.transpose();
        }
}

void RigidSystem::sleep(BodyId id) {
    check(id, "sleep");
    const std::uint32_t s = id.index;
    if (type_[s] != BodyType::Dynamic)
        throw RigidError(std::string("sleep: only dynamic bodies sleep, body {index ") + std::to_string(s) + "} is " +
                         body_type_name(type_[s]));
    if (!awake_[s]) return;  // its island sleeps already
    // The island from the last update_sleep() (a body created since is its own island).
    const std::uint32_t root = find_root(s);
    std::vector<std::uint32_t> members;
    for (std::uint32_t i = 0; i < slots_.size(); ++i)
        if (slots_.alive(i) && type_[i] == BodyType::Dynamic && awake_[i] && (i == s || find_root(i) == root))
            members.push_back(i);
    // A sleeping island keeps its union-find links until it wakes: linked to s itself, not through a
    // slot (the last root) that may since have been destroyed, disabled or turned static.
    for (const std::uint32_t i : members) {
        awake_[i] = false;
        sleep_timer_[i] = 0;
        state_.v[i].setZero();
        state_.w[i].setZero();
        island_[i] = s;
    }
}

void RigidSystem::update_sleep(Real h) {
    refresh_active_contacts();  // a hook may have woken an island since detection
    const std::size_t n = slots_.size();
    auto counts = [&](std::uint32_t s) { return slots_.alive(s) && type_[s] == BodyType::Dynamic && enabled_[s]; };
    // A joint from an awake body to a sleeping one wakes the sleeping island: nothing in an awake island
    // may stay asleep (no floating).
    joints_->for_each_connection([&](std::uint32_t a, std::uint32_t b) {
        if (type_[a] != BodyType::Dynamic || type_[b] != BodyType::Dynamic || !enabled_[a] || !enabled_[b]) return;
        if (awake_[a] != awake_[b]) wake_island(awake_[a] ? b : a);
    });
    // Islands of the awake bodies: union-find over contacts and joints between two awake dynamic bodies
    // (static bodies join no island). A sleeping island keeps the links it fell asleep with, so its
    // bodies and contacts cost nothing here: a contact from an awake body to a sleeping one woke that
    // island in detection, and a joint just above.
    for (std::uint32_t s = 0; s < n; ++s)
        if (awake_[s] && counts(s)) island_[s] = s;
    auto join = [&](std::uint32_t a, std::uint32_t b) {
        const std::uint32_t ra = find_root(a), rb = find_root(b);
        if (ra != rb) island_[std::max(ra, rb)] = std::min(ra, rb);
    };
    for (const std::uint32_t ci : active_contacts_) {
        const ContactManifold& c = contacts_[ci];
        if (c.manifold.count == 0 || type_[c.body_a] != BodyType::Dynamic || type_[c.body_b] != BodyType::Dynamic ||
            !awake_[c.body_a] || !awake_[c.body_b])
            continue;
        join(c.body_a, c.body_b);
    }
    joints_->for_each_connection([&](std::uint32_t a, std::uint32_t b) {
        if (type_[a] != BodyType::Dynamic || type_[b] != BodyType::Dynamic || !enabled_[a] || !enabled_[b]) return;
        if (awake_[a] && awake_[b]) join(a, b);
    });
    const Real lin2 = settings_.sleep_linear_velocity * settings_.sleep_linear_velocity;
    const Real ang2 = settings_.sleep_angular_velocity * settings_.sleep_angular_velocity;
    // Per body: time spent below the thresholds. Per island: the minimum over its bodies (kept at the
    // root, an awake body's slot).
    island_min_timer_.resize(n);
    for (std::uint32_t s = 0; s < n; ++s)
        if (awake_[s] && counts(s)) island_min_timer_[s] = kRealMax;
    for (std::uint32_t s = 0; s < n; ++s) {
        if (!awake_[s] || !counts(s)) continue;
        if (!allow_sleep_[s] || state_.v[s].squaredNorm() > lin2 || state_.w[s].squaredNorm() > ang2)
            sleep_timer_[s] = 0;
        else
            sleep_timer_[s] += h;
        const std::uint32_t r = find_root(s);
        island_min_timer_[r] = std::min(island_min_timer_[r], sleep_timer_[s]);
    }
    for (std::uint32_t s = 0; s < n; ++s) {
        if (!awake_[s] || !counts(s)) continue;
        if (island_min_timer_[find_root(s)] >= settings_.sleep_time) {
            awake_[s] = false;  // the whole island falls asleep together
            state_.v[s].setZero();
            state_.w[s].setZero();
        }
    }
}

}  // namespace sinew
