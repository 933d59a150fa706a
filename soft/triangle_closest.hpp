// The point of a triangle closest to a point, as barycentric weights (Ericson, Real-Time Collision
// Detection §5.1.5: the Voronoi regions of the vertices, edges and face), shared by the particle-shape
// distance (triangle meshes) and the soft-soft contact pass, which needs the weights to share an impulse
// among the triangle's three particles.
#pragma once

#include "engine/core/math.hpp"

namespace sinew {

/// Weights (wa, wb, wc), each in [0, 1] and summing to 1, of the point of triangle abc closest to p.
inline Vec3 closest_on_triangle_weights(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
    const Vec3 ab = b - a, ac = c - a, ap = p - a;
    const Real d1 = ab.dot(ap), d2 = ac.dot(ap);
    if (d1 <= 0 && d2 <= 0) return Vec3(1, 0, 0);
    const Vec3 bp = p - b;
    const Real d3 = ab.dot(bp), d4 = ac.dot(bp);
    if (d3 >= 0 && d4 <= d3) return Vec3(0, 1, 0);
    const Real vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0) {
        const Real t = d1 / (d1 - d3);
        return Vec3(1 - t, t, 0);
    }
    const Vec3 cp = p - c;
    const Real d5 = ab.dot(cp), d6 = ac.dot(cp);
    if (d6 >= 0 && d5 <= d6) return Vec3(0, 0, 1);
    const Real vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) {
        const Real t = d2 / (d2 - d6);
        return Vec3(1 - t, 0, t);
    }
    const Real va = d3 * d6 - d5 * d4;
    if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
        const Real t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return Vec3(0, 1 - t, t);
    }
    const Real denom = Real(1) / (va + vb + vc);
    const Real v = vb * denom, w = vc * denom;
    return Vec3(1 - v - w, v, w);
}

inline Vec3 closest_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
    const Vec3 w = closest_on_triangle_weights(p, a, b, c);
    return w.x() * a + w.y() * b + w.z() * c;
}

}  // namespace sinew
