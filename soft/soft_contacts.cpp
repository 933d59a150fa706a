// Soft-soft contacts: particles against the other body's triangles (Bridson, Fedkiw & Anderson 2002),
// found once per step at the start-of-step positions through a hash grid of each body's triangles (their
// boxes swept over the step) and enforced on the predicted positions by Gauss-Seidel sweeps of shared
// impulses (soft_contacts.hpp).
#include "soft/soft_contacts.hpp"

#include <algorithm>
#include <cmath>

#include "engine/core/segment_closest.hpp"
#include "soft/triangle_closest.hpp"

namespace sinew {
namespace {

// A contact is kept while its gap is below this fraction of the two thicknesses, so a resting pair does
// not flicker in and out of contact between steps (as the particle-shape pass's slop).
constexpr Real kSlop = Real(0.1);
// Restitution acts above this approach speed only (m/s), as in the particle-shape pass and the rigid solvers.
constexpr Real kRestitutionThreshold = Real(1);
constexpr Real kTinyArea = Real(1e-12);  // m^2 x 2: a triangle this small has no normal
// A closest point whose smallest barycentric weight is below this is on an edge or a corner.
constexpr Real kFeatureTolerance = Real(1e-5);
// Closest points nearer than this (m) are the same point (the triangles around an edge or a corner).
constexpr Real kTieDistance = Real(1e-6);
// Edge-edge contacts only where both closest points are this far (as a fraction of the edge) from the ends,
// and between edges at more than about 6 degrees (this sine) to each other.
constexpr Real kEdgeInterior = Real(1e-3);
constexpr Real kEdgeParallelSine = Real(0.1);
constexpr Real kEdgeRepulsion = Real(0.1);
// Edge-edge contacts of a body with itself are built (detect_edges' `self`) but off: on cloth-pile
// (demos/scenes) they kept the settled pile moving (0.10 J left after 5 s against 0.014 J without, the
// largest stretch 3.3 against 2.4) and made the step 20 times dearer (the search reach grows with the
// fastest particle's travel); as position pushes they blew it up (0.5 J to 15 J within 15 steps).
// docs/soft-bodies.md, "Soft bodies against soft bodies".
constexpr bool kSelfEdgeContacts = false;
// Off an edge or a corner a particle is inside when the direction from the closest point makes more than
// 120 degrees with the pseudo-normal there.
constexpr Real kBehindCosine = Real(0.5);

Vec3 triangle_normal(const Vec3& a, const Vec3& b, const Vec3& c) {
    const Vec3 n = (b - a).cross(c - a);
    const Real len = n.norm();
    return len > kTinyArea ? Vec3(n / len) : Vec3(Vec3::Zero());
}

// Clamped, so that a far or huge coordinate never overflows the conversion (such a body is about to be
// contained as a blow-up; the grid only has to stay finite).
std::int64_t cell_of(Real x, Real cell) {
    return static_cast<std::int64_t>(std::clamp(std::floor(double(x) / double(cell)), -1e15, 1e15));
}
// A particle whose swept box covers more cells than this along an axis tests every triangle's box instead.
constexpr std::int64_t kMaxQueryCellsPerAxis = 4;

bool finite_box(const Aabb& b) { return b.lo.allFinite() && b.hi.allFinite(); }

// The point of triangle `t` (its three particle indices) at barycentric weights w, in array v.
Vec3 at(const Vec3& w, const std::vector<Vec3>& v, const std::uint32_t* t) {
    return w.x() * v[t[0]] + w.y() * v[t[1]] + w.z() * v[t[2]];
}

// 21 bits per axis: cells further apart than 2^21 share keys, which only adds candidates to test.
std::uint64_t cell_key(std::int64_t i, std::int64_t j, std::int64_t k) {
    const std::uint64_t m = (std::uint64_t(1) << 21) - 1;
    return ((std::uint64_t(i) & m) << 42) | ((std::uint64_t(j) & m) << 21) | (std::uint64_t(k) & m);
}

// Calls visit(t) for every triangle of grid g filed in a cell that query box q covers (a triangle in
// several such cells more than once: the callers stamp them), or for every triangle when q covers more
// than kMaxQueryCellsPerAxis cells along an axis (something sweeping the whole body).
template <class Grid, class Visit>
void for_each_triangle_near(const Grid& g, const Aabb& q, Visit&& visit) {
    const Aabb r{q.lo.cwiseMax(g.bounds.lo), q.hi.cwiseMin(g.bounds.hi)};  // no triangle outside the grid's box
    const std::int64_t i0 = cell_of(r.lo.x(), g.cell), i1 = cell_of(r.hi.x(), g.cell);
    const std::int64_t j0 = cell_of(r.lo.y(), g.cell), j1 = cell_of(r.hi.y(), g.cell);
    const std::int64_t k0 = cell_of(r.lo.z(), g.cell), k1 = cell_of(r.hi.z(), g.cell);
    if (i1 - i0 >= kMaxQueryCellsPerAxis || j1 - j0 >= kMaxQueryCellsPerAxis || k1 - k0 >= kMaxQueryCellsPerAxis) {
        for (std::uint32_t t = 0; t < g.boxes.size(); ++t) visit(t);
        return;
    }
    for (std::int64_t ci = i0; ci <= i1; ++ci)
        for (std::int64_t cj = j0; cj <= j1; ++cj)
            for (std::int64_t ck = k0; ck <= k1; ++ck) {
                const auto range = std::equal_range(g.keys.begin(), g.keys.end(), cell_key(ci, cj, ck));
                for (auto it = range.first; it != range.second; ++it) visit(g.tris[std::size_t(it - g.keys.begin())]);
            }
}

}  // namespace

struct SoftContactPass::Side {
    std::uint32_t slot = 0;
    SoftBody* b = nullptr;
    bool stepping = false;
    std::vector<Vec3>* x = nullptr;  ///< the positions the pass works on (x_next if stepping, else x)
    Aabb box0;                       ///< of the positions at x_n, fattened by the thickness
    Real travel = 0;                 ///< largest move of a particle from x_n to x (m)
    bool closed = false;             ///< its triangles enclose a volume: inside is known
    bool grid_built = false;
    bool rigid = false;              ///< moves as one rigid body in the pass (SoftBody::as_rigid)
    Real inv_mass(std::uint32_t i) const { return stepping && !rigid ? b->p.inv_mass[i] : Real(0); }
};

bool SoftContactPass::may_touch(const SoftBody& a, std::uint32_t sa, const SoftBody& b, std::uint32_t sb) {
    if (a.p.size() == 0 || b.p.size() == 0) return false;
    if (a.triangles.empty() && b.triangles.empty()) return false;
    if (a.meets_colliders_through_proxy || b.meets_colliders_through_proxy) return false;
    const auto partner = [](const SoftBody& x, std::uint32_t other) {
        return x.soft_partners.empty() || std::find(x.soft_partners.begin(), x.soft_partners.end(), other) != x.soft_partners.end();
    };
    if (!partner(a, sb) || !partner(b, sa)) return false;
    return should_collide(a.def.filter, b.def.filter);
}

bool SoftContactPass::closed_surface(const std::vector<std::uint32_t>& triangles) {
    if (triangles.empty()) return false;
    // Closed (a 2-manifold without boundary): every edge is shared by exactly two triangles.
    std::vector<std::uint64_t> edges;
    edges.reserve(triangles.size());
    for (std::size_t t = 0; t + 2 < triangles.size(); t += 3)
        for (int e = 0; e < 3; ++e) {
            const std::uint64_t a = triangles[t + e], b = triangles[t + (e + 1) % 3];
            edges.push_back(std::min(a, b) << 32 | std::max(a, b));
        }
    std::sort(edges.begin(), edges.end());
    for (std::size_t k = 0; k < edges.size();) {
        std::size_t n = 1;
        while (k + n < edges.size() && edges[k + n] == edges[k]) ++n;
        if (n != 2) return false;
        k += n;
    }
    return true;
}

void SoftContactPass::build_grid(Side& s, std::uint32_t entry, Real margin) {
    Grid& g = grids_[entry];
    const SoftBody& b = *s.b;
    // Each triangle's box sweeps its nodes from x_n to the predicted positions (a particle meets it only
    // if their swept boxes overlap within the contact distance `margin`).
    const std::vector<Vec3>& x = b.p.x;
    const std::vector<Vec3>& x1 = *s.x;
    Real largest = 0;
    for (std::size_t t = 0; t + 2 < b.triangles.size(); t += 3) {
        Aabb box;
        for (int k = 0; k < 3; ++k) box.grow(x[b.triangles[t + k]]), box.grow(x1[b.triangles[t + k]]);
        if (finite_box(box)) largest = std::max(largest, box.extent().maxCoeff());
    }
    // A fattened triangle box spans at most two cells per axis.
    g.cell = std::max(largest + 2 * margin, Real(1e-6));
    sort_scratch_.clear();
    g.boxes.resize(b.triangles.size() / 3);
    g.bounds = Aabb();
    for (std::uint32_t t = 0; 3 * std::size_t(t) + 2 < b.triangles.size(); ++t) {
        Aabb box;
        for (int k = 0; k < 3; ++k) box.grow(x[b.triangles[3 * t + k]]), box.grow(x1[b.triangles[3 * t + k]]);
        box = box.fattened(margin);
        if (!finite_box(box)) {
            g.boxes[t] = Aabb();  // meets nothing
            continue;
        }
        g.boxes[t] = box;
        g.bounds = g.bounds.merged(box);
        const std::int64_t i0 = cell_of(box.lo.x(), g.cell), i1 = cell_of(box.hi.x(), g.cell);
        const std::int64_t j0 = cell_of(box.lo.y(), g.cell), j1 = cell_of(box.hi.y(), g.cell);
        const std::int64_t k0 = cell_of(box.lo.z(), g.cell), k1 = cell_of(box.hi.z(), g.cell);
        for (std::int64_t i = i0; i <= i1; ++i)
            for (std::int64_t j = j0; j <= j1; ++j)
                for (std::int64_t k = k0; k <= k1; ++k) sort_scratch_.push_back({cell_key(i, j, k), t});
    }
    std::sort(sort_scratch_.begin(), sort_scratch_.end());
    g.stamp.assign(g.boxes.size(), 0);
    g.query = 0;
    g.keys.resize(sort_scratch_.size());
    g.tris.resize(sort_scratch_.size());
    for (std::size_t k = 0; k < sort_scratch_.size(); ++k) {
        g.keys[k] = sort_scratch_[k].first;
        g.tris[k] = sort_scratch_[k].second;
    }
    s.grid_built = true;
}

void SoftContactPass::detect(const Side& a, const Side& b, std::uint32_t ea, std::uint32_t eb, Real reach, bool self) {
    // The contact is found where the step started (x_n), where the two were last resolved, and enforced on
    // the predicted positions: a particle that passes an edge of the other body within the step (two equal
    // cubes stacked meet edge on edge) is still pushed back the way it came, not out through the face it
    // now finds itself beside.
    Grid& g = grids_[eb];
    const std::vector<Vec3>& xa0 = a.b->p.x;
    const std::vector<Vec3>& xb0 = b.b->p.x;
    const std::vector<Vec3>& xa = *a.x;
    const std::vector<Vec3>& xb = *b.x;
    const std::vector<std::uint32_t>& tri = b.b->triangles;
    const Real rsum = a.b->def.thickness + b.b->def.thickness;
    const Aabb near = b.box0.fattened(reach);
    for (std::uint32_t i : surface_[ea]) {
        const Vec3& x0 = xa0[i];
        if (!near.contains(x0)) continue;
        // The triangles whose swept boxes overlap the particle's (x_n to its prediction, its thickness
        // around), each once (stamped), from every cell that box covers.
        Aabb q;
        q.grow(x0);
        q.grow(xa[i]);
        q = q.fattened(a.b->def.thickness * (1 + kSlop));
        if (!finite_box(q) || !q.overlaps(g.bounds)) continue;
        cand_.clear();
        ++g.query;
        const auto consider = [&](std::uint32_t t) {
            if (g.stamp[t] == g.query || !g.boxes[t].overlaps(q)) return;
            g.stamp[t] = g.query;
            // Against its own surface a particle skips the triangles it is on or is one edge from (they
            // touch it by construction).
            if (self && near_self(i, &tri[3 * std::size_t(t)])) return;
            cand_.push_back(t);
        };
        for_each_triangle_near(g, q, consider);
        if (cand_.empty()) continue;
        // The closest feature of the surface: the triangle whose closest point is nearest, a face
        // interior winning a tie with the edges and corners it meets (its normal is the surface's there).
        Real best = kRealMax;
        std::uint32_t best_t = 0;
        Vec3 best_w = Vec3::Zero();
        bool best_face = false;
        for (const std::uint32_t t : cand_) {
            const Vec3 w = closest_on_triangle_weights(x0, xb0[tri[3 * t]], xb0[tri[3 * t + 1]], xb0[tri[3 * t + 2]]);
            const Vec3 on = at(w, xb0, &tri[3 * std::size_t(t)]);
            const Real d = (x0 - on).norm();
            const bool face = w.minCoeff() > kFeatureTolerance;
            const Real rank = face ? d - kTieDistance : d;
            if (!(d < reach) || !(rank < best)) continue;  // also a degenerate triangle's NaN weights
            best = rank;
            best_t = t;
            best_w = w;
            best_face = face;
        }
        if (best == kRealMax) continue;
        const std::uint32_t* bt = &tri[3 * std::size_t(best_t)];
        const Vec3 on0 = at(best_w, xb0, bt);
        const Real d0 = (x0 - on0).norm();
        const Vec3 face_n = triangle_normal(xb0[bt[0]], xb0[bt[1]], xb0[bt[2]]);
        if (face_n.isZero()) continue;  // a degenerate triangle: no normal
        Vec3 n;
        if (d0 < kTieDistance) {
            // On the surface: its normal, turned to the particle's side for an open one.
            n = b.closed || face_n.dot(xa[i] - x0) <= 0 ? face_n : Vec3(-face_n);
        } else if (!b.closed) {
            // An open surface (cloth) has two sides: the particle is on the side it is on at x_n.
            n = (x0 - on0) / d0;
        } else if (best_face) {
            // Outward normals (counter-clockwise from outside), so inside is known and a particle that
            // went in is pushed back out, not through.
            n = face_n;
        } else {
            // Off an edge or a corner: the direction from the closest point, on the side the angle-weighted
            // pseudo-normal of the triangles around that point gives (Bærentzen & Aanæs 2005: the sign
            // test that is exact there, where one triangle's normal is not). Behind only when clearly so:
            // a particle level with a flat face's inner edge is beside its rim, outside.
            Vec3 pseudo = Vec3::Zero();
            for (const std::uint32_t t : cand_) {
                const Vec3& p0 = xb0[tri[3 * t]];
                const Vec3& p1 = xb0[tri[3 * t + 1]];
                const Vec3& p2 = xb0[tri[3 * t + 2]];
                const Vec3 w = closest_on_triangle_weights(x0, p0, p1, p2);
                if ((at(w, xb0, &tri[3 * std::size_t(t)]) - on0).norm() > kTieDistance) continue;
                // At a corner each triangle counts by its angle there; along an edge both count once.
                Real weight = 1;
                for (int k = 0; k < 3; ++k)
                    if (w[k] > 1 - kFeatureTolerance) {
                        const Vec3& o = xb0[tri[3 * t + k]];
                        const Vec3 e1 = xb0[tri[3 * t + (k + 1) % 3]] - o, e2 = xb0[tri[3 * t + (k + 2) % 3]] - o;
                        weight = std::atan2(e1.cross(e2).norm(), e1.dot(e2));
                    }
                pseudo += weight * triangle_normal(p0, p1, p2);
            }
            const Vec3 out = (x0 - on0) / d0;
            const Real len = pseudo.norm();
            n = len > 0 && pseudo.dot(out) < -kBehindCosine * len ? Vec3(-out) : out;
        }
        // The gap on the predicted positions, along the normal found at x_n.
        const Vec3 on = at(best_w, xb, bt);
        const Real gap = n.dot(xa[i] - on) - rsum;
        if (gap >= rsum * kSlop) continue;
        SoftSoftContact c;
        c.body = a.slot;
        c.particle = i;
        c.other = b.slot;
        c.triangle = best_t;
        c.weights = best_w;
        c.normal = n;
        c.depth = std::max(Real(0), -gap);
        // Restitution from the approach before the pass (as the rigid solvers' target velocity).
        const std::vector<Vec3>& vb = b.b->p.v;
        const Vec3 vt = at(best_w, vb, bt);
        const Real vn0 = n.dot(a.b->p.v[i] - vt);
        const Real e = std::max(a.b->def.restitution, b.b->def.restitution);
        Work w{};
        w.ea = ea;
        w.eb = eb;
        w.na = 1;
        w.nb = 3;
        w.ia[0] = i;
        w.wa[0] = 1;
        for (int k = 0; k < 3; ++k) w.ib[k] = bt[k], w.wb[k] = best_w[k];
        w.normal = n;
        w.target_vn = vn0 < -kRestitutionThreshold ? -e * vn0 : Real(0);
        w.edge = false;
        w.record = std::uint32_t(contacts_.size());
        contacts_.push_back(c);
        work_.push_back(w);
    }
}

void SoftContactPass::build_edges(const SoftBody& b, std::uint32_t e) {
    // Each triangle edge once: the (smaller, larger) particle pairs sorted with the triangle edge they
    // came from, equal pairs one edge.
    sort_scratch_.clear();
    for (std::size_t t = 0; t + 2 < b.triangles.size(); t += 3)
        for (int k = 0; k < 3; ++k) {
            const std::uint64_t u = b.triangles[t + k], v = b.triangles[t + (k + 1) % 3];
            sort_scratch_.push_back({std::min(u, v) << 32 | std::max(u, v), std::uint32_t(t + k)});
        }
    std::sort(sort_scratch_.begin(), sort_scratch_.end());
    std::vector<std::uint32_t>& ends = edge_ends_[e];
    std::vector<std::uint32_t>& of_tri = tri_edges_[e];
    ends.clear();
    of_tri.assign(b.triangles.size(), 0);
    for (std::size_t k = 0; k < sort_scratch_.size(); ++k) {
        const std::uint64_t key = sort_scratch_[k].first;
        if (k == 0 || key != sort_scratch_[k - 1].first) {
            ends.push_back(std::uint32_t(key >> 32));
            ends.push_back(std::uint32_t(key & 0xffffffffu));
        }
        of_tri[sort_scratch_[k].second] = std::uint32_t(ends.size() / 2 - 1);
    }
    edge_stamp_[e].assign(ends.size() / 2, 0);
    edges_built_[e] = 1;
}

bool SoftContactPass::adjacent(std::uint32_t i, std::uint32_t j) const {
    if (i == j) return true;
    const auto first = neighbours_.begin() + neighbour_start_[i], last = neighbours_.begin() + neighbour_start_[i + 1];
    return std::binary_search(first, last, j);
}

void SoftContactPass::detect_edges(const Side& a, const Side& b, std::uint32_t ea, std::uint32_t eb, Real reach, Real h,
                                   bool self) {
    // As detect(): found at x_n through b's triangle grid (each triangle's edges are its candidates),
    // enforced on the predicted positions along the direction between the closest points at x_n.
    Grid& g = grids_[eb];
    const std::vector<Vec3>& xa0 = a.b->p.x;
    const std::vector<Vec3>& xb0 = b.b->p.x;
    const std::vector<Vec3>& xa = *a.x;
    const std::vector<Vec3>& xb = *b.x;
    const std::vector<std::uint32_t>& ends_a = edge_ends_[ea];
    const std::vector<std::uint32_t>& ends_b = edge_ends_[eb];
    const std::vector<std::uint32_t>& tri_edges = tri_edges_[eb];
    std::vector<std::uint32_t>& stamp = edge_stamp_[eb];
    const Real rsum = a.b->def.thickness + b.b->def.thickness;
    const Aabb near = b.box0.fattened(reach);
    for (std::uint32_t e = 0; 2 * std::size_t(e) + 1 < ends_a.size(); ++e) {
        const std::uint32_t u = ends_a[2 * e], v = ends_a[2 * e + 1];
        Aabb q;
        q.grow(xa0[u]);
        q.grow(xa0[v]);
        if (!q.overlaps(near)) continue;
        q.grow(xa[u]);
        q.grow(xa[v]);
        q = q.fattened(a.b->def.thickness * (1 + kSlop));
        if (!finite_box(q) || !q.overlaps(g.bounds)) continue;
        ++g.query;
        const Vec3 p0 = xa0[u], d1 = xa0[v] - xa0[u];
        Real best = kRealMax, best_s = 0, best_t = 0;
        std::uint32_t best_f = 0;
        const auto consider = [&](std::uint32_t t) {
            if (g.stamp[t] == g.query || !g.boxes[t].overlaps(q)) return;
            g.stamp[t] = g.query;
            for (int k = 0; k < 3; ++k) {
                const std::uint32_t f = tri_edges[3 * std::size_t(t) + k];
                if (stamp[f] == g.query) continue;
                stamp[f] = g.query;
                const std::uint32_t f0 = ends_b[2 * f], f1 = ends_b[2 * f + 1];
                // Against its own surface: each pair once, and not edges that share a particle or are one
                // edge apart (they touch by construction).
                if (self && (f <= e || adjacent(u, f0) || adjacent(u, f1) || adjacent(v, f0) || adjacent(v, f1))) continue;
                const Vec3 d2 = xb0[f1] - xb0[f0];
                // Nearly parallel edges have no well-defined closest pair; the point-triangle contacts of
                // their ends hold them.
                if (d1.cross(d2).squaredNorm() <= kEdgeParallelSine * kEdgeParallelSine * d1.squaredNorm() * d2.squaredNorm())
                    continue;
                Real sa = 0, tb = 0;
                closest_segment_params(p0, d1, xb0[f0], d2, sa, tb);
                // A closest point at an end of either edge is a particle against a face or an edge: the
                // point-triangle contacts hold it.
                if (!(sa > kEdgeInterior && sa < 1 - kEdgeInterior && tb > kEdgeInterior && tb < 1 - kEdgeInterior)) continue;
                const Real d = (p0 + sa * d1 - xb0[f0] - tb * (xb0[f1] - xb0[f0])).norm();
                if (!(d < reach) || !(d < best)) continue;
                best = d;
                best_f = f;
                best_s = sa;
                best_t = tb;
            }
        };
        for_each_triangle_near(g, q, consider);
        if (best == kRealMax || best < kTieDistance) continue;  // none, or crossing already: no direction
        const std::uint32_t f0 = ends_b[2 * best_f], f1 = ends_b[2 * best_f + 1];
        const Vec3 n = (p0 + best_s * d1 - xb0[f0] - best_t * (xb0[f1] - xb0[f0])) / best;
        const Real gap = n.dot((1 - best_s) * xa[u] + best_s * xa[v] - (1 - best_t) * xb[f0] - best_t * xb[f1]) - rsum;
        if (gap >= rsum * kSlop) continue;
        SoftEdgeContact c;
        c.body = a.slot;
        c.a[0] = u;
        c.a[1] = v;
        c.other = b.slot;
        c.b[0] = f0;
        c.b[1] = f1;
        c.s = best_s;
        c.t = best_t;
        c.normal = n;
        c.depth = std::max(Real(0), -gap);
        const std::vector<Vec3>& va = a.b->p.v;
        const std::vector<Vec3>& vb = b.b->p.v;
        const Real vn0 = n.dot((1 - best_s) * va[u] + best_s * va[v] - (1 - best_t) * vb[f0] - best_t * vb[f1]);
        const Real rest = std::max(a.b->def.restitution, b.b->def.restitution);
        Work w{};
        w.ea = ea;
        w.eb = eb;
        w.na = 2;
        w.nb = 2;
        w.ia[0] = u, w.ia[1] = v;
        w.wa[0] = 1 - best_s, w.wa[1] = best_s;
        w.ib[0] = f0, w.ib[1] = f1;
        w.wb[0] = 1 - best_t, w.wb[1] = best_t;
        w.normal = n;
        // The normal speed the velocity sweeps hold the edges to. Apart at x_n, they may close the gap
        // within the step and no more (a speculative contact): stopping them where they are would hold a
        // falling square in the air, its gap at x_n. Already closer than the two thicknesses, they part at
        // a tenth of the overlap per step (Bridson et al. 2002 §7.2's repulsion bound), not at once. An
        // impact that closes the gap within the step rebounds with the restitution.
        const Real gap0 = best - rsum;
        w.target_vn = gap0 > 0 ? -gap0 / h : -kEdgeRepulsion * gap0 / h;
        if (rest > 0 && vn0 < -kRestitutionThreshold && -vn0 * h > gap0) w.target_vn = std::max(w.target_vn, -rest * vn0);
        w.edge = true;
        w.record = std::uint32_t(edge_contacts_.size());
        edge_contacts_.push_back(c);
        work_.push_back(w);
    }
}

void SoftContactPass::build_neighbours(const SoftBody& b) {
    // Edge neighbours of every particle, as compressed rows.
    const std::size_t np = b.p.size();
    sort_scratch_.clear();
    for (std::size_t t = 0; t + 2 < b.triangles.size(); t += 3)
        for (int e = 0; e < 3; ++e) {
            const std::uint32_t u = b.triangles[t + e], v = b.triangles[t + (e + 1) % 3];
            sort_scratch_.push_back({u, v});
            sort_scratch_.push_back({v, u});
        }
    std::sort(sort_scratch_.begin(), sort_scratch_.end());
    sort_scratch_.erase(std::unique(sort_scratch_.begin(), sort_scratch_.end()), sort_scratch_.end());
    neighbour_start_.assign(np + 1, 0);
    neighbours_.resize(sort_scratch_.size());
    for (std::size_t k = 0; k < sort_scratch_.size(); ++k) {
        ++neighbour_start_[sort_scratch_[k].first + 1];
        neighbours_[k] = sort_scratch_[k].second;
    }
    for (std::size_t i = 0; i < np; ++i) neighbour_start_[i + 1] += neighbour_start_[i];
}

bool SoftContactPass::near_self(std::uint32_t i, const std::uint32_t* tri) const {
    for (int k = 0; k < 3; ++k) {
        if (tri[k] == i) return true;
        const auto first = neighbours_.begin() + neighbour_start_[i], last = neighbours_.begin() + neighbour_start_[i + 1];
        if (std::binary_search(first, last, tri[k])) return true;
    }
    return false;
}

// The plane is the other body's surface where the step starts (x_n), not at its prediction: held against
// each other's predictions, both bodies of a contact took the whole reaction (each saw the other as
// immovable where its free motion would take it), and three fast mass-spring pressure balls stacked on
// the ground blew up within 2 s (kinetic energy 1.7e7 J). Against the surfaces at x_n neither crosses
// where they met; the pass after the solves exchanges the impulses (measured: the stack stands, then
// rolls apart onto the ground, volumes 0.96-0.97, as a stack of balls does).
void SoftContactPass::gather_planes(const std::vector<Entry>& entries, Real h) {
    for (const Entry& e : entries) e.body->soft_planes.clear();
    std::vector<Side> sides;
    const bool found = detect_all(entries, h, sides, false);
    if (found)
        for (const Work& w : work_) {
            const Side& a = sides[w.ea];
            const Side& b = sides[w.eb];
            if (w.edge || !a.stepping || !a.b->holds_soft_planes()) continue;
            const Vec3 on = at(Vec3(w.wb[0], w.wb[1], w.wb[2]), b.b->p.x, w.ib);
            a.b->soft_planes.push_back({w.ia[0], w.normal, w.normal.dot(on) + b.b->def.thickness});
        }
    contacts_.clear();
    edge_contacts_.clear();
    work_.clear();
}

void SoftContactPass::run(const std::vector<Entry>& entries, Real h) {
    for (const Entry& e : entries) e.body->soft_touched.clear();
    std::vector<Side> sides;
    if (!detect_all(entries, h, sides, true)) return;
    resolve(sides, h);
}

bool SoftContactPass::detect_all(const std::vector<Entry>& entries, Real h, std::vector<Side>& sides, bool all_kinds) {
    contacts_.clear();
    edge_contacts_.clear();
    work_.clear();
    const std::size_t n = entries.size();
    // Nothing to do unless two bodies may touch or one meets itself (a lone cloth costs nothing here).
    bool any = false;
    for (std::size_t i = 0; i < n && !any; ++i) {
        const Entry& e = entries[i];
        any = all_kinds && e.stepping && e.body->def.self_collision && !e.body->triangles.empty();
        for (std::size_t j = i + 1; j < n && !any; ++j)
            any = (e.stepping || entries[j].stepping) && may_touch(*e.body, e.slot, *entries[j].body, entries[j].slot);
    }
    if (!any) return false;
    sides.assign(n, Side());
    if (grids_.size() < n) grids_.resize(n);
    if (surface_.size() < n) surface_.resize(n);
    if (edge_ends_.size() < n) edge_ends_.resize(n), tri_edges_.resize(n), edge_stamp_.resize(n);
    edges_built_.assign(n, 0);
    Real thickest = 0;
    for (std::size_t e = 0; e < n; ++e) {
        Side& s = sides[e];
        s.slot = entries[e].slot;
        s.b = entries[e].body;
        s.stepping = entries[e].stepping;
        s.x = s.stepping ? &s.b->p.x_next : &s.b->p.x;
        s.closed = s.b->closed_surface;
        s.rigid = s.stepping && s.b->as_rigid.active;
        Aabb box;
        for (std::size_t i = 0; i < s.x->size(); ++i) {
            box.grow(s.b->p.x[i]);
            if (s.stepping) s.travel = std::max(s.travel, ((*s.x)[i] - s.b->p.x[i]).squaredNorm());
        }
        s.travel = std::sqrt(s.travel);
        s.box0 = box.fattened(s.b->def.thickness);
        thickest = std::max(thickest, s.b->def.thickness);
        // The particles that can touch: those of its triangles (an FEM body's inner nodes cannot), or all.
        std::vector<std::uint32_t>& surf = surface_[e];
        surf.clear();
        const std::size_t np = s.b->p.size();
        if (s.b->triangles.empty()) {
            for (std::uint32_t i = 0; i < np; ++i) surf.push_back(i);
        } else {
            mark_.assign(np, 0);
            for (std::uint32_t i : s.b->triangles) mark_[i] = 1;
            for (std::uint32_t i = 0; i < np; ++i)
                if (mark_[i]) surf.push_back(i);
        }
    }

    for (std::size_t i = 0; i < n; ++i)
        for (std::size_t j = i + 1; j < n; ++j) {
            Side& a = sides[i];
            Side& b = sides[j];
            if (!(a.stepping || b.stepping) || !may_touch(*a.b, a.slot, *b.b, b.slot)) continue;
            // A particle is tested against triangles within the contact distance plus how far the two
            // bodies moved this step, so one that went a step's travel deep into a closed body is found.
            const Real reach = (a.b->def.thickness + b.b->def.thickness) * (1 + kSlop) + a.travel + b.travel;
            if (!a.box0.fattened(reach).overlaps(b.box0)) continue;
            for (int dir = 0; dir < 2; ++dir) {
                Side& p = dir == 0 ? a : b;  // particles
                Side& t = dir == 0 ? b : a;  // triangles
                const std::uint32_t ep = std::uint32_t(dir == 0 ? i : j), et = std::uint32_t(dir == 0 ? j : i);
                if (t.b->triangles.empty()) continue;
                if (!t.grid_built) build_grid(t, et, (t.b->def.thickness + thickest) * (1 + kSlop));
                detect(p, t, ep, et, reach, false);
            }
            // Edge on edge, once per pair: a's edges against b's triangle grid.
            if (!all_kinds || a.b->triangles.empty() || b.b->triangles.empty()) continue;
            if (!edges_built_[i]) build_edges(*a.b, std::uint32_t(i));
            if (!edges_built_[j]) build_edges(*b.b, std::uint32_t(j));
            detect_edges(a, b, std::uint32_t(i), std::uint32_t(j), reach, h, false);
        }
    // Self-collision: a body's particles against its own triangles (a cloth folding on itself).
    for (std::size_t i = 0; all_kinds && i < n; ++i) {
        Side& s = sides[i];
        const SoftBody& b = *s.b;
        if (!s.stepping || !b.def.self_collision || b.triangles.empty() || b.meets_colliders_through_proxy) continue;
        if (!s.grid_built) build_grid(s, std::uint32_t(i), (b.def.thickness + thickest) * (1 + kSlop));
        build_neighbours(b);
        const Real reach = 2 * b.def.thickness * (1 + kSlop) + 2 * s.travel;
        detect(s, s, std::uint32_t(i), std::uint32_t(i), reach, true);
        if (kSelfEdgeContacts) {
            if (!edges_built_[i]) build_edges(b, std::uint32_t(i));
            detect_edges(s, s, std::uint32_t(i), std::uint32_t(i), reach, h, true);
        }
    }
    return !work_.empty();
}

void SoftContactPass::resolve(std::vector<Side>& sides, Real h) {
    // One contact's sides and the inverse masses of its particles, which the sweeps share impulses by: a
    // side's point moves by Δx_k = w_k m_k⁻¹ I n for an impulse I, so the effective inverse mass of the
    // contact is W = Σ_a w_k² m_k⁻¹ + Σ_b w_k² m_k⁻¹.
    const auto inv_masses = [&](const Work& w, Real* ma, Real* mb) {
        const Side& a = sides[w.ea];
        const Side& b = sides[w.eb];
        for (std::uint32_t k = 0; k < w.na; ++k) ma[k] = a.inv_mass(w.ia[k]);
        for (std::uint32_t k = 0; k < w.nb; ++k) mb[k] = b.inv_mass(w.ib[k]);
    };
    const auto point = [](const std::vector<Vec3>& x, const std::uint32_t* idx, const Real* wt, std::uint32_t m) {
        Vec3 p = Vec3::Zero();
        for (std::uint32_t k = 0; k < m; ++k) p += wt[k] * x[idx[k]];
        return p;
    };
    // Gauss-Seidel: positions out of each other, then the normal velocities and friction. Edge-edge
    // contacts act on velocities only, each change moving the predicted positions by h times it (as
    // friction does): a position push without a velocity change is free energy, and edges fighting the
    // point contacts around them with such pushes blew up a piled cloth (0.5 J to 15 J within 15 steps).
    for (int it = 0; it < kIterations; ++it)
        for (Work& w : work_) {
            if (w.edge) continue;
            const Side& a = sides[w.ea];
            const Side& b = sides[w.eb];
            Real ma[2] = {0, 0}, mb[3] = {0, 0, 0};
            inv_masses(w, ma, mb);
            std::vector<Vec3>& xa = *a.x;
            std::vector<Vec3>& xb = *b.x;
            Real W = 0;
            for (std::uint32_t k = 0; k < w.na; ++k) W += w.wa[k] * w.wa[k] * ma[k];
            for (std::uint32_t k = 0; k < w.nb; ++k) W += w.wb[k] * w.wb[k] * mb[k];
            if (W <= 0) continue;
            const Real gap = w.normal.dot(point(xa, w.ia, w.wa, w.na) - point(xb, w.ib, w.wb, w.nb)) -
                             (a.b->def.thickness + b.b->def.thickness);
            if (!(gap < 0)) continue;  // apart, or not finite (a body about to be contained)
            const Real d = -gap / W;  // kg m: the position "impulse"
            for (std::uint32_t k = 0; k < w.na; ++k) xa[w.ia[k]] += w.wa[k] * ma[k] * d * w.normal;
            for (std::uint32_t k = 0; k < w.nb; ++k) xb[w.ib[k]] -= w.wb[k] * mb[k] * d * w.normal;
            w.push += d;
        }
    for (int it = 0; it < kIterations; ++it)
        for (Work& w : work_) {
            const Side& a = sides[w.ea];
            const Side& b = sides[w.eb];
            Real ma[2] = {0, 0}, mb[3] = {0, 0, 0};
            inv_masses(w, ma, mb);
            std::vector<Vec3>& va = a.b->p.v;
            std::vector<Vec3>& vb = b.b->p.v;
            const Vec3& n = w.normal;
            // A side that moves as a rigid body (a rigid body's FEM proxy) is met at the contact point with
            // its rigid velocity field and effective inverse mass 1/M + (r x n) I^-1 (r x n).
            const Vec3 xa0 = point(a.b->p.x, w.ia, w.wa, w.na);
            const Vec3 xb0 = point(b.b->p.x, w.ib, w.wb, w.nb);
            const auto rigid_w = [&](const SoftBody::RigidMotion& m, const Vec3& x) {
                const Vec3 rn = (x - m.com).cross(n);
                return m.inv_mass + rn.dot(m.inv_inertia * rn);
            };
            Real Wa = 0, Wb = 0;
            for (std::uint32_t k = 0; k < w.na; ++k) Wa += w.wa[k] * w.wa[k] * ma[k];
            for (std::uint32_t k = 0; k < w.nb; ++k) Wb += w.wb[k] * w.wb[k] * mb[k];
            const Real W = (a.rigid ? rigid_w(a.b->as_rigid, xa0) : Wa) + (b.rigid ? rigid_w(b.b->as_rigid, xb0) : Wb);
            if (W <= 0) continue;
            const auto push_rigid = [](SoftBody::RigidMotion& m, const Vec3& x, const Vec3& j) {
                const Vec3 r = x - m.com;
                m.v += m.inv_mass * j;
                m.w += m.inv_inertia * r.cross(j);
                m.impulse += j;
                m.angular_impulse += r.cross(j);
            };
            const auto apply = [&](const Vec3& j) {
                if (a.rigid)
                    push_rigid(a.b->as_rigid, xa0, j);
                else
                    for (std::uint32_t k = 0; k < w.na; ++k) va[w.ia[k]] += w.wa[k] * ma[k] * j;
                if (b.rigid)
                    push_rigid(b.b->as_rigid, xb0, -j);
                else
                    for (std::uint32_t k = 0; k < w.nb; ++k) vb[w.ib[k]] -= w.wb[k] * mb[k] * j;
            };
            const auto relative = [&] {
                const SoftBody::RigidMotion& ra = a.b->as_rigid;
                const SoftBody::RigidMotion& rb = b.b->as_rigid;
                const Vec3 vpa = a.rigid ? Vec3(ra.v + ra.w.cross(xa0 - ra.com)) : point(va, w.ia, w.wa, w.na);
                const Vec3 vpb = b.rigid ? Vec3(rb.v + rb.w.cross(xb0 - rb.com)) : point(vb, w.ib, w.wb, w.nb);
                return Vec3(vpa - vpb);
            };
            // An edge-edge contact's changes move this step's predicted positions too (see above).
            const auto move = [&](const Vec3& j) {
                if (a.stepping && !a.rigid)
                    for (std::uint32_t k = 0; k < w.na; ++k) (*a.x)[w.ia[k]] += h * w.wa[k] * ma[k] * j;
                if (b.stepping && !b.rigid)
                    for (std::uint32_t k = 0; k < w.nb; ++k) (*b.x)[w.ib[k]] -= h * w.wb[k] * mb[k] * j;
            };
            // Normal: accumulated and kept >= 0, so a later sweep can take back what an earlier one gave.
            const Real vn = n.dot(relative());
            if (!std::isfinite(vn)) continue;
            const Real jn = std::max(Real(0), w.impulse + (w.target_vn - vn) / W);
            apply((jn - w.impulse) * n);
            if (w.edge) move((jn - w.impulse) * n);
            w.impulse = jn;
            // Coulomb friction, bounded by mu times the normal impulse including the position pushes.
            const Real mu = std::sqrt(std::max(Real(0), a.b->def.friction * b.b->def.friction));
            const Real budget = mu * (w.impulse + w.push / h);
            const Vec3 vr = relative();
            const Vec3 vt = vr - n.dot(vr) * n;
            Vec3 jt = w.friction - vt / W;
            const Real len = jt.norm();
            if (len > budget) jt *= budget / len;
            const Vec3 djt = jt - w.friction;
            apply(djt);
            // The step already moved the particles with their pre-friction velocities: friction takes back
            // its share of that motion, as the particle-shape pass does.
            move(djt);
            w.friction = jt;
        }
    // What each contact did, into its record; the particles it moved, into their bodies' flags.
    const auto touch = [&](const Side& side, const std::uint32_t* idx, std::uint32_t count) {
        if (!side.stepping || side.rigid) return;
        std::vector<std::uint8_t>& t = side.b->soft_touched;
        if (t.size() != side.b->p.size()) t.assign(side.b->p.size(), 0);
        for (std::uint32_t k = 0; k < count; ++k) t[idx[k]] = 1;
    };
    for (const Work& w : work_) {
        if (w.impulse > 0 || w.push > 0) {
            touch(sides[w.ea], w.ia, w.na);
            touch(sides[w.eb], w.ib, w.nb);
        }
        if (w.edge) {
            edge_contacts_[w.record].impulse = w.impulse;
            edge_contacts_[w.record].friction = w.friction;
        } else {
            contacts_[w.record].impulse = w.impulse;
            contacts_[w.record].friction = w.friction;
        }
    }
    // A rigid side's nodes take its rigid velocity field.
    for (const Side& s : sides)
        if (s.rigid) {
            const SoftBody::RigidMotion& m = s.b->as_rigid;
            for (std::size_t i = 0; i < s.b->p.size(); ++i) s.b->p.v[i] = m.v + m.w.cross(s.b->p.x[i] - m.com);
        }
    for (const Side& s : sides)
        if (s.stepping) s.b->p.v_solved = s.b->p.v;
}

}  // namespace sinew
