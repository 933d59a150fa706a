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
    // The island from the last update_sleep() (a body created since is its own island).
    const std::uint32_t root = find_root(s);
    for (std::uint32_t i = 0; i < slots_.size(); ++i)
        if (slots_.alive(i) && type_[i] == BodyType::Dynamic && awake_[i] && (i == s || find_root(i) == root)) {
            awake_[i] = false;
            sleep_timer_[i] = 0;
            state_.v[i].setZero();
            state_.w[i].setZero();
        }
}

void RigidSystem::update_sleep(Real h) {
    const std::size_t n = slots_.size();
    // Islands: union-find over contacts between two dynamic bodies (static bodies do not join islands).
    for (std::uint32_t s = 0; s < n; ++s) island_[s] = s;
    for (const ContactManifold& c : contacts_) {
        if (c.manifold.count == 0 || type_[c.body_a] != BodyType::Dynamic || type_[c.body_b] != BodyType::Dynamic)
            continue;
        std::uint32_t ra = find_root(c.body_a), rb = find_root(c.body_b);
        if (ra != rb) island_[std::max(ra, rb)] = std::min(ra, rb);
    }
    joints_->for_each_connection([&](std::uint32_t a, std::uint32_t b) {
        if (type_[a] != BodyType::Dynamic || type_[b] != BodyType::Dynamic || !enabled_[a] || !enabled_[b]) return;
        std::uint32_t ra = find_root(a), rb = find_root(b);
        if (ra != rb) island_[std::max(ra, rb)] = std::min(ra, rb);
    });
    const Real lin2 = settings_.sleep_linear_velocity * settings_.sleep_linear_velocity;
    const Real ang2 = settings_.sleep_angular_velocity * settings_.sleep_angular_velocity;
    // Per body: time spent below the thresholds. Per island: the minimum over its bodies.
    island_min_timer_.assign(n, kRealMax);
    island_awake_.assign(n, 0);
    for (std::uint32_t s = 0; s < n; ++s) {
        if (!slots_.alive(s) || type_[s] != BodyType::Dynamic || !enabled_[s]) continue;
        if (awake_[s]) {
            if (!allow_sleep_[s] || state_.v[s].squaredNorm() > lin2 || state_.w[s].squaredNorm() > ang2)
                sleep_timer_[s] = 0;
            else
                sleep_timer_[s] += h;
        }
        std::uint32_t r = find_root(s);
        island_min_timer_[r] = std::min(island_min_timer_[r], awake_[s] ? sleep_timer_[s] : kRealMax);
        island_awake_[r] |= awake_[s] ? 1 : 0;
    }
    for (std::uint32_t s = 0; s < n; ++s) {
        if (!slots_.alive(s) || type_[s] != BodyType::Dynamic || !enabled_[s]) continue;
        std::uint32_t r = find_root(s);
        if (island_awake_[r] && island_min_timer_[r] >= settings_.sleep_time) {
            awake_[s] = false;  // the whole island falls asleep together
            state_.v[s].setZero();
            state_.w[s].setZero();
        } else if (island_awake_[r] && !awake_[s]) {
            awake_[s] = true;   // joined an awake island: nothing may stay asleep in it (no floating)
            sleep_timer_[s] = 0;
        }
    }
}

}  // namespace sinew
