// Convex shape against a static plane (solid below n . x = offset).
//
// The distance of a point to a plane is exact and cheap, so every routine tests the shape's candidate
// points directly: the sphere's centre, the capsule's two segment ends, the box's eight corners, the hull's
// vertices (each pushed out by the radius where there is one). Each point within the margin becomes a
// contact, so a lying capsule gets two and a flat box four, and a point keeps its id (end or vertex index)
// for as long as it touches.
#include <string>
#include <utility>

#include "engine/core/narrowphase.hpp"

namespace sinew::narrow {

namespace {

constexpr std::uint32_t kPlaneFeature = 8;

struct WorldPlane {
    Vec3 n;       ///< unit normal, out of the solid
    Real offset;  ///< n . x = offset on the surface
    Real height(const Vec3& x) const { return n.dot(x) - offset; }
};

/// Adds the contact of a core point x (surface at radius r around it) if within the margin.
void add_point(const WorldPlane& plane, const Vec3& x, Real r, Real margin, std::uint32_t index, Manifold& m) {
    const Real height = plane.height(x);
    const Real depth = r - height;
    if (depth < -margin) return;
    // Shape surface at x - r n, plane surface at x - height n; the contact is halfway.
    m.add(x - (Real(0.5) * (r + height)) * plane.n, depth, make_feature_id(kPlaneFeature, index, 0));
}

void box_plane(const Shape& a, const Transform& xa, const WorldPlane& plane, Real margin, Manifold& m) {
    // Corner i has coordinate k positive when bit k of i is set (the box-box vertex numbering).
    Vec3 corners[8];
    Real depth[8];
    int order[8];
    for (int i = 0; i < 8; ++i) {
        Vec3 c((i & 1) ? a.half_extents.x() : -a.half_extents.x(), (i & 2) ? a.half_extents.y() : -a.half_extents.y(),
               (i & 4) ? a.half_extents.z() : -a.half_extents.z());
        corners[i] = xa.apply(c);
        depth[i] = -plane.height(corners[i]);
        order[i] = i;
    }
    // The four deepest corners (a box sunk deeper than half its size has more than four below the
    // plane; the deepest ones carry the support). Ties keep index order, so the choice is deterministic.
    // Insertion sort: eight entries, stable, and (unlike std::stable_sort) never allocates.
    for (int i = 1; i < 8; ++i)
        for (int k = i; k > 0 && depth[order[k]] > depth[order[k - 1]]; --k) std::swap(order[k], order[k - 1]);
    for (int k = 0; k < Manifold::kMaxPoints; ++k)
        add_point(plane, corners[order[k]], 0, margin, static_cast<std::uint32_t>(order[k]), m);
}

void hull_plane(const Shape& a, const Transform& xa, const WorldPlane& plane, Real margin, Manifold& m) {
    const std::vector<Vec3>& verts = a.hull->vertices;
    const int n = static_cast<int>(verts.size());
    auto depth_of = [&](int i) { return -plane.height(xa.apply(verts[i])); };
    int touching = 0;
    int deepest = -1;
    Real deepest_depth = -kRealMax;
    for (int i = 0; i < n; ++i) {
        Real d = depth_of(i);
        if (d < -margin) continue;
        ++touching;
        if (d > deepest_depth) {
            deepest_depth = d;
            deepest = i;
        }
    }
    if (touching == 0) return;
    if (touching <= Manifold::kMaxPoints) {
        for (int i = 0; i < n; ++i) add_point(plane, xa.apply(verts[i]), 0, margin, static_cast<std::uint32_t>(i), m);
        return;
    }
    // More than four: keep the deepest, the one farthest from it in the plane, and on each side of that
    // diagonal the one spanning the largest triangle (the supporting area is what keeps a hull from
    // rocking; Bullet's sortCachedPoints reduces the same way). Passes over the vertices instead of a
    // candidate list, so nothing is allocated.
    const Vec3 p0 = xa.apply(verts[deepest]);
    int far = -1;
    Real far_d2 = -1;
    for (int i = 0; i < n; ++i) {
        if (i == deepest || depth_of(i) < -margin) continue;
        Vec3 d = xa.apply(verts[i]) - p0;
        d -= plane.n.dot(d) * plane.n;
        if (d.squaredNorm() > far_d2) {
            far_d2 = d.squaredNorm();
            far = i;
        }
    }
    const Vec3 diagonal = xa.apply(verts[far]) - p0;
    int left = -1, right = -1;
    Real most = 0, least = 0;
    for (int i = 0; i < n; ++i) {
        if (i == deepest || i == far || depth_of(i) < -margin) continue;
        Real area = diagonal.cross(xa.apply(verts[i]) - p0).dot(plane.n);
        if (left < 0 || area > most) {
            most = area;
            left = i;
        }
        if (right < 0 || area < least) {
            least = area;
            right = i;
        }
    }
    const int keep[4] = {deepest, left, far, right};
    for (int k = 0; k < 4; ++k) {
        if (k == 3 && right == left) break;  // every candidate on one line: three distinct points
        add_point(plane, xa.apply(verts[keep[k]]), 0, margin, static_cast<std::uint32_t>(keep[k]), m);
    }
}

}  // namespace

bool convex_plane(const Shape& a, const Transform& xa, const Shape& b, const Transform& xb, Real margin, Manifold& m) {
    m.clear();
    const Vec3 n = xb.rotate(b.normal);
    const WorldPlane plane{n, b.offset + n.dot(xb.p)};
    m.normal = -n;  // from the shape above into the solid below
    switch (a.type) {
        case ShapeType::Sphere:
            add_point(plane, xa.p, a.radius, margin, 0, m);
            break;
        case ShapeType::Capsule:
            add_point(plane, xa.apply(Vec3(0, -a.half_height, 0)), a.radius, margin, 0, m);
            add_point(plane, xa.apply(Vec3(0, a.half_height, 0)), a.radius, margin, 1, m);
            break;
        case ShapeType::Box:
            box_plane(a, xa, plane, margin, m);
            break;
        case ShapeType::ConvexHull:
            hull_plane(a, xa, plane, margin, m);
            break;
        default:
            throw ShapeError(std::string("convex_plane: a ") + shape_type_name(a.type) + " is not a convex shape");
    }
    return m.count > 0;
}

}  // namespace sinew::narrow
