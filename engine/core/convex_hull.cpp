// make_convex_hull(): 3-D quickhull (Barber, Dobkin & Huhdanpaa 1996, "The Quickhull Algorithm for
// Convex Hulls") followed by merging of coplanar triangles into polygonal faces.
//
// Physics needs polygonal faces (reference-face clipping wants the cube's 6 quads, not 12 triangles) and
// a hull that is robust to the noise of real input. Both are handled with one distance tolerance `tol`
// relative to the size of the point cloud:
//   * a point becomes a vertex (the "eye" of an expansion step) only if it is more than `tol` above a
//     face, so duplicate, interior and nearly coplanar points never become vertices; which faces the eye
//     sees is decided by the exact sign, which keeps the triangle hull convex up to rounding;
//   * points at most `tol` above a face are kept in its conflict list and checked at the end, since a
//     point within tol of a thin early hull can lie far outside the final one (beyond a sharp edge);
//   * the finished triangle hull is checked for convexity at every edge; if rounding folded a sliver
//     over, the hull is rebuilt with a larger tol;
//   * after the triangle hull is built, adjacent triangles whose vertices lie within `tol` of a seed
//     plane are merged into one polygon (the boundary loop of the merged triangles), and vertices left on
//     only two faces (collinear on an edge) are removed.
// All construction is done in double whatever `Real` is; the result is stored in `Real`.
#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>

#include "engine/core/shape.hpp"
#include "engine/core/format.hpp"

namespace sinew {

namespace {

using V3 = Eigen::Vector3d;

/// Relative tolerance of the hull, the same in both precisions: 64 float ulps, far above the rounding of
/// float input and of the double arithmetic, far below any feature that matters to a physics hull. A
/// smaller one (double input) only buys slivers: a triangle whose apex is nearly on its opposite edge
/// has a plane too ill-conditioned to decide which side of it a distant point is on.
constexpr double kRelativeTolerance = 64.0 * std::numeric_limits<float>::epsilon();
/// If the hull fails its convexity check (rounding beat the tolerance), it is rebuilt with a tolerance
/// this many times larger, a few times at most.
constexpr double kToleranceGrowth = 10.0;
constexpr int kAttempts = 4;

/// Internal: the construction met a numerically inconsistent configuration; retried at a larger tol.
struct NumericalFailure {};

constexpr std::size_t kMaxHullVertices = 65535;  // faces store uint16 vertex indices

struct HullTri {
    int v[3];    // counter-clockwise seen from outside
    int adj[3];  // adj[i]: triangle across edge v[i] -> v[(i+1)%3]
    V3 n;        // outward unit normal
    double d;    // plane: n . x = d
    double area2;  // twice the area (orders the merge seeds)
    std::vector<int> outside;  // conflict list: points above this plane (and assigned to it)
    bool alive = true;
    int mark = 0;  // per-iteration visit mark
};

class QuickHull {
public:
    QuickHull(const std::vector<V3>& pts, double tol) : p_(pts), tol_(tol) {}

    void build();
    /// Every edge convex within tol: the check that rounding did not fold a triangle over.
    bool locally_convex() const;
    /// Merges coplanar triangles and writes the polygonal hull.
    void extract(ConvexHullData& out) const;

private:
    const std::vector<V3>& p_;
    double tol_;
    std::vector<HullTri> tris_;
    int mark_ = 0;

    double dist(const HullTri& t, int i) const { return t.n.dot(p_[i]) - t.d; }
    int add_tri(int a, int b, int c);
    void initial_simplex(int& i0, int& i1, int& i2, int& i3) const;
    void add_point(int fi, int eye);
    void expand();
    bool relocate_near_points();
};

int QuickHull::add_tri(int a, int b, int c) {
    HullTri t;
    t.v[0] = a;
    t.v[1] = b;
    t.v[2] = c;
    t.adj[0] = t.adj[1] = t.adj[2] = -1;
    V3 cr = (p_[b] - p_[a]).cross(p_[c] - p_[a]);
    t.area2 = cr.norm();
    // A sliver from nearly collinear points still gets a unit normal; its vertices lie within tol of its
    // neighbours' planes, so the merge step absorbs it.
    t.n = t.area2 > 0 ? V3(cr / t.area2) : V3::UnitZ();
    t.d = t.n.dot(p_[a]);
    tris_.push_back(std::move(t));
    return static_cast<int>(tris_.size()) - 1;
}

void QuickHull::initial_simplex(int& i0, int& i1, int& i2, int& i3) const {
    const int n = static_cast<int>(p_.size());
    // The two most distant of the six axis-extreme points span the cloud well.
    int ext[6] = {0, 0, 0, 0, 0, 0};
    for (int i = 1; i < n; ++i)
        for (int k = 0; k < 3; ++k) {
            if (p_[i][k] < p_[ext[2 * k]][k]) ext[2 * k] = i;
            if (p_[i][k] > p_[ext[2 * k + 1]][k]) ext[2 * k + 1] = i;
        }
    double best = -1;
    for (int a = 0; a < 6; ++a)
        for (int b = a + 1; b < 6; ++b) {
            double d = (p_[ext[a]] - p_[ext[b]]).squaredNorm();
            if (d > best) {
                best = d;
                i0 = ext[a];
                i1 = ext[b];
            }
        }
    if (std::sqrt(best) <= tol_) throw ShapeError("convex hull is degenerate: all points coincide");

    V3 axis = (p_[i1] - p_[i0]).normalized();
    best = -1;
    for (int i = 0; i < n; ++i) {
        V3 r = p_[i] - p_[i0];
        double d = (r - axis * axis.dot(r)).norm();
        if (d > best) {
            best = d;
            i2 = i;
        }
    }
    if (best <= tol_)
        throw ShapeError("convex hull is degenerate: all points lie on a line (largest distance from the line " +
                         to_text(best) + ")");

    V3 nrm = (p_[i1] - p_[i0]).cross(p_[i2] - p_[i0]).normalized();
    best = -1;
    for (int i = 0; i < n; ++i) {
        double d = std::abs(nrm.dot(p_[i] - p_[i0]));
        if (d > best) {
            best = d;
            i3 = i;
        }
    }
    if (best <= tol_)
        throw ShapeError("convex hull is degenerate: all points lie on a plane (flat cloud; largest distance "
                         "from the plane " + to_text(best) + ")");
}

void QuickHull::build() {
    int i0 = 0, i1 = 0, i2 = 0, i3 = 0;
    initial_simplex(i0, i1, i2, i3);

    // Tetrahedron with outward orientation: (i0,i1,i2) must face away from i3.
    if ((p_[i1] - p_[i0]).cross(p_[i2] - p_[i0]).dot(p_[i3] - p_[i0]) > 0) std::swap(i1, i2);
    add_tri(i0, i1, i2);
    add_tri(i0, i3, i1);
    add_tri(i1, i3, i2);
    add_tri(i2, i3, i0);
    // Link the tetrahedron: the twin of directed edge (a,b) is (b,a).
    for (int f = 0; f < 4; ++f)
        for (int e = 0; e < 3; ++e)
            for (int g = 0; g < 4; ++g)
                for (int k = 0; k < 3; ++k)
                    if (tris_[g].v[k] == tris_[f].v[(e + 1) % 3] && tris_[g].v[(k + 1) % 3] == tris_[f].v[e])
                        tris_[f].adj[e] = g;

    // Conflict lists: each point goes to the face it is furthest above, if it is above any. Points at
    // most tol above are kept too (never as eyes): they may turn out to lie beyond a sharp edge of an
    // early, thin hull, further out than tol from the final one (see relocate_near_points).
    for (int i = 0; i < static_cast<int>(p_.size()); ++i) {
        if (i == i0 || i == i1 || i == i2 || i == i3) continue;
        int bf = -1;
        double bd = 0;
        for (int f = 0; f < 4; ++f) {
            double d = dist(tris_[f], i);
            if (d > bd) {
                bd = d;
                bf = f;
            }
        }
        if (bf >= 0) tris_[bf].outside.push_back(i);
    }

    // Expansion, then a check that no kept near point has ended up far outside; a few rounds at most.
    for (int round = 0; round < 8; ++round) {
        expand();
        if (!relocate_near_points()) break;
    }
}

bool QuickHull::locally_convex() const {
    for (const HullTri& t : tris_) {
        if (!t.alive) continue;
        // A triangle within tol of a line (collinear input points make them) has no meaningful plane.
        double longest = 0;
        for (int e = 0; e < 3; ++e) longest = std::max(longest, (p_[t.v[(e + 1) % 3]] - p_[t.v[e]]).norm());
        if (t.area2 <= tol_ * longest) continue;
        for (int e = 0; e < 3; ++e) {
            const HullTri& u = tris_[t.adj[e]];
            // The neighbour's vertex off the shared edge must not be above this triangle's plane.
            for (int v : u.v)
                if (v != t.v[e] && v != t.v[(e + 1) % 3] && dist(t, v) > tol_) return false;
        }
    }
    return true;
}

void QuickHull::expand() {
    // New triangles are appended, and points only move to new triangles, so one forward pass suffices.
    for (std::size_t f = 0; f < tris_.size(); ++f) {
        while (tris_[f].alive) {
            int eye = -1;
            double bd = tol_;
            for (int i : tris_[f].outside) {
                double d = dist(tris_[f], i);
                if (d > bd) {
                    bd = d;
                    eye = i;
                }
            }
            if (eye < 0) break;
            add_point(static_cast<int>(f), eye);
        }
    }
}

bool QuickHull::relocate_near_points() {
    // A point kept at most tol above its triangle can still be far above another one (beyond a sharp
    // edge). The triangles a point sees form a connected patch containing its own, so a walk over that
    // patch finds the one it is furthest above.
    bool moved = false;
    std::vector<int> patch;
    for (std::size_t f = 0; f < tris_.size(); ++f) {
        if (!tris_[f].alive) continue;
        for (std::size_t k = 0; k < tris_[f].outside.size();) {
            const int i = tris_[f].outside[k];
            const int mark = ++mark_;
            patch.assign(1, static_cast<int>(f));
            tris_[f].mark = mark;
            int best = static_cast<int>(f);
            double bd = dist(tris_[f], i);
            for (std::size_t q = 0; q < patch.size(); ++q)
                for (int g : tris_[patch[q]].adj) {
                    if (tris_[g].mark == mark) continue;
                    tris_[g].mark = mark;
                    const double d = dist(tris_[g], i);
                    if (d <= 0) continue;
                    patch.push_back(g);
                    if (d > bd) {
                        bd = d;
                        best = g;
                    }
                }
            if (best != static_cast<int>(f) && bd > tol_) {
                tris_[best].outside.push_back(i);
                tris_[f].outside[k] = tris_[f].outside.back();
                tris_[f].outside.pop_back();
                moved = true;
            } else {
                ++k;
            }
        }
    }
    return moved;
}

void QuickHull::add_point(int fi, int eye) {
    // 1. Visible set: triangles connected to fi that the eye is above. Deliberately no tolerance here:
    //    hiding a triangle the eye is slightly above leaves a concave edge, and a later point near that
    //    edge can then fold a cone triangle over (an inward-facing sliver). With the exact sign the
    //    triangle hull stays convex up to rounding and near-coplanar pieces are merged afterwards.
    const int vis = ++mark_;
    std::vector<int> visible{fi};
    tris_[fi].mark = vis;
    for (std::size_t k = 0; k < visible.size(); ++k)
        for (int g : tris_[visible[k]].adj)
            if (tris_[g].mark != vis && dist(tris_[g], eye) > 0) {
                tris_[g].mark = vis;
                visible.push_back(g);
            }

    // 2. Horizon: directed edges of visible triangles whose neighbour is hidden, chained into one loop.
    struct HEdge {
        int a, b, hidden_tri, hidden_edge;
    };
    std::vector<HEdge> horizon;
    std::vector<int> loop;
    auto find_horizon = [&]() {
        horizon.clear();
        loop.clear();
        for (int f : visible)
            for (int e = 0; e < 3; ++e) {
                int g = tris_[f].adj[e];
                if (tris_[g].mark == vis) continue;
                int ge = 0;
                while (tris_[g].adj[ge] != f) ++ge;
                horizon.push_back({tris_[f].v[e], tris_[f].v[(e + 1) % 3], g, ge});
            }
        std::unordered_map<int, int> by_start;
        for (std::size_t k = 0; k < horizon.size(); ++k)
            if (!by_start.emplace(horizon[k].a, static_cast<int>(k)).second) return false;  // pinched
        std::vector<char> seen(horizon.size(), 0);
        for (int k = 0; !horizon.empty() && !seen[k];) {
            seen[k] = 1;
            loop.push_back(k);
            auto it = by_start.find(horizon[k].b);
            if (it == by_start.end()) return false;
            k = it->second;
        }
        return !loop.empty() && loop.size() == horizon.size() && horizon[loop.back()].b == horizon[loop[0]].a;
    };

    if (!find_horizon()) {
        // Rounding can leave a hidden triangle enclosed by visible ones (a hole makes the horizon two
        // loops). Keep only the hidden region connected to the triangle furthest below the eye.
        int far = -1;
        double fd = std::numeric_limits<double>::max();
        for (std::size_t g = 0; g < tris_.size(); ++g)
            if (tris_[g].alive && tris_[g].mark != vis) {
                double d = dist(tris_[g], eye);
                if (d < fd) {
                    fd = d;
                    far = static_cast<int>(g);
                }
            }
        if (far < 0) throw NumericalFailure{};  // the eye sees the whole hull
        const int hid = ++mark_;
        std::vector<int> hidden{far};
        tris_[far].mark = hid;
        for (std::size_t k = 0; k < hidden.size(); ++k)
            for (int g : tris_[hidden[k]].adj)
                if (tris_[g].mark != vis && tris_[g].mark != hid) {
                    tris_[g].mark = hid;
                    hidden.push_back(g);
                }
        for (std::size_t g = 0; g < tris_.size(); ++g)
            if (tris_[g].alive && tris_[g].mark != vis && tris_[g].mark != hid) {
                tris_[g].mark = vis;
                visible.push_back(static_cast<int>(g));
            }
        if (!find_horizon()) throw NumericalFailure{};
    }

    // 4. Orphaned conflict points, then retire the visible triangles.
    std::vector<int> orphans;
    for (int f : visible) {
        for (int i : tris_[f].outside)
            if (i != eye) orphans.push_back(i);
        tris_[f].outside.clear();
        tris_[f].outside.shrink_to_fit();
        tris_[f].alive = false;
    }

    // 5. Cone from the eye to the horizon. Triangle k = (a_k, b_k, eye) keeps the orientation of the
    //    visible triangle it replaces; its edge 1 (b_k -> eye) meets the next cone triangle's edge 2.
    const int first = static_cast<int>(tris_.size());
    const int m = static_cast<int>(loop.size());
    for (int k = 0; k < m; ++k) {
        const HEdge& h = horizon[loop[k]];
        int t = add_tri(h.a, h.b, eye);
        tris_[t].adj[0] = h.hidden_tri;
        tris_[h.hidden_tri].adj[h.hidden_edge] = t;
    }
    for (int k = 0; k < m; ++k) {
        tris_[first + k].adj[1] = first + (k + 1) % m;
        tris_[first + k].adj[2] = first + (k + m - 1) % m;
    }

    // 6. Reassign orphans to the new triangle they are furthest above; the rest are inside.
    for (int i : orphans) {
        int bf = -1;
        double bd = 0;
        for (int k = 0; k < m; ++k) {
            double d = dist(tris_[first + k], i);
            if (d > bd) {
                bd = d;
                bf = first + k;
            }
        }
        if (bf >= 0) tris_[bf].outside.push_back(i);
    }
}

void QuickHull::extract(ConvexHullData& out) const {
    // --- group coplanar triangles: seeds in order of decreasing area, grown across edges while every
    //     vertex of the neighbour stays within tol of the seed plane.
    std::vector<int> alive;
    for (std::size_t t = 0; t < tris_.size(); ++t)
        if (tris_[t].alive) alive.push_back(static_cast<int>(t));
    std::stable_sort(alive.begin(), alive.end(), [&](int a, int b) { return tris_[a].area2 > tris_[b].area2; });
    std::vector<int> group(tris_.size(), -1);
    std::vector<std::vector<int>> groups;
    for (int s : alive) {
        if (group[s] >= 0) continue;
        const int g = static_cast<int>(groups.size());
        groups.push_back({s});
        group[s] = g;
        const HullTri& seed = tris_[s];
        std::vector<int>& members = groups.back();
        for (std::size_t k = 0; k < members.size(); ++k)
            for (int nb : tris_[members[k]].adj) {
                if (group[nb] >= 0 || tris_[nb].n.dot(seed.n) <= 0) continue;
                bool coplanar = true;
                for (int v : tris_[nb].v) coplanar = coplanar && std::abs(seed.n.dot(p_[v]) - seed.d) <= tol_;
                if (coplanar) {
                    group[nb] = g;
                    members.push_back(nb);
                }
            }
    }

    // --- each group's boundary edges chained into one counter-clockwise loop. A group whose boundary is
    //     not a single simple loop (possible only with pathological noise) falls back to its triangles.
    std::vector<std::vector<int>> polys;
    for (std::size_t g = 0; g < groups.size(); ++g) {
        std::unordered_map<int, int> next;
        bool simple = true;
        for (int t : groups[g])
            for (int e = 0; e < 3; ++e)
                if (group[tris_[t].adj[e]] != static_cast<int>(g))
                    simple = next.emplace(tris_[t].v[e], tris_[t].v[(e + 1) % 3]).second && simple;
        std::vector<int> poly;
        if (simple && !next.empty()) {
            int start = next.begin()->first, v = start;
            do {
                poly.push_back(v);
                auto it = next.find(v);
                if (it == next.end()) break;
                v = it->second;
            } while (v != start && poly.size() <= next.size());
            simple = v == start && poly.size() == next.size();
        }
        if (simple) {
            polys.push_back(std::move(poly));
        } else {
            for (int t : groups[g]) polys.push_back({tris_[t].v[0], tris_[t].v[1], tris_[t].v[2]});
        }
    }

    // --- a vertex on only two faces lies on their common edge: it is not a corner, drop it.
    std::unordered_map<int, int> face_count;
    for (const auto& poly : polys)
        for (int v : poly) ++face_count[v];
    for (auto& poly : polys) {
        std::vector<int> kept;
        for (int v : poly)
            if (face_count[v] >= 3) kept.push_back(v);
        if (kept.size() >= 3) poly = std::move(kept);
    }

    // --- compact the vertex set (sorted by input index for determinism).
    std::vector<int> used;
    for (const auto& poly : polys) used.insert(used.end(), poly.begin(), poly.end());
    std::sort(used.begin(), used.end());
    used.erase(std::unique(used.begin(), used.end()), used.end());
    if (used.size() > kMaxHullVertices)
        throw ShapeError("convex hull has " + std::to_string(used.size()) + " vertices; at most " +
                         std::to_string(kMaxHullVertices) + " are supported (16-bit indices)");
    std::unordered_map<int, std::uint16_t> remap;
    out.vertices.clear();
    for (std::size_t i = 0; i < used.size(); ++i) {
        remap[used[i]] = static_cast<std::uint16_t>(i);
        out.vertices.push_back(p_[used[i]].cast<Real>());
    }

    // --- faces: Newell's normal (robust for a slightly non-planar polygon), offset = mean of the vertices.
    out.faces.clear();
    out.edges.clear();
    for (const auto& poly : polys) {
        V3 n = V3::Zero();
        V3 c = V3::Zero();
        const std::size_t k = poly.size();
        for (std::size_t i = 0; i < k; ++i) {
            // Newell's vector: sum of (a - o) x (b - o), twice the area times the normal; taken about the
            // first vertex o so a hull far from the origin loses no precision.
            const V3& o = p_[poly[0]];
            n += (p_[poly[i]] - o).cross(p_[poly[(i + 1) % k]] - o);
            c += p_[poly[i]];
        }
        n.normalize();
        c /= double(k);
        ConvexHullData::Face face;
        face.normal = n.cast<Real>();
        face.offset = Real(n.dot(c));
        for (int v : poly) face.verts.push_back(remap[v]);
        for (std::size_t i = 0; i < k; ++i) {
            std::uint16_t a = face.verts[i], b = face.verts[(i + 1) % k];
            if (a < b) out.edges.emplace_back(a, b);  // each undirected edge is seen once in each direction
        }
        out.faces.push_back(std::move(face));
    }
    std::sort(out.edges.begin(), out.edges.end());

    // --- volume centroid: sum of tetrahedra (reference point, fan triangle), divergence theorem.
    V3 ref = V3::Zero();
    for (int v : used) ref += p_[v];
    ref /= double(used.size());
    double vol = 0;
    V3 cen = V3::Zero();
    for (const auto& poly : polys)
        for (std::size_t i = 1; i + 1 < poly.size(); ++i) {
            const V3 &a = p_[poly[0]], &b = p_[poly[i]], &c = p_[poly[i + 1]];
            double v6 = (a - ref).dot((b - ref).cross(c - ref));
            vol += v6;
            cen += v6 * (ref + a + b + c) * 0.25;
        }
    out.centroid = (vol > 0 ? V3(cen / vol) : ref).cast<Real>();
}

}  // namespace

Shape make_convex_hull(const std::vector<Vec3>& points, Real flatness) {
    if (points.size() < 4)
        throw ShapeError("convex hull needs at least 4 points, got " + std::to_string(points.size()));
    std::vector<V3> pts;
    pts.reserve(points.size());
    Eigen::AlignedBox<double, 3> box;
    for (std::size_t i = 0; i < points.size(); ++i) {
        if (!is_finite(points[i]))
            throw ShapeError("convex hull point " + std::to_string(i) + " is not finite (" + to_text(points[i].x()) +
                             ", " + to_text(points[i].y()) + ", " + to_text(points[i].z()) + ")");
        pts.push_back(points[i].cast<double>());
        box.extend(pts.back());
    }
    // Size of the cloud: its bounding-box diagonal, plus an eighth of its distance from the origin
    // because the vertices are stored in the caller's frame and rounded there (so tol stays >= 8 ulps of
    // the coordinates).
    const double scale = box.diagonal().norm() + box.center().norm() * 0.125;
    double tol = kRelativeTolerance * scale;
    if (!(flatness >= 0) || !std::isfinite(double(flatness)))
        throw ShapeError("convex hull flatness must be finite and >= 0, got " + to_text(flatness));
    tol = std::max(tol, double(flatness) * box.diagonal().norm());

    auto hull = std::make_shared<ConvexHullData>();
    for (int attempt = 0;; ++attempt, tol *= kToleranceGrowth) {
        if (attempt == kAttempts)
            throw ShapeError("convex hull construction failed: the points are numerically degenerate (nearly "
                             "coplanar or collinear beyond what a tolerance of " + to_text(tol / kToleranceGrowth) +
                             " resolves)");
        QuickHull qh(pts, tol);
        try {
            qh.build();
        } catch (const NumericalFailure&) {
            continue;
        }
        if (!qh.locally_convex()) continue;
        qh.extract(*hull);
        break;
    }

    Shape s;
    s.type = ShapeType::ConvexHull;
    s.hull = std::move(hull);
    return s;
}

}  // namespace sinew
