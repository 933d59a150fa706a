// Long-range attachments (Kim, Chentanez & Müller 2012, "Long Range Attachments - A Method to Simulate
// Inextensible Clothing in Computer Games"; seed 004): each free particle may be no further from its
// nearest pin than its rest distance along the cloth. Gauss-Seidel relaxation carries a pin's pull down a
// chain of N links only about one link per sweep, so a long pinned cloth stretches under its own weight
// however many iterations it gets; one unilateral constraint per particle to the pin removes that stretch
// in a single pass, at the cost of one distance per particle.
#include <cmath>
#include <functional>
#include <limits>
#include <queue>
#include <utility>

#include "soft/soft_integrators.hpp"

namespace sinew {

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

    // Multi-source Dijkstra from every pinned particle at once: each particle ends with the distance to
    // its nearest pin along the links and which pin that is. Distances in double so a long path of float
    // rest lengths does not drift.
    const double inf = std::numeric_limits<double>::infinity();
    std::vector<double> dist(n, inf);
    std::vector<std::uint32_t> anchor(n, 0);
    using Entry = std::pair<double, std::uint32_t>;
    std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> queue;
    for (std::size_t i = 0; i < n; ++i)
        if (b.p.inv_mass[i] == 0) {
            dist[i] = 0;
            anchor[i] = std::uint32_t(i);
            queue.push({0.0, std::uint32_t(i)});
        }
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
