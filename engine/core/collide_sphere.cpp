// Sphere against sphere, capsule and box: closed-form distance between a point (the sphere centre) and a
// point, a segment or a box, minus the radii (Ericson, "Real-Time Collision Detection", ch. 5.1).
//
// All three report one point, midway between the two surfaces along the normal, so the same point comes
// out whichever shape is A (the dispatcher relies on that when it swaps arguments).
#include <algorithm>

#include "engine/core/narrowphase.hpp"

namespace sinew::narrow {

namespace {

// Feature-id kinds of the one-point sphere manifolds (high 4 bits of the id).
constexpr std::uint32_t kSphereFeature = 5;

// Two surface points facing each other along `n` (from A to B): A's sphere of radius ra around ca and B's
// surface point, given as B's core point cb pushed out by rb. Writes the one-point manifold.
bool emit_core_pair(const Vec3& ca, Real ra, const Vec3& cb, Real rb, Real margin, std::uint32_t feature,
                    Manifold& m) {
    m.clear();
    Vec3 d = cb - ca;
    Real dist2 = d.squaredNorm();
    Real reach = ra + rb + margin;
    if (dist2 > reach * reach) return false;
    Real dist = std::sqrt(dist2);
    // Coincident cores have no preferred direction; any unit vector is as good, +y matches the usual
    // "fall along gravity" case and keeps the result deterministic.
    Vec3 n = dist > kEpsilon * (Real(1) + ca.cwiseAbs().maxCoeff()) ? Vec3(d / dist) : Vec3(Vec3::UnitY());
    Real depth = ra + rb - dist;
    Vec3 surface_a = ca + ra * n;
    Vec3 surface_b = cb - rb * n;
    m.normal = n;
    m.add(Real(0.5) * (surface_a + surface_b), depth, feature);
    return true;
}

}  // namespace

bool sphere_sphere(const Shape& a, const Transform& xa, const Shape& b, const Transform& xb, Real margin,
                   Manifold& m) {
    return emit_core_pair(xa.p, a.radius, xb.p, b.radius, margin, make_feature_id(kSphereFeature, 0, 0), m);
}

bool sphere_capsule(const Shape& a, const Transform& xa, const Shape& b, const Transform& xb, Real margin,
                    Manifold& m) {
    // Closest point of B's segment to the sphere centre, found in B's frame where the segment is on y.
    Vec3 c = xb.apply_inverse(xa.p);
    Real y = std::clamp(c.y(), -b.half_height, b.half_height);
    Vec3 on_axis = xb.apply(Vec3(0, y, 0));
    // Which part of the capsule: 0 = bottom cap, 1 = cylinder, 2 = top cap (stable while it stays there).
    std::uint32_t region = y <= -b.half_height ? 0u : (y >= b.half_height ? 2u : 1u);
    return emit_core_pair(xa.p, a.radius, on_axis, b.radius, margin, make_feature_id(kSphereFeature, 1, region), m);
}

bool sphere_box(const Shape& a, const Transform& xa, const Shape& b, const Transform& xb, Real margin, Manifold& m) {
    m.clear();
    const Vec3& h = b.half_extents;
    const Real r = a.radius;
    Vec3 c = xb.apply_inverse(xa.p);  // sphere centre in the box frame
    Vec3 q = c.cwiseMax(-h).cwiseMin(h);  // closest box point
    Vec3 d = c - q;
    Real dist2 = d.squaredNorm();
    if (dist2 > Real(0)) {
        // Centre outside: the closest box point lies on a face, an edge or a vertex; which one is the
        // Voronoi region code (per axis below / inside / above), stable while the sphere stays in it.
        Real reach = r + margin;
        if (dist2 > reach * reach) return false;
        Real dist = std::sqrt(dist2);
        Vec3 n_box = -d / dist;  // from the sphere towards the box
        std::uint32_t region = 0;
        for (int k = 2; k >= 0; --k) region = 3 * region + (c[k] < -h[k] ? 0u : (c[k] > h[k] ? 2u : 1u));
        Vec3 surface_a = c + r * n_box;
        Vec3 mid = Real(0.5) * (surface_a + q);
        m.normal = xb.rotate(n_box);
        m.add(xb.apply(mid), r - dist, make_feature_id(kSphereFeature, 2, region));
        return true;
    }
    // Centre inside the box: push out through the face of least penetration (smallest distance to a face
    // plane), the minimum-translation direction of a point in a box.
    int best_axis = 0;
    Real best_sign = 1;
    Real best_gap = kRealMax;
    for (int k = 0; k < 3; ++k) {
        Real to_plus = h[k] - c[k];
        Real to_minus = h[k] + c[k];
        if (to_plus < best_gap) {
            best_gap = to_plus;
            best_axis = k;
            best_sign = 1;
        }
        if (to_minus < best_gap) {
            best_gap = to_minus;
            best_axis = k;
            best_sign = -1;
        }
    }
    Vec3 face_normal = Vec3::Zero();  // outward normal of that face, box frame
    face_normal[best_axis] = best_sign;
    Vec3 surface_b = c + best_gap * face_normal;  // where the centre leaves the box
    Vec3 surface_a = c - r * face_normal;         // the sphere's point deepest past that face
    m.normal = xb.rotate(-face_normal);
    std::uint32_t face = static_cast<std::uint32_t>(2 * best_axis + (best_sign > 0 ? 1 : 0));
    m.add(xb.apply(Real(0.5) * (surface_a + surface_b)), r + best_gap, make_feature_id(kSphereFeature, 3, face));
    return true;
}

}  // namespace sinew::narrow
