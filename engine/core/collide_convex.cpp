// General convex contact: narrow::convex_convex (any pair of sphere, box, capsule, hull) and
// narrow::convex_triangle (a convex shape against one world-space triangle).
//
// Two stages, the split used by Bullet and Box2D:
//  1. Normal and depth. Every shape is seen as a *core* (sphere: a point, capsule: a segment, box, hull,
//     triangle: themselves) swept by a sphere of `radius` (van den Bergen, "Collision Detection in
//     Interactive 3D Environments", 2003, ch. 4). GJK (Gilbert, Johnson & Keerthi 1988; the sub-simplex
//     solver is Ericson's "Real-Time Collision Detection" 5.1.5) gives the exact distance between the
//     cores; if they are apart, depth = radii - distance and the normal is the closest-point direction,
//     which also covers separated shapes inside `margin` (speculative contacts, negative depth). Only if
//     the cores overlap does libccd's GJK+EPA (van den Bergen 2001) give the penetration normal and
//     depth.
//  2. Manifold. A single normal gives a single point, which lets a box resting on a hull rock. As in
//     Box2D's b2CollidePolygons and Bullet's btPolyhedralContactClipping, the face of either shape most
//     aligned with the normal becomes the *reference* face; the *incident* feature of the other shape
//     (its most anti-aligned face, a capsule's segment) is clipped against the side planes of the
//     reference face (Sutherland & Hodgman 1974); points below the reference plane (within margin) are
//     kept and reduced to at most four: the deepest, then the ones spreading the contact area most.
//     Edge-edge contacts (the normal is not close to any face normal) keep the single GJK/EPA point, as
//     do face manifolds that miss the deepest overlap along their normal (an edge contact nearly
//     parallel to a face).
//  libccd's EPA can stop short on deep overlaps; its answer is checked against the exact overlap of the
//  support functions along its normal and, if short, replaced by the least overlapping of MPR's normal
//  and the face normals (conservative: never less deep than the true penetration).
//  convex_triangle treats the triangle as a one-face polygon and, for a shape on its front side, uses
//  the face normal whenever the shape's incident feature overlaps the face, against internal-edge snags.
//
// Everything inside is computed in double whatever `Real` is: GJK's sub-simplex solver loses about half
// the digits on nearly touching shapes, and libccd works in double anyway.
#include <ccd/ccd.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "engine/core/narrowphase.hpp"

namespace sinew::narrow {

namespace {

using V3d = Eigen::Vector3d;
using M3d = Eigen::Matrix3d;

// A face is a reference-face candidate only if its normal is within ~0.8 degrees of the contact normal.
// A face contact's normal (vertex-face, face-face) *is* the face normal up to EPA's tolerance; anything
// further off is an edge-edge or edge-vertex contact where one point is the honest answer, and snapping
// it to a face would under-report the overlap along the snapped normal.
constexpr double kFaceAlignCos = 0.9999;
// When both shapes have an acceptable face, B's becomes the reference only if clearly better aligned
// than A's (by ~0.26 degrees), so the choice, and with it the feature ids, does not flip between two
// nearly parallel faces under tiny motion (the bias of Box2D's b2CollidePolygons).
constexpr double kReferenceBias = 1e-5;
// Cores closer than this fraction of the shapes' size are treated as overlapping: the closest-point
// direction of a shorter vector is no longer trustworthy, EPA takes over.
constexpr double kTouchFraction = 1e-9;

enum class Kind { Sphere, Capsule, Box, Hull, Triangle };

/// A convex shape placed in the world, as the contact code sees it: a core swept by a sphere of `radius`.
struct Placed {
    Kind kind = Kind::Sphere;
    const Shape* shape = nullptr;
    M3d R = M3d::Identity();  ///< local -> world rotation
    V3d p = V3d::Zero();      ///< local -> world translation
    V3d tri[3];               ///< triangle corners, world
    V3d tri_n = V3d::UnitZ();  ///< triangle unit normal (right-handed a, b, c)
    double radius = 0;
    double size = 0;  ///< bounding radius about p; scales the tolerances

    int face_count() const {
        switch (kind) {
            case Kind::Box: return 6;
            case Kind::Hull: return static_cast<int>(shape->hull->faces.size());
            case Kind::Triangle: return 2;
            default: return 0;
        }
    }

    /// Furthest point of the core along world direction d; `feature` gets its vertex index.
    V3d core_support(const V3d& d, int* feature = nullptr) const {
        int f = 0;
        V3d out;
        switch (kind) {
            case Kind::Sphere: out = p; break;
            case Kind::Capsule: {
                const double s = d.dot(R.col(1)) >= 0 ? 1 : -1;
                f = s > 0 ? 1 : 0;
                out = p + R.col(1) * (s * double(shape->half_height));
                break;
            }
            case Kind::Box: {
                const V3d dl = R.transpose() * d;
                V3d x;
                for (int k = 0; k < 3; ++k) {
                    x[k] = dl[k] >= 0 ? double(shape->half_extents[k]) : -double(shape->half_extents[k]);
                    if (dl[k] >= 0) f |= 1 << k;
                }
                out = p + R * x;
                break;
            }
            case Kind::Hull: {
                const V3d dl = R.transpose() * d;
                f = shape->hull->support_index(dl.cast<Real>());
                out = p + R * shape->hull->vertices[f].cast<double>();
                break;
            }
            case Kind::Triangle: {
                double b0 = tri[0].dot(d), b1 = tri[1].dot(d), b2 = tri[2].dot(d);
                f = b0 >= b1 ? (b0 >= b2 ? 0 : 2) : (b1 >= b2 ? 1 : 2);
                out = tri[f];
                break;
            }
        }
        if (feature) *feature = f;
        return out;
    }

    /// Outward world normal of face i and its plane offset (normal . x = offset).
    V3d face_normal(int i, double* offset = nullptr) const {
        V3d n;
        double off = 0;
        switch (kind) {
            case Kind::Box: {
                const int axis = i >> 1;
                const double s = (i & 1) ? -1 : 1;
                n = R.col(axis) * s;
                off = double(shape->half_extents[axis]) + n.dot(p);
                break;
            }
            case Kind::Hull: {
                const ConvexHullData::Face& f = shape->hull->faces[i];
                n = R * f.normal.cast<double>();
                off = double(f.offset) + n.dot(p);
                break;
            }
            default:  // triangle: face 0 is the front (tri_n), face 1 the back
                n = i == 0 ? tri_n : V3d(-tri_n);
                off = n.dot(tri[0]);
                break;
        }
        if (offset) *offset = off;
        return n;
    }

    /// The face most aligned with world direction d, and that alignment (cosine).
    int best_face(const V3d& d, double* align) const {
        int best = -1;
        double best_dot = -2;
        if (kind == Kind::Hull) {
            const Vec3 dl = (R.transpose() * d).cast<Real>();
            const auto& faces = shape->hull->faces;
            for (int i = 0; i < static_cast<int>(faces.size()); ++i) {
                const double v = double(faces[i].normal.dot(dl));
                if (v > best_dot) {
                    best_dot = v;
                    best = i;
                }
            }
        } else {
            for (int i = 0; i < face_count(); ++i) {
                const double v = face_normal(i).dot(d);
                if (v > best_dot) {
                    best_dot = v;
                    best = i;
                }
            }
        }
        *align = best_dot;
        return best;
    }

    /// Vertices of face i, counter-clockwise seen from outside, with their vertex indices as codes.
    template <class Out>
    void face_polygon(int i, Out&& out) const {
        switch (kind) {
            case Kind::Box: {
                // Corners of the face, ordered by the in-face axes u, w with u x w = the face axis.
                const int axis = i >> 1, u = (axis + 1) % 3, w = (axis + 2) % 3;
                const double s = (i & 1) ? -1 : 1;
                static const double su[4] = {1, -1, -1, 1}, sw[4] = {1, 1, -1, -1};
                for (int k = 0; k < 4; ++k) {
                    const int kk = s > 0 ? k : 3 - k;
                    V3d x;
                    x[axis] = s * double(shape->half_extents[axis]);
                    x[u] = su[kk] * double(shape->half_extents[u]);
                    x[w] = sw[kk] * double(shape->half_extents[w]);
                    const int id = (x[0] > 0 ? 1 : 0) | (x[1] > 0 ? 2 : 0) | (x[2] > 0 ? 4 : 0);
                    out(V3d(p + R * x), static_cast<std::uint32_t>(id));
                }
                break;
            }
            case Kind::Hull:
                for (std::uint16_t v : shape->hull->faces[i].verts)
                    out(V3d(p + R * shape->hull->vertices[v].cast<double>()), std::uint32_t(v));
                break;
            case Kind::Triangle:
                if (i == 0) {
                    out(tri[0], 0u);
                    out(tri[1], 1u);
                    out(tri[2], 2u);
                } else {
                    out(tri[0], 0u);
                    out(tri[2], 2u);
                    out(tri[1], 1u);
                }
                break;
            default: break;
        }
    }

    V3d center() const {
        if (kind == Kind::Triangle) return (tri[0] + tri[1] + tri[2]) / 3.0;
        if (kind == Kind::Hull) return p + R * shape->hull->centroid.cast<double>();
        return p;
    }
};

Placed place(const Shape& s, const Transform& xf) {
    Placed o;
    o.shape = &s;
    o.R = xf.q.normalized().toRotationMatrix().cast<double>();
    o.p = xf.p.cast<double>();
    switch (s.type) {
        case ShapeType::Sphere:
            o.kind = Kind::Sphere;
            o.radius = s.radius;
            o.size = s.radius;
            break;
        case ShapeType::Capsule:
            o.kind = Kind::Capsule;
            o.radius = s.radius;
            o.size = double(s.half_height) + s.radius;
            break;
        case ShapeType::Box:
            o.kind = Kind::Box;
            o.size = s.half_extents.cast<double>().norm();
            break;
        case ShapeType::ConvexHull:
            o.kind = Kind::Hull;
            for (const Vec3& v : s.hull->vertices) o.size = std::max(o.size, double(v.norm()));
            break;
        default:
            throw ShapeError(std::string("convex contact is not defined for a ") + shape_type_name(s.type));
    }
    return o;
}

// ------------------------------------------------------------------------------------------------------
// GJK distance between the cores.

struct SimplexVertex {
    V3d w, a, b;  ///< w = a - b: a point of the Minkowski difference and its two witnesses
};

struct Simplex {
    SimplexVertex v[4];
    double lambda[4];
    int n = 0;
};

/// Keeps the listed vertices with their barycentric weights.
void keep(Simplex& s, std::initializer_list<std::pair<int, double>> kept) {
    SimplexVertex tmp[4];
    double lam[4];
    int n = 0;
    for (const auto& [i, l] : kept) {
        tmp[n] = s.v[i];
        lam[n++] = l;
    }
    for (int i = 0; i < n; ++i) {
        s.v[i] = tmp[i];
        s.lambda[i] = lam[i];
    }
    s.n = n;
}

void solve_segment(Simplex& s, int i, int j) {
    const V3d& a = s.v[i].w;
    const V3d ab = s.v[j].w - a;
    const double den = ab.squaredNorm();
    const double t = den > 0 ? -a.dot(ab) / den : 0;
    if (t <= 0) return keep(s, {{i, 1.0}});
    if (t >= 1) return keep(s, {{j, 1.0}});
    keep(s, {{i, 1 - t}, {j, t}});
}

/// Closest point of triangle (i, j, k) to the origin, by Voronoi regions (Ericson 5.1.5).
void solve_triangle(Simplex& s, int i, int j, int k) {
    const V3d &a = s.v[i].w, &b = s.v[j].w, &c = s.v[k].w;
    const V3d ab = b - a, ac = c - a;
    const double d1 = -ab.dot(a), d2 = -ac.dot(a);
    if (d1 <= 0 && d2 <= 0) return keep(s, {{i, 1.0}});
    const double d3 = -ab.dot(b), d4 = -ac.dot(b);
    if (d3 >= 0 && d4 <= d3) return keep(s, {{j, 1.0}});
    const double vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0) {
        const double t = d1 / (d1 - d3);
        return keep(s, {{i, 1 - t}, {j, t}});
    }
    const double d5 = -ab.dot(c), d6 = -ac.dot(c);
    if (d6 >= 0 && d5 <= d6) return keep(s, {{k, 1.0}});
    const double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) {
        const double t = d2 / (d2 - d6);
        return keep(s, {{i, 1 - t}, {k, t}});
    }
    const double va = d3 * d6 - d5 * d4;
    if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
        const double t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return keep(s, {{j, 1 - t}, {k, t}});
    }
    const double sum = va + vb + vc;
    if (!(sum > 0)) {  // collinear corners: the best of the three edges
        Simplex best = s;
        double best_d = kRealMax;
        const int e[3][2] = {{i, j}, {i, k}, {j, k}};
        for (const auto& ed : e) {
            Simplex t = s;
            solve_segment(t, ed[0], ed[1]);
            V3d q = V3d::Zero();
            for (int m = 0; m < t.n; ++m) q += t.lambda[m] * t.v[m].w;
            if (q.squaredNorm() < best_d) {
                best_d = q.squaredNorm();
                best = t;
            }
        }
        s = best;
        return;
    }
    keep(s, {{i, va / sum}, {j, vb / sum}, {k, vc / sum}});
}

/// Tetrahedron: the origin inside means overlap (returns false); else the closest of the faces that
/// the origin is outside of.
bool solve_tetrahedron(Simplex& s) {
    static const int faces[4][4] = {{0, 1, 2, 3}, {0, 3, 1, 2}, {0, 2, 3, 1}, {1, 3, 2, 0}};
    Simplex best = s;
    double best_d = -1;
    for (const auto& f : faces) {
        const V3d &a = s.v[f[0]].w, &b = s.v[f[1]].w, &c = s.v[f[2]].w, &d = s.v[f[3]].w;
        const V3d n = (b - a).cross(c - a);
        const double side_o = -n.dot(a), side_d = n.dot(d - a);
        const bool flat = std::abs(side_d) <= 1e-12 * n.norm() * (d - a).norm();
        if (!flat && side_o * side_d >= 0) continue;  // origin on the inner side of this face
        Simplex t = s;
        solve_triangle(t, f[0], f[1], f[2]);
        V3d q = V3d::Zero();
        for (int m = 0; m < t.n; ++m) q += t.lambda[m] * t.v[m].w;
        if (best_d < 0 || q.squaredNorm() < best_d) {
            best_d = q.squaredNorm();
            best = t;
        }
    }
    if (best_d < 0) return false;
    s = best;
    return true;
}

struct GjkResult {
    bool overlap = false;
    double distance = 0;
    V3d pa = V3d::Zero(), pb = V3d::Zero();  ///< closest points of the cores
};

/// Distance between the cores of A (translated by `shift_a`) and B.
GjkResult gjk_distance(const Placed& A, const Placed& B, const V3d& shift_a) {
    const double touch = kTouchFraction * (A.size + B.size + 1e-30);
    auto support = [&](const V3d& d, SimplexVertex& sv) {
        sv.a = A.core_support(d) + shift_a;
        sv.b = B.core_support(-d);
        sv.w = sv.a - sv.b;
    };
    Simplex s;
    V3d d = B.center() - A.center() - shift_a;
    if (d.squaredNorm() == 0) d = V3d::UnitX();
    support(-d, s.v[0]);
    s.lambda[0] = 1;
    s.n = 1;
    V3d v = s.v[0].w;
    GjkResult r;
    for (int iter = 0; iter < 64; ++iter) {
        const double vv = v.squaredNorm();
        if (vv <= touch * touch) {
            r.overlap = true;
            return r;
        }
        SimplexVertex w;
        support(-v, w);
        // Converged: the support point gets no closer along v than v itself (relative test).
        if (vv - v.dot(w.w) <= 1e-12 * vv) break;
        bool repeated = false;
        for (int i = 0; i < s.n; ++i) repeated = repeated || (s.v[i].w - w.w).squaredNorm() <= 1e-24 * vv;
        if (repeated) break;
        s.v[s.n++] = w;
        if (s.n == 2) solve_segment(s, 0, 1);
        else if (s.n == 3) solve_triangle(s, 0, 1, 2);
        else if (!solve_tetrahedron(s)) {
            r.overlap = true;
            return r;
        }
        V3d nv = V3d::Zero();
        for (int i = 0; i < s.n; ++i) nv += s.lambda[i] * s.v[i].w;
        const bool progress = nv.squaredNorm() < vv;
        v = nv;
        if (!progress) break;  // rounding: no closer than before, v is as good as it gets
    }
    r.pa = V3d::Zero();
    r.pb = V3d::Zero();
    for (int i = 0; i < s.n; ++i) {
        r.pa += s.lambda[i] * s.v[i].a;
        r.pb += s.lambda[i] * s.v[i].b;
    }
    r.distance = (r.pa - r.pb).norm();
    r.overlap = r.distance <= touch;
    return r;
}

// ------------------------------------------------------------------------------------------------------
// libccd penetration for overlapping cores.

struct CcdObject {
    const Placed* shape;
    bool round;           ///< include the sphere radius (full shape) or not (core)
    double extra_radius;  ///< additional rounding, for the touching-contact retry
};

void ccd_support(const void* obj, const ccd_vec3_t* dir, ccd_vec3_t* out) {
    const CcdObject& o = *static_cast<const CcdObject*>(obj);
    const V3d d(dir->v[0], dir->v[1], dir->v[2]);
    V3d s = o.shape->core_support(d);
    const double r = (o.round ? o.shape->radius : 0.0) + o.extra_radius;
    const double len = d.norm();
    if (r > 0 && len > 0) s += d * (r / len);
    out->v[0] = s.x();
    out->v[1] = s.y();
    out->v[2] = s.z();
}

void ccd_center(const void* obj, ccd_vec3_t* out) {
    const V3d c = static_cast<const CcdObject*>(obj)->shape->center();
    out->v[0] = c.x();
    out->v[1] = c.y();
    out->v[2] = c.z();
}

/// Penetration normal (A to B) and depth of the shapes by libccd: GJK+EPA, or MPR if `mpr`. `round`: run
/// on the full shapes rather than on the cores. Returns false if libccd finds no overlap or no usable
/// direction.
bool ccd_penetration(const Placed& A, const Placed& B, bool round, double extra, bool mpr, V3d& n, double& depth,
                     V3d& pos) {
    CcdObject oa{&A, round, extra}, ob{&B, round, 0.0};
    ccd_t ccd;
    CCD_INIT(&ccd);
    ccd.support1 = ccd_support;
    ccd.support2 = ccd_support;
    ccd.center1 = ccd_center;
    ccd.center2 = ccd_center;
    ccd.max_iterations = 200;
    const double scale = A.size + B.size;
    ccd.epa_tolerance = 1e-7 * scale;
    ccd.mpr_tolerance = 1e-7 * scale;
    ccd.dist_tolerance = 1e-10 * scale;
    ccd_real_t d = 0;
    ccd_vec3_t dir, p;
    const int rc = mpr ? ccdMPRPenetration(&oa, &ob, &ccd, &d, &dir, &p) : ccdGJKPenetration(&oa, &ob, &ccd, &d, &dir, &p);
    if (rc != 0) return false;
    // libccd: translating B by depth * dir separates the shapes, so dir points from A to B.
    n = V3d(dir.v[0], dir.v[1], dir.v[2]);
    const double len = n.norm();
    if (!std::isfinite(len) || len < 0.5 || !std::isfinite(d)) return false;
    n /= len;
    depth = d - extra;
    pos = V3d(p.v[0], p.v[1], p.v[2]);
    return true;
}

// ------------------------------------------------------------------------------------------------------
// Stage 1: normal, depth and witness points.

/// Overlap of the projections of A and B on unit direction n (A to B): how far B must move along n
/// before the projections separate. The penetration depth if n is the minimum-translation direction, an
/// upper bound for any other n.
double overlap(const Placed& A, const Placed& B, const V3d& n) {
    return n.dot(A.core_support(n)) - n.dot(B.core_support(-n)) + A.radius + B.radius;
}

struct ContactQuery {
    V3d n = V3d::UnitY();  ///< unit, from A to B
    double depth = 0;      ///< > 0 penetrating
    V3d pa = V3d::Zero(), pb = V3d::Zero();  ///< deepest / closest surface points of A and of B
};

bool query_contact(const Placed& A, const Placed& B, double margin, ContactQuery& q) {
    const double rsum = A.radius + B.radius;
    GjkResult g = gjk_distance(A, B, V3d::Zero());
    if (!g.overlap) {
        const double sep = g.distance - rsum;
        if (sep > margin) return false;
        q.n = (g.pb - g.pa) / g.distance;
        q.depth = -sep;
        q.pa = g.pa + A.radius * q.n;
        q.pb = g.pb - B.radius * q.n;
        return true;
    }

    // Cores overlap. EPA on the cores is exact for polytopes; it needs a solid Minkowski difference, so
    // if neither core is a solid (point, segment, triangle pairs) run it on the rounded shapes instead.
    const bool solid_core = A.kind == Kind::Box || A.kind == Kind::Hull || B.kind == Kind::Box || B.kind == Kind::Hull;
    // Overlap of the full shapes along unit n: how far B must move along n to come free. Exact for any n.
    auto overlap_along = [&](const V3d& dir) { return overlap(A, B, dir); };
    V3d n = V3d::UnitY(), pos = 0.5 * (A.center() + B.center());
    double d = 0;
    bool ok = ccd_penetration(A, B, !solid_core, 0.0, false, n, d, pos);
    if (!ok) {
        // Exactly touching cores can leave EPA without a usable direction; rounding A slightly makes the
        // overlap proper, and the rounding is subtracted from the depth.
        ok = ccd_penetration(A, B, !solid_core, 1e-4 * (A.size + B.size), false, n, d, pos);
    }
    double depth = ok ? overlap_along(n) : std::numeric_limits<double>::infinity();
    if (!ok || depth > (solid_core ? d + rsum : d) + 1e-5 * (A.size + B.size)) {
        // libccd's EPA can stop short on a deep overlap: its depth is then below the overlap along its
        // own normal. Fall back to the least overlapping of MPR's direction (Snethen, "XenoCollide", Game
        // Programming Gems 7) and the face normals of both shapes: not always the minimum translation
        // (edge-edge axes are not tried), but a valid, conservative one.
        auto consider = [&](const V3d& dir) {
            const double ov = overlap_along(dir);
            if (ov < depth) {
                depth = ov;
                n = dir;
            }
        };
        V3d mn, mpos;
        double md = 0;
        if (ccd_penetration(A, B, !solid_core, 0.0, true, mn, md, mpos)) consider(mn);
        for (int i = 0; i < A.face_count(); ++i) consider(A.face_normal(i));
        for (int i = 0; i < B.face_count(); ++i) consider(-B.face_normal(i));
        if (!std::isfinite(depth)) {  // two round shapes with coincident cores: any direction will do
            n = B.center() - A.center();
            n = n.squaredNorm() > 0 ? V3d(n.normalized()) : V3d::UnitY();
            depth = overlap_along(n);
        }
    }
    if (-depth > margin) return false;
    q.n = n;
    q.depth = depth;

    // Witness points: move A back along n until the shapes are just apart and ask GJK for the closest
    // points; moved forward again they are where the shapes overlap deepest. Exact for vertex-face and
    // edge-edge contacts, which EPA's position (an average of its last face) is not.
    const double shift = std::max(depth, 0.0) + 1e-3 * (A.size + B.size);
    GjkResult w = gjk_distance(A, B, -shift * n);
    if (!w.overlap) {
        const V3d nw = (w.pb - w.pa) / w.distance;
        q.pa = w.pa + shift * n + A.radius * nw;
        q.pb = w.pb - B.radius * nw;
    } else {
        q.pa = pos + 0.5 * depth * n;
        q.pb = pos - 0.5 * depth * n;
    }
    return true;
}

// ------------------------------------------------------------------------------------------------------
// Stage 2: reference-face clipping.

struct ClipVertex {
    V3d p;
    std::uint32_t code;  ///< which incident vertex, or which incident edge crossed which side plane
};

std::uint32_t mix(std::uint32_t h, std::uint32_t x) {
    // Combine step of boost::hash_combine followed by a murmur3 finaliser: cheap and well spread.
    h ^= x + 0x9e3779b9u + (h << 6) + (h >> 2);
    h ^= h >> 16;
    h *= 0x85ebca6bu;
    h ^= h >> 13;
    return h;
}

std::uint32_t fold14(std::uint32_t h) { return (h ^ (h >> 14) ^ (h >> 28)) & 0x3FFFu; }

struct Scratch {
    std::vector<ClipVertex> a, b;
    std::vector<V3d> ref;
};

Scratch& scratch() {
    // Reused between calls: no heap allocation once the buffers have grown to the largest face.
    thread_local Scratch s;
    return s;
}

/// Sutherland-Hodgman: keeps the part of `in` with plane_n . x <= plane_d. `side` names the plane in the
/// codes of new vertices. Points and segments (1-2 vertices) are clipped as such, not as polygons.
void clip(const std::vector<ClipVertex>& in, std::vector<ClipVertex>& out, const V3d& plane_n, double plane_d,
          std::uint32_t side) {
    out.clear();
    const std::size_t n = in.size();
    if (n == 0) return;
    auto cut = [&](const ClipVertex& s, double ds, const ClipVertex& e, double de) {
        const double t = ds / (ds - de);
        out.push_back({s.p + t * (e.p - s.p), mix(mix(mix(0x51de0000u, side), s.code), e.code)});
    };
    if (n == 1) {
        if (plane_n.dot(in[0].p) <= plane_d) out.push_back(in[0]);
        return;
    }
    if (n == 2) {
        const double d0 = plane_n.dot(in[0].p) - plane_d, d1 = plane_n.dot(in[1].p) - plane_d;
        if (d0 <= 0) out.push_back(in[0]);
        if ((d0 < 0 && d1 > 0) || (d0 > 0 && d1 < 0)) cut(in[0], d0, in[1], d1);
        if (d1 <= 0) out.push_back(in[1]);
        return;
    }
    const ClipVertex* s = &in[n - 1];
    double ds = plane_n.dot(s->p) - plane_d;
    for (std::size_t i = 0; i < n; ++i) {
        const ClipVertex& e = in[i];
        const double de = plane_n.dot(e.p) - plane_d;
        // Intersections only for strict crossings: a vertex exactly on the plane is kept once, not twice.
        if ((ds < 0 && de > 0) || (ds > 0 && de < 0)) cut(*s, ds, e, de);
        if (de <= 0) out.push_back(e);
        s = &e;
        ds = de;
    }
}

struct Candidate {
    V3d position;
    double depth;
    std::uint32_t id;
};

/// Reduces to at most four points: the deepest, the one furthest from it, the one making the largest
/// triangle with those, and the one furthest outside that triangle (the area-maximising choice used by
/// Bullet's contact cache and Box2D v3).
int reduce(Candidate* c, int n, const V3d& normal) {
    if (n <= Manifold::kMaxPoints) return n;
    auto take = [&](int slot, int idx) { std::swap(c[slot], c[idx]); };
    int best = 0;
    for (int i = 1; i < n; ++i)
        if (c[i].depth > c[best].depth) best = i;
    take(0, best);
    best = 1;
    for (int i = 2; i < n; ++i)
        if ((c[i].position - c[0].position).squaredNorm() > (c[best].position - c[0].position).squaredNorm()) best = i;
    take(1, best);
    auto area = [&](const V3d& a, const V3d& b, const V3d& p) { return (b - a).cross(p - a).dot(normal); };
    best = 2;
    for (int i = 3; i < n; ++i)
        if (std::abs(area(c[0].position, c[1].position, c[i].position)) >
            std::abs(area(c[0].position, c[1].position, c[best].position)))
            best = i;
    take(2, best);
    const double orient = area(c[0].position, c[1].position, c[2].position) >= 0 ? 1 : -1;
    best = -1;
    double best_out = 0;
    for (int i = 3; i < n; ++i) {
        const V3d& p = c[i].position;
        // Positive when p lies outside the triangle across some edge: how much area it would add.
        const double out = std::max({-orient * area(c[0].position, c[1].position, p),
                                     -orient * area(c[1].position, c[2].position, p),
                                     -orient * area(c[2].position, c[0].position, p)});
        if (out > best_out) {
            best_out = out;
            best = i;
        }
    }
    if (best < 0) return 3;
    take(3, best);
    return 4;
}

/// Clips the incident feature of `inc` against reference face `ref_face` of `ref` and writes the points
/// into m. `ref_is_a` orients the normal (the manifold's normal points from A to B).
bool clip_manifold(const Placed& ref, int ref_face, const Placed& inc, bool ref_is_a, double margin, Manifold& m) {
    Scratch& sc = scratch();
    double ref_d = 0;
    const V3d nr = ref.face_normal(ref_face, &ref_d);

    // Incident feature, on the incident shape's surface.
    sc.a.clear();
    std::uint32_t inc_face = 0;
    if (inc.kind == Kind::Sphere) {
        sc.a.push_back({inc.p - inc.radius * nr, 0u});
    } else if (inc.kind == Kind::Capsule) {
        const V3d axis = inc.R.col(1) * double(inc.shape->half_height);
        sc.a.push_back({inc.p - axis - inc.radius * nr, 0u});
        sc.a.push_back({inc.p + axis - inc.radius * nr, 1u});
    } else {
        double align = 0;
        inc_face = static_cast<std::uint32_t>(inc.best_face(-nr, &align));
        inc.face_polygon(static_cast<int>(inc_face), [&](const V3d& x, std::uint32_t id) { sc.a.push_back({x, id}); });
    }

    // Side planes of the reference face: through each edge, facing out of the face (edge x normal).
    sc.ref.clear();
    ref.face_polygon(ref_face, [&](const V3d& x, std::uint32_t) { sc.ref.push_back(x); });
    const std::size_t k = sc.ref.size();
    for (std::size_t j = 0; j < k && !sc.a.empty(); ++j) {
        const V3d& v0 = sc.ref[j];
        const V3d& v1 = sc.ref[(j + 1) % k];
        V3d sn = (v1 - v0).cross(nr);
        const double len = sn.norm();
        if (!(len > 1e-9 * ref.size)) continue;  // a vanishing edge has no direction; its neighbours clip
        sn /= len;
        clip(sc.a, sc.b, sn, sn.dot(v0), static_cast<std::uint32_t>(j));
        std::swap(sc.a, sc.b);
    }

    Candidate cand[64];
    int n = 0;
    const std::uint32_t ref_bits = static_cast<std::uint32_t>(ref_face) & 0x3FFFu;
    for (const ClipVertex& v : sc.a) {
        const double sep = nr.dot(v.p) - ref_d;  // > 0: the incident point is above the reference face
        if (sep > margin) continue;
        const std::uint32_t inc_bits = fold14(mix(mix(0x1dc0u, inc_face), v.code));
        Candidate c{v.p - 0.5 * sep * nr, -sep,
                    ref_is_a ? make_feature_id(1, ref_bits, inc_bits) : make_feature_id(2, inc_bits, ref_bits)};
        if (n < 64) {
            cand[n++] = c;
        } else {  // a huge incident face: keep the 64 deepest, plenty to choose four from
            int shallow = 0;
            for (int i = 1; i < n; ++i)
                if (cand[i].depth < cand[shallow].depth) shallow = i;
            if (c.depth > cand[shallow].depth) cand[shallow] = c;
        }
    }
    if (n == 0) return false;
    const V3d normal = ref_is_a ? nr : V3d(-nr);
    n = reduce(cand, n, normal);
    m.clear();
    m.normal = normal.cast<Real>();
    for (int i = 0; i < n; ++i) m.add(cand[i].position.cast<Real>(), Real(cand[i].depth), cand[i].id);
    return true;
}

/// Feature of a shape at a single-point contact with outward direction d: the face it touches with if one
/// is aligned with d (stable while the shape rests on it; the extreme vertex of a face would be a tie
/// that flickers), else the extreme vertex.
std::uint32_t touching_feature(const Placed& s, const V3d& d) {
    if (s.face_count() > 0) {
        double align = -2;
        const int f = s.best_face(d, &align);
        if (align >= kFaceAlignCos) return 0x2000u | static_cast<std::uint32_t>(f);
    }
    int v = 0;
    s.core_support(d, &v);
    return static_cast<std::uint32_t>(v);
}

void single_point(const Placed& A, const Placed& B, const ContactQuery& q, Manifold& m) {
    m.clear();
    m.normal = q.n.cast<Real>();
    m.add((0.5 * (q.pa + q.pb)).cast<Real>(), Real(q.depth),
          make_feature_id(3, touching_feature(A, q.n), touching_feature(B, -q.n)));
}

bool has_faces(const Placed& s) { return s.face_count() > 0; }

/// Stage 2 for a contact found by stage 1.
bool build_manifold(const Placed& A, const Placed& B, const ContactQuery& q, double margin, Manifold& m) {
    double align_a = -2, align_b = -2;
    const int fa = has_faces(A) ? A.best_face(q.n, &align_a) : -1;
    const int fb = has_faces(B) ? B.best_face(-q.n, &align_b) : -1;
    const bool ok_a = fa >= 0 && align_a >= kFaceAlignCos, ok_b = fb >= 0 && align_b >= kFaceAlignCos;
    const bool ref_is_a = ok_a && !(ok_b && align_b > align_a + kReferenceBias);
    // A sphere touches in one point: stage 1's point is exact.
    const bool incident_round = ref_is_a ? B.kind == Kind::Sphere : A.kind == Kind::Sphere;
    if ((ok_a || ok_b) && !incident_round) {
        if (ref_is_a ? clip_manifold(A, fa, B, true, margin, m) : clip_manifold(B, fb, A, false, margin, m)) {
            // The clipped points must hold the deepest overlap along the face normal. If the shapes
            // overlap further along it outside the reference face (an edge contact nearly parallel to the
            // face), the face manifold would under-report it: one point along the true normal is better.
            double deepest = -std::numeric_limits<double>::infinity();
            for (int i = 0; i < m.count; ++i) deepest = std::max(deepest, double(m.points[i].depth));
            if (overlap(A, B, m.normal.cast<double>()) <= deepest + 1e-4 * (A.size + B.size)) return true;
        }
    }
    single_point(A, B, q, m);
    return true;
}

}  // namespace

bool convex_convex(const Shape& a, const Transform& xa, const Shape& b, const Transform& xb, Real margin, Manifold& m) {
    m.clear();
    const Placed A = place(a, xa), B = place(b, xb);
    ContactQuery q;
    if (!query_contact(A, B, double(margin), q)) return false;
    return build_manifold(A, B, q, double(margin), m);
}

bool convex_triangle(const Shape& a, const Transform& xa, const Triangle& tri, Real margin, Manifold& m) {
    m.clear();
    const Placed A = place(a, xa);
    Placed B;
    B.kind = Kind::Triangle;
    B.tri[0] = tri.a.cast<double>();
    B.tri[1] = tri.b.cast<double>();
    B.tri[2] = tri.c.cast<double>();
    const V3d cr = (B.tri[1] - B.tri[0]).cross(B.tri[2] - B.tri[0]);
    const double area2 = cr.norm();
    const double longest = std::max({(B.tri[1] - B.tri[0]).norm(), (B.tri[2] - B.tri[0]).norm(),
                                     (B.tri[2] - B.tri[1]).norm()});
    if (!(area2 > 1e-12 * longest * longest)) return false;  // no area, no contact (meshes drop these)
    B.tri_n = cr / area2;
    const V3d c = B.center();
    B.p = c;
    for (const V3d& v : B.tri) B.size = std::max(B.size, (v - c).norm());

    ContactQuery q;
    if (!query_contact(A, B, double(margin), q)) return false;

    // A shape on the front side is pushed out along the face normal whenever its incident feature
    // overlaps the triangle's face: a box sliding over the shared edge of two coplanar triangles then
    // sees two identical face contacts instead of catching on the edge's normal (internal-edge
    // snagging). Without adjacency information this is as far as it can simply go; a shape beyond the
    // triangle's edges still gets the true edge/vertex normal below.
    if (B.tri_n.dot(A.center() - B.tri[0]) > 0 && clip_manifold(B, 0, A, false, double(margin), m)) return true;
    return build_manifold(A, B, q, double(margin), m);
}

}  // namespace sinew::narrow
