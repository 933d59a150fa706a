// Long-range attachments (Kim, Chentanez & Müller 2012, "Long Range Attachments - A Method to Simulate
// Inextensible Clothing in Computer Games"; seed 004): each free particle may be no further from a pin
// than its rest distance to it along the cloth (to every pin when there are few, else the nearest). Gauss-Seidel relaxation carries a pin's pull down a
// chain of N links only about one link per sweep, so a long pinned cloth stretches under its own weight
// however many iterations it gets; one unilateral constraint per particle to the pin removes that stretch
// in a single pass, at the cost of one distance per particle.
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <queue>
#include <utility>

#include "soft/soft_integrators.hpp"

namespace sinew {

// Up to this many pins every particle is tethered to each of them; above it, to the nearest only.
constexpr std::size_t kMaxTetheredPins = 8;

void build_long_range_attachments(SoftBody& b) {
    b.lra.clear();
    const std::size_t n = b.p.size();
    if (n == 0) return;

    // Adjacency in CSR form. A link limits the distance of its ends to its largest allowed length
    // (rest for an equality link, max_length for an inequality one); links with no finite upper bound
    // (a ragdoll's min-distance links) do not bound the distance and are left out.
    std::vector<std::uint32_t> start(n + 1, 0);
    auto upper = [](const Link& l) { return l.max_length <= 0 ? l.rest : l.max_length; };
    auto usable = [&](const Link& l) {
        const Real u = upper(l);
        return l.a < n && l.b < n && l.a != l.b && is_finite(u) && u > 0 && u < Real(1e12);
    };
    for (const Link& l : b.links)
        if (usable(l)) {
            ++start[l.a + 1];
            ++start[l.b + 1];
        }
    for (std::size_t i = 0; i < n; ++i) start[i + 1] += start[i];
    std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
    std::vector<std::pair<std::uint32_t, double>> adj(start[n]);
    for (const Link& l : b.links)
        if (usable(l)) {
            adj[fill[l.a]++] = {l.b, double(upper(l))};
            adj[fill[l.b]++] = {l.a, double(upper(l))};
        }

    // Dijkstra over the links, in double so a long path of float rest lengths does not drift.
    const double inf = std::numeric_limits<double>::infinity();
    using Entry = std::pair<double, std::uint32_t>;
    std::vector<double> dist(n, inf);
    std::vector<std::uint32_t> anchor(n, 0);
    std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> queue;
    auto run = [&]() {
        while (!queue.empty()) {
            const auto [d, i] = queue.top();
            queue.pop();
            if (d > dist[i]) continue;
            for (std::uint32_t k = start[i]; k < start[i + 1]; ++k) {
                const auto [j, len] = adj[k];
                if (d + len < dist[j]) {
                    dist[j] = d + len;
                    anchor[j] = anchor[i];
                    queue.push({dist[j], j});
                }
            }
        }
    };
    std::vector<std::uint32_t> pins;
    for (std::size_t i = 0; i < n; ++i)
        if (b.p.inv_mass[i] == 0) pins.push_back(std::uint32_t(i));

    if (pins.size() <= kMaxTetheredPins) {
        // Few pins (a cloth held at its corners): tether every particle to every pin. The tether to the
        // nearest pin alone leaves the span between two pins free to sag and stretch (a cloth hung from
        // two corners one edge apart puts all its stretch on the middle of the top edge); the rest
        // configuration satisfies every tether, so adding them never fights the cloth's shape.
        for (std::uint32_t pin : pins) {
            std::fill(dist.begin(), dist.end(), inf);
            dist[pin] = 0;
            anchor[pin] = pin;
            queue.push({0.0, pin});
            run();
            for (std::size_t i = 0; i < n; ++i)
                if (b.p.inv_mass[i] != 0 && dist[i] < inf) b.lra.push_back({std::uint32_t(i), pin, Real(dist[i])});
        }
        // Longest tethers first: each particle's tether to its nearest pin is projected last, so that one
        // holds exactly after every sweep (the far ones can be left slightly violated where two tethers
        // pull apart, e.g. along a straight edge between two pins).
        std::stable_sort(b.lra.begin(), b.lra.end(), [](const LongRangeAttachment& x, const LongRangeAttachment& y) {
            return x.max_length > y.max_length;
        });
        return;
    }
    // Many pins: the nearest one only (seed 004: "upper distance constraint to closest attachment
    // point"), from a multi-source Dijkstra.
    for (std::uint32_t pin : pins) {
        dist[pin] = 0;
        anchor[pin] = pin;
        queue.push({0.0, pin});
    }
    run();
    for (std::size_t i = 0; i < n; ++i)
        if (b.p.inv_mass[i] != 0 && dist[i] < inf)  // free and connected to a pin
            b.lra.push_back({std::uint32_t(i), anchor[i], Real(dist[i])});
}

void apply_long_range_attachments(SoftBody& b) {
    std::vector<Vec3>& x = b.p.x;
    std::vector<Vec3>& v = b.p.v;
    for (const LongRangeAttachment& a : b.lra) {
        if (b.p.inv_mass[a.particle] == 0) continue;  // pinned since the build: nothing to hold
        const Vec3 d = x[a.particle] - x[a.anchor];
        const Real len2 = d.squaredNorm();
        if (len2 <= a.max_length * a.max_length) continue;  // unilateral: slack inside the sphere
        const Real len = std::sqrt(len2);
        const Vec3 dir = d / len;
        x[a.particle] = x[a.anchor] + a.max_length * dir;
        const Real vn = v[a.particle].dot(dir);
        if (vn > 0) v[a.particle] -= vn * dir;  // no velocity out of the sphere
    }
}

}  // namespace sinew
