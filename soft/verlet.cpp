// Jakobsen 2003 ("Advanced Character Physics"): position Verlet with drag, then Gauss-Seidel relaxation of
// the links as distance constraints, each sweep followed by collision projection and long-range
// attachments. Equations: Jakobsen 2003; docs/theory.md#verlet.
//
// Verlet's x_{n+1} = x_n + (1 - k_d)(x_n - x_{n-1}) + a h^2 is written with the velocity field the other
// integrators share, v_n = (x_n - x_{n-1}) / h, so bodies can switch method, be woken, or get velocities
// from collisions (ParticleCollision::finish edits v) without a stale x_{n-1}. The velocity of the next
// step is read back from the positions at the end: v_{n+1} = (x_{n+1} - x_n) / h, which carries the
// constraint and collision corrections into the momentum, as Verlet does implicitly.
#include <algorithm>
#include <cmath>
#include <string>

#include "engine/core/bucket_sort.hpp"
#include "engine/core/task_system.hpp"
#include "soft/particle_collision.hpp"
#include "soft/soft_integrators.hpp"

namespace sinew {

namespace {

// Below this length the direction of a link is undefined; the link is skipped for the sweep (the next
// sweep, after the neighbours moved, usually separates the particles). 1e-9 m is far below any rest length.
constexpr Real kMinLinkLength = Real(1e-9);

// One relaxation sweep over the links in order (Gauss-Seidel; Jakobsen 2003, docs/theory.md#verlet):
//   d = x_b - x_a, s = k (|d| - L)/|d|, x_a += s w_a/(w_a + w_b) d, x_b -= s w_b/(w_a + w_b) d,
// with L the rest length for an equality link, or the violated bound for an inequality link (which acts
// only outside [min_length, max_length]: Jakobsen's angle limits).
void relax_link(const Link& l, std::vector<Vec3>& x, const std::vector<Real>& w, int iteration) {
    if (l.max_iterations != 0 && iteration >= int(l.max_iterations)) return;  // softer link
    const Real wa = w[l.a], wb = w[l.b];
    const Real wsum = wa + wb;
    if (wsum <= 0) return;  // both ends pinned
    const Vec3 d = x[l.b] - x[l.a];
    const Real len = d.norm();
    if (len < kMinLinkLength) return;
    // A link whose bounds were never set (both 0) is an equality constraint at its rest length.
    Real lo = l.min_length, hi = l.max_length;
    if (hi <= 0) lo = hi = l.rest;
    Real target;
    if (len > hi)
        target = hi;
    else if (len < lo)
        target = lo;
    else
        return;  // inside the allowed range (always false for equality: lo == hi)
    const Real s = l.fraction * (len - target) / (len * wsum);
    x[l.a] += (s * wa) * d;
    x[l.b] -= (s * wb) * d;
}

// One relaxation sweep over the links in order (Gauss-Seidel). Builders emit links row by row from the
// first row, where cloths are pinned, so a forward sweep carries a pin's pull down the cloth in one pass.
// (Alternating forward and backward sweeps, symmetric Gauss-Seidel, was measured worse: the hanging
// cloth-64 without LRA ended at max_stretch 11.5 instead of 7.8, a 20-segment rope at h = 1/120 at 1.0%
// instead of 0.9%.)
void relax_links(SoftBody& b, int iteration) {
    std::vector<Vec3>& x = b.p.x;
    const std::vector<Real>& w = b.p.inv_mass;
    for (const Link& l : b.links) relax_link(l, x, w, iteration);
}

// Greedy colouring of the links in builder order (each link takes the least colour neither end's links
// have yet: a cloth's structural and shear links take 8-10), kept by colour in ascending link order.
// Links past the 64th colour (a particle with more than 32 links) go to one last group run on one thread.
void colour_links(SoftBody& b) {
    const std::size_t m = b.links.size();
    b.coloured_ends.resize(2 * m);
    for (std::size_t j = 0; j < m; ++j) b.coloured_ends[2 * j] = b.links[j].a, b.coloured_ends[2 * j + 1] = b.links[j].b;
    std::vector<std::uint64_t> used(b.p.size(), 0);
    std::vector<std::uint8_t> colour(m);
    int colours = 0;
    for (std::size_t j = 0; j < m; ++j) {
        const Link& l = b.links[j];
        const std::uint64_t free = ~(used[l.a] | used[l.b]);
        int c = 64;  // the serial group
        if (free != 0) {
            c = 0;
            while (!((free >> c) & 1u)) ++c;
            used[l.a] |= std::uint64_t(1) << c;
            used[l.b] |= std::uint64_t(1) << c;
        }
        colour[j] = std::uint8_t(c);
        colours = std::max(colours, c + 1);
    }
    std::vector<std::uint32_t> fill;
    bucket_sort(m, std::size_t(colours), [&](std::size_t j) { return colour[j]; }, b.colour_start, b.colour_links, fill);
}

// One sweep colour by colour. No two links of a colour share a particle, so a colour's links may run in
// any order or at once: a large body's colours are split among the workers (SoftBody::region), each
// giving the bits of one thread. The serial group (colour 64) runs last, on this thread.
// Whether the colouring was built for the body's links as they are now (a link's ends may have been
// edited between steps; two links of a colour sharing a particle would race on the workers).
bool colouring_current(const SoftBody& b) {
    const std::size_t m = b.links.size();
    if (b.colour_start.empty() || b.colour_links.size() != m || b.coloured_ends.size() != 2 * m) return false;
    for (std::size_t j = 0; j < m; ++j)
        if (b.coloured_ends[2 * j] != b.links[j].a || b.coloured_ends[2 * j + 1] != b.links[j].b) return false;
    return true;
}

void relax_links_by_colour(SoftBody& b, int iteration) {
    std::vector<Vec3>& x = b.p.x;
    const std::vector<Real>& w = b.p.inv_mass;
    const std::size_t colours = b.colour_start.size() - 1;
    for (std::size_t c = 0; c < colours; ++c) {
        const std::uint32_t first = b.colour_start[c], count = b.colour_start[c + 1] - first;
        ParallelRegion* region = c < 64 && count >= 1024 ? b.region : nullptr;
        for_ranges(region, count, 256, [&](std::size_t begin, std::size_t end) {
            for (std::size_t k = begin; k < end; ++k) relax_link(b.links[b.colour_links[first + k]], x, w, iteration);
        });
    }
}

}  // namespace

void predict_verlet(SoftBody& b, Real h) {
    if (!(is_finite(h) && h > 0)) throw SoftError("step_verlet: time step h must be finite and > 0, got " + std::to_string(h));
    Particles& p = b.p;
    const std::size_t n = p.size();

    // Integration. Jakobsen's damping k_d scales the carried-over displacement: k_d = h * drag (clamped
    // so a huge drag stops the particle instead of reversing it).
    const Real keep = Real(1) - std::min(Real(1), h * b.def.drag);
    const Real h2 = h * h;
    // Pressure (Matyka) acts as an external force here; p.f is cleared by the system after the step.
    if (b.def.pressure > 0) add_pressure_forces(b, p.x, p.f);
    for (std::size_t i = 0; i < n; ++i) {
        p.x_prev[i] = p.x[i];
        const Real w = p.inv_mass[i];
        if (w == 0) continue;  // pinned, or attached (the system already placed it)
        p.x[i] += (keep * h) * p.v[i] + h2 * (b.gravity + w * p.f[i]);
    }
}

void relax_verlet(SoftBody& b, Real h, ParticleCollision* collision) {
    Particles& p = b.p;
    const std::size_t n = p.size();
    // Relaxation: links, then collisions, then long-range attachments, every sweep (Jakobsen: satisfying
    // the constraints one after another and repeating converges to satisfying all of them; the collision
    // projection inside the loop keeps links from pulling particles back into the colliders).
    const int iterations = std::max(b.def.iterations, 0);
    const bool by_colour = b.def.relaxation == SoftRelaxation::ByColour;
    if (by_colour && !colouring_current(b)) colour_links(b);  // once a step: one pass over the ends
    for (int it = 0; it < iterations; ++it) {
        if (by_colour) relax_links_by_colour(b, it);
        else relax_links(b, it);
        if (collision != nullptr) collision->project_positions(b, h);
        if (!b.lra.empty()) apply_long_range_attachments(b);
    }

    // Velocity from the positions (Verlet's implicit velocity).
    const Real inv_h = Real(1) / h;
    for (std::size_t i = 0; i < n; ++i)
        p.v[i] = p.inv_mass[i] == 0 ? Vec3::Zero() : Vec3((p.x[i] - p.x_prev[i]) * inv_h);
}

void step_verlet(SoftBody& b, Real h, ParticleCollision* collision) {
    predict_verlet(b, h);
    relax_verlet(b, h, collision);
}

}  // namespace sinew
