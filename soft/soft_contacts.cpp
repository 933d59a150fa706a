// Soft-soft contacts: particles against the other body's triangles (Bridson, Fedkiw & Anderson 2002),
// found once per step at the start-of-step positions through a hash grid of each body's triangles (their
// boxes swept over the step) and enforced on the predicted positions by Gauss-Seidel sweeps of shared
// impulses (soft_contacts.hpp).
#include "soft/soft_contacts.hpp"

#include <algorithm>
#include <cmath>

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
        const Aabb r{q.lo.cwiseMax(g.bounds.lo), q.hi.cwiseMin(g.bounds.hi)};  // no triangle outside the grid's box
        const std::int64_t i0 = cell_of(r.lo.x(), g.cell), i1 = cell_of(r.hi.x(), g.cell);
        const std::int64_t j0 = cell_of(r.lo.y(), g.cell), j1 = cell_of(r.hi.y(), g.cell);
        const std::int64_t k0 = cell_of(r.lo.z(), g.cell), k1 = cell_of(r.hi.z(), g.cell);
        if (i1 - i0 >= kMaxQueryCellsPerAxis || j1 - j0 >= kMaxQueryCellsPerAxis || k1 - k0 >= kMaxQueryCellsPerAxis) {
            for (std::uint32_t t = 0; t < g.boxes.size(); ++t) consider(t);  // a particle sweeping the whole body
        } else
        for (std::int64_t ci = i0; ci <= i1; ++ci)
            for (std::int64_t cj = j0; cj <= j1; ++cj)
                for (std::int64_t ck = k0; ck <= k1; ++ck) {
                    const auto range = std::equal_range(g.keys.begin(), g.keys.end(), cell_key(ci, cj, ck));
                    for (auto it = range.first; it != range.second; ++it) consider(g.tris[std::size_t(it - g.keys.begin())]);
                }
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
        contacts_.push_back(c);
        work_.push_back({ea, eb, vn0 < -kRestitutionThreshold ? -e * vn0 : Real(0), Real(0)});
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

void SoftContactPass::run(const std::vector<Entry>& entries, Real h) {
    contacts_.clear();
    work_.clear();
    const std::size_t n = entries.size();
    // Nothing to do unless two bodies may touch or one meets itself (a lone cloth costs nothing here).
    bool any = false;
    for (std::size_t i = 0; i < n && !any; ++i) {
        const Entry& e = entries[i];
        any = e.stepping && e.body->def.self_collision && !e.body->triangles.empty();
        for (std::size_t j = i + 1; j < n && !any; ++j)
            any = (e.stepping || entries[j].stepping) && may_touch(*e.body, e.slot, *entries[j].body, entries[j].slot);
    }
    if (!any) return;
    std::vector<Side> sides(n);
    if (grids_.size() < n) grids_.resize(n);
    if (surface_.size() < n) surface_.resize(n);
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
        }
    // Self-collision: a body's particles against its own triangles (a cloth folding on itself).
    for (std::size_t i = 0; i < n; ++i) {
        Side& s = sides[i];
        const SoftBody& b = *s.b;
        if (!s.stepping || !b.def.self_collision || b.triangles.empty() || b.meets_colliders_through_proxy) continue;
        if (!s.grid_built) build_grid(s, std::uint32_t(i), (b.def.thickness + thickest) * (1 + kSlop));
        build_neighbours(b);
        detect(s, s, std::uint32_t(i), std::uint32_t(i), 2 * b.def.thickness * (1 + kSlop) + 2 * s.travel, true);
    }
    if (contacts_.empty()) return;

    // One contact's sides, the triangle's particles and the inverse masses the sweeps share impulses by.
    struct Joined {
        SoftSoftContact& c;
        const Side& a;
        const Side& b;
        const std::uint32_t* tri;
        Real wp;
        Vec3 wk;
    };
    const auto join = [&](std::size_t k) {
        SoftSoftContact& c = contacts_[k];
        const Side& a = sides[work_[k].ea];
        const Side& b = sides[work_[k].eb];
        const std::uint32_t* tri = &b.b->triangles[3 * std::size_t(c.triangle)];
        return Joined{c, a, b, tri, a.inv_mass(c.particle), Vec3(b.inv_mass(tri[0]), b.inv_mass(tri[1]), b.inv_mass(tri[2]))};
    };
    // Gauss-Seidel: positions out of each other, then the normal velocities and friction.
    for (int it = 0; it < kIterations; ++it)
        for (std::size_t k = 0; k < contacts_.size(); ++k) {
            const Joined j = join(k);
            SoftSoftContact& c = j.c;
            const Side& a = j.a;
            const Side& b = j.b;
            const std::uint32_t* tri = j.tri;
            const Real wp = j.wp;
            const Vec3& wk = j.wk;
            std::vector<Vec3>& xa = *a.x;
            std::vector<Vec3>& xb = *b.x;
            const Real W = wp + c.weights.cwiseAbs2().dot(wk);
            if (W <= 0) continue;
            const Vec3 on = at(c.weights, xb, tri);
            const Real gap = c.normal.dot(xa[c.particle] - on) - (a.b->def.thickness + b.b->def.thickness);
            if (!(gap < 0)) continue;  // apart, or not finite (a body about to be contained)
            const Real d = -gap / W;  // kg m: the position "impulse"
            xa[c.particle] += wp * d * c.normal;
            for (int q = 0; q < 3; ++q) xb[tri[q]] -= c.weights[q] * wk[q] * d * c.normal;
            work_[k].push += d;
        }
    for (int it = 0; it < kIterations; ++it)
        for (std::size_t k = 0; k < contacts_.size(); ++k) {
            const Joined j = join(k);
            SoftSoftContact& c = j.c;
            const Side& a = j.a;
            const Side& b = j.b;
            const std::uint32_t* tri = j.tri;
            const Real wp = j.wp;
            const Vec3& wk = j.wk;
            std::vector<Vec3>& va = a.b->p.v;
            std::vector<Vec3>& vb = b.b->p.v;
            // A side that moves as a rigid body (a rigid body's FEM proxy) is met at the contact point with
            // its rigid velocity field and effective inverse mass 1/M + (r x n) I^-1 (r x n).
            const Vec3 xa0 = a.b->p.x[c.particle];
            const Vec3 xb0 = at(c.weights, b.b->p.x, tri);
            const auto rigid_w = [&](const SoftBody::RigidMotion& m, const Vec3& x) {
                const Vec3 rn = (x - m.com).cross(c.normal);
                return m.inv_mass + rn.dot(m.inv_inertia * rn);
            };
            const Real W = (a.rigid ? rigid_w(a.b->as_rigid, xa0) : wp) +
                           (b.rigid ? rigid_w(b.b->as_rigid, xb0) : c.weights.cwiseAbs2().dot(wk));
            if (W <= 0) continue;
            const auto push_rigid = [](SoftBody::RigidMotion& m, const Vec3& x, const Vec3& j) {
                const Vec3 r = x - m.com;
                m.v += m.inv_mass * j;
                m.w += m.inv_inertia * r.cross(j);
                m.impulse += j;
                m.angular_impulse += r.cross(j);
            };
            const auto apply = [&](const Vec3& j) {
                if (a.rigid) push_rigid(a.b->as_rigid, xa0, j);
                else if (wp > 0) va[c.particle] += wp * j;
                if (b.rigid) {
                    push_rigid(b.b->as_rigid, xb0, -j);
                    return;
                }
                for (int q = 0; q < 3; ++q)
                    if (wk[q] > 0) vb[tri[q]] -= c.weights[q] * wk[q] * j;
            };
            const auto relative = [&] {
                const SoftBody::RigidMotion& ma = a.b->as_rigid;
                const SoftBody::RigidMotion& mb = b.b->as_rigid;
                const Vec3 vpa = a.rigid ? Vec3(ma.v + ma.w.cross(xa0 - ma.com)) : va[c.particle];
                const Vec3 vpb = b.rigid ? Vec3(mb.v + mb.w.cross(xb0 - mb.com))
                                         : at(c.weights, vb, tri);
                return Vec3(vpa - vpb);
            };
            // Normal: accumulated and kept >= 0, so a later sweep can take back what an earlier one gave.
            const Real vn = c.normal.dot(relative());
            if (!std::isfinite(vn)) continue;
            const Real jn = std::max(Real(0), c.impulse + (work_[k].target_vn - vn) / W);
            apply((jn - c.impulse) * c.normal);
            c.impulse = jn;
            // Coulomb friction, bounded by mu times the normal impulse including the position pushes.
            const Real mu = std::sqrt(std::max(Real(0), a.b->def.friction * b.b->def.friction));
            const Real budget = mu * (c.impulse + work_[k].push / h);
            const Vec3 vr = relative();
            const Vec3 vt = vr - c.normal.dot(vr) * c.normal;
            Vec3 jt = c.friction - vt / W;
            const Real len = jt.norm();
            if (len > budget) jt *= budget / len;
            const Vec3 djt = jt - c.friction;
            apply(djt);
            // The step already moved the particles with their pre-friction velocities: friction takes back
            // its share of that motion, as the particle-shape pass does.
            if (a.stepping && wp > 0) (*a.x)[c.particle] += h * wp * djt;
            if (b.stepping)
                for (int q = 0; q < 3; ++q)
                    if (wk[q] > 0) (*b.x)[tri[q]] -= h * c.weights[q] * wk[q] * djt;
            c.friction = jt;
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
