// Capsule against capsule and box.
//
// A capsule is a segment swept by a sphere, so both routines first find the closest points between the
// segment and the other core (segment or box; Ericson, "Real-Time Collision Detection", 5.1.9), then
// subtract the radii. One closest pair is not enough for resting contact: a capsule lying on another
// capsule or on a box face touches along a line, and one point lets it rock about that point. So when the
// segment lies (nearly) along the other core we report the two ends of the overlap instead, each with its
// own depth, as Box2D v3 does for its capsules (b2CollideCapsules).
#include <algorithm>
#include <initializer_list>

#include "engine/core/narrowphase.hpp"
#include "engine/core/segment_closest.hpp"

namespace sinew::narrow {

namespace {

constexpr std::uint32_t kCapsuleCapsuleFeature = 6;
constexpr std::uint32_t kCapsuleBoxFeature = 7;

// Segments whose directions differ by less than this sine (about 5.7 degrees) are treated as lying along
// each other. The two points are exact distances, so a loose bound costs nothing: a point whose surfaces
// are further apart than the margin is dropped anyway.
constexpr Real kParallelSine = Real(0.1);
// A capsule whose closest box feature is a face (normal within ~2.6 degrees of the face normal) is clipped
// against that face for up to two points.
constexpr Real kFaceCosine = Real(0.999);


Vec3 closest_on_segment(const Vec3& p0, const Vec3& d, const Vec3& x) {
    Real dd = d.squaredNorm();
    if (dd <= kEpsilon * kEpsilon) return p0;
    return p0 + std::clamp((x - p0).dot(d) / dd, Real(0), Real(1)) * d;
}

/// A unit vector from `from` to `to`, or `fallback` when the two points coincide.
Vec3 unit_direction(const Vec3& from, const Vec3& to, const Vec3& fallback, Real scale) {
    Vec3 d = to - from;
    Real n = d.norm();
    return n > kEpsilon * scale ? Vec3(d / n) : fallback;
}

}  // namespace

bool capsule_capsule(const Shape& a, const Transform& xa, const Shape& b, const Transform& xb, Real margin,
                     Manifold& m) {
    m.clear();
    const Vec3 a0 = xa.apply(Vec3(0, -a.half_height, 0));
    const Vec3 d1 = xa.rotate(Vec3(0, 2 * a.half_height, 0));
    const Vec3 b0 = xb.apply(Vec3(0, -b.half_height, 0));
    const Vec3 d2 = xb.rotate(Vec3(0, 2 * b.half_height, 0));
    const Real ra = a.radius, rb = b.radius;
    const Real reach = ra + rb + margin;

    Real s, t;
    closest_segment_params(a0, d1, b0, d2, s, t);
    const Vec3 pa = a0 + s * d1;
    const Vec3 pb = b0 + t * d2;
    if ((pb - pa).squaredNorm() > reach * reach) return false;

    // Intersecting cores have no closest-point direction. Crossing ones separate fastest along
    // d1 x d2, coaxial ones along any perpendicular of the axis; either way facing B.
    const Real l1 = d1.squaredNorm(), l2 = d2.squaredNorm();
    const Vec3 cross = d1.cross(d2);
    Vec3 fallback = Vec3::UnitY();
    if (cross.squaredNorm() > kEpsilon * l1 * l2 && l1 > 0 && l2 > 0) {
        fallback = cross.normalized();
    } else if (l1 > 0) {
        Vec3 t2;
        tangent_basis(d1.normalized(), fallback, t2);
    }
    if (fallback.dot(xb.p - xa.p) < 0) fallback = -fallback;
    const Real scale = Real(1) + ra + rb + a.half_height + b.half_height;
    const Vec3 n = unit_direction(pa, pb, fallback, scale);
    m.normal = n;

    // Lying along each other (both segments longer than rounding noise): the two ends of the overlap of
    // B's segment projected on A's.
    if (l1 > kEpsilon && l2 > kEpsilon && cross.squaredNorm() <= kParallelSine * kParallelSine * l1 * l2) {
        Real u0 = (b0 - a0).dot(d1) / l1;
        Real u1 = (b0 + d2 - a0).dot(d1) / l1;
        Real lo = std::max(Real(0), std::min(u0, u1));
        Real hi = std::min(Real(1), std::max(u0, u1));
        // Overlap long enough that two points give a lever arm (1% of the smaller radius).
        if ((hi - lo) * std::sqrt(l1) > Real(0.01) * std::min(ra, rb)) {
            const Real ends[2] = {lo, hi};
            for (int i = 0; i < 2; ++i) {
                Vec3 p = a0 + ends[i] * d1;
                Vec3 q = closest_on_segment(b0, d2, p);
                Real depth = ra + rb - (q - p).norm();
                if (depth < -margin) continue;
                m.add(Real(0.5) * (p + q) + Real(0.5) * (ra - rb) * n, depth,
                      make_feature_id(kCapsuleCapsuleFeature, 1, static_cast<std::uint32_t>(i)));
            }
            if (m.count > 0) return true;
        }
    }
    Real depth = ra + rb - (pb - pa).norm();
    m.add(Real(0.5) * (pa + pb) + Real(0.5) * (ra - rb) * n, depth, make_feature_id(kCapsuleCapsuleFeature, 0, 0));
    return true;
}

namespace {

/// Does segment p0 + t d (t in [0,1]) enter the box [-h, h]? Slab clipping (Liang-Barsky).
bool segment_enters_box(const Vec3& p0, const Vec3& d, const Vec3& h) {
    Real t0 = 0, t1 = 1;
    for (int k = 0; k < 3; ++k) {
        if (std::abs(d[k]) <= kEpsilon * kEpsilon) {
            if (std::abs(p0[k]) > h[k]) return false;
            continue;
        }
        Real ta = (-h[k] - p0[k]) / d[k];
        Real tb = (h[k] - p0[k]) / d[k];
        if (ta > tb) std::swap(ta, tb);
        t0 = std::max(t0, ta);
        t1 = std::min(t1, tb);
        if (t0 > t1) return false;
    }
    return true;
}

/// Closest points of a segment and a box it does not enter, box frame. On the box the closest point is on
/// a face, an edge or a vertex; face-interior closest points with an interior segment point only happen
/// when the segment is parallel to the face, and then an end point is as close. So the two end points
/// clamped to the box and the twelve edge-segment pairs contain the answer.
void closest_segment_box(const Vec3& p0, const Vec3& d, const Vec3& h, Vec3& on_segment, Vec3& on_box) {
    Real best = kRealMax;
    for (int end = 0; end < 2; ++end) {
        Vec3 p = end == 0 ? p0 : Vec3(p0 + d);
        Vec3 q = p.cwiseMax(-h).cwiseMin(h);
        Real d2 = (p - q).squaredNorm();
        if (d2 < best) {
            best = d2;
            on_segment = p;
            on_box = q;
        }
    }
    for (int axis = 0; axis < 3; ++axis) {
        const int u = (axis + 1) % 3, v = (axis + 2) % 3;
        Vec3 edge = Vec3::Zero();
        edge[axis] = 2 * h[axis];
        for (int corner = 0; corner < 4; ++corner) {
            Vec3 e0;
            e0[axis] = -h[axis];
            e0[u] = (corner & 1) ? h[u] : -h[u];
            e0[v] = (corner & 2) ? h[v] : -h[v];
            Real s, t;
            closest_segment_params(p0, d, e0, edge, s, t);
            Vec3 p = p0 + s * d;
            Vec3 q = e0 + t * edge;
            Real d2 = (p - q).squaredNorm();
            if (d2 < best) {
                best = d2;
                on_segment = p;
                on_box = q;
            }
        }
    }
}

/// Separating-axis test of a segment that enters the box: the axis of least penetration among the box
/// face normals and the segment direction crossed with each box axis. Returns the penetration and the
/// direction that pushes the segment out (box frame, from the box towards the segment).
Real segment_box_penetration(const Vec3& p0, const Vec3& d, const Vec3& h, Vec3& push) {
    const Vec3 p1 = p0 + d;
    Real best = kRealMax;
    for (int k = 0; k < 3; ++k) {
        Real out_plus = h[k] - std::min(p0[k], p1[k]);
        Real out_minus = std::max(p0[k], p1[k]) + h[k];
        if (out_plus < best) {
            best = out_plus;
            push = Vec3::Unit(k);
        }
        if (out_minus < best) {
            best = out_minus;
            push = -Vec3::Unit(k);
        }
    }
    // A cross axis must beat the best face clearly (by 5% plus 0.1% of the box's smallest half extent), so
    // a capsule sunk flat into a box keeps the face normal, which the clipping below turns into two points.
    const Real face_best = best;
    const Real len = d.norm();
    for (int k = 0; k < 3; ++k) {
        Vec3 axis = d.cross(Vec3::Unit(k));
        Real an = axis.norm();
        if (an <= Real(1e-3) * len) continue;  // segment along a box axis: already a face axis
        axis /= an;
        Real s = p0.dot(axis);
        Real pen = h.dot(axis.cwiseAbs()) - std::abs(s);
        if (pen < face_best - Real(0.05) * face_best - Real(1e-3) * h.minCoeff() && pen < best) {
            best = pen;
            push = s >= 0 ? axis : Vec3(-axis);
        }
    }
    return best;
}

}  // namespace

bool capsule_box(const Shape& a, const Transform& xa, const Shape& b, const Transform& xb, Real margin, Manifold& m) {
    m.clear();
    const Vec3& h = b.half_extents;
    const Real r = a.radius;
    // Everything in the box frame, where the box is [-h, h].
    const Vec3 p0 = xb.apply_inverse(xa.apply(Vec3(0, -a.half_height, 0)));
    const Vec3 d = xb.rotate_inverse(xa.rotate(Vec3(0, 2 * a.half_height, 0)));
    const Real scale = Real(1) + h.maxCoeff() + a.half_height + r;

    Vec3 n = Vec3::UnitY();  // from the capsule to the box, box frame
    Real depth = 0;
    // The closest pair (or, when the segment is inside, its deepest point and where that point exits).
    Vec3 on_segment = p0, on_box = p0;
    bool inside = segment_enters_box(p0, d, h);
    if (!inside) {
        closest_segment_box(p0, d, h, on_segment, on_box);
        Real dist = (on_box - on_segment).norm();
        if (dist > r + margin) return false;
        if (dist > kEpsilon * scale) {
            n = (on_box - on_segment) / dist;
            depth = r - dist;
        } else {
            inside = true;  // touching core: direction undefined, use the penetration axis
        }
    }
    if (inside) {
        Vec3 push;
        Real pen = segment_box_penetration(p0, d, h, push);
        n = -push;
        depth = pen + r;
        const Vec3 p1 = p0 + d;
        on_segment = p0.dot(push) <= p1.dot(push) ? p0 : p1;
        on_box = on_segment + pen * push;
    }

    // Face region: clip the segment to the face rectangle and report both ends (a lying capsule rests on
    // two points). The face's outward normal f faces the capsule.
    int k = 0;
    n.cwiseAbs().maxCoeff(&k);
    if (std::abs(n[k]) >= kFaceCosine) {
        const Real fs = n[k] > 0 ? Real(-1) : Real(1);
        const int u = (k + 1) % 3, v = (k + 2) % 3;
        Real t0 = 0, t1 = 1;
        bool overlap = true;
        for (int axis : {u, v}) {
            if (std::abs(d[axis]) <= kEpsilon * kEpsilon) {
                if (std::abs(p0[axis]) > h[axis]) overlap = false;
                continue;
            }
            Real ta = (-h[axis] - p0[axis]) / d[axis];
            Real tb = (h[axis] - p0[axis]) / d[axis];
            if (ta > tb) std::swap(ta, tb);
            t0 = std::max(t0, ta);
            t1 = std::min(t1, tb);
        }
        if (overlap && t0 <= t1) {
            // A clipped piece shorter than 1% of the radius gives no lever arm: one point at its middle.
            const bool one = (t1 - t0) * d.norm() < Real(0.01) * r;
            const Real ends[2] = {one ? Real(0.5) * (t0 + t1) : t0, t1};
            const std::uint32_t face = static_cast<std::uint32_t>(2 * k + (fs > 0 ? 1 : 0));
            Manifold clipped;
            for (int i = 0; i < (one ? 1 : 2); ++i) {
                Vec3 p = p0 + ends[i] * d;
                Real height = fs * p[k] - h[k];  // core point above the face plane
                Real pd = r - height;
                if (pd < -margin) continue;
                Vec3 mid = p;
                mid[k] -= fs * Real(0.5) * (r + height);  // halfway between p - f r and p - f height
                clipped.add(xb.apply(mid), pd, make_feature_id(kCapsuleBoxFeature, static_cast<std::uint32_t>(i), face));
            }
            if (clipped.count > 0) {
                m = clipped;
                m.normal = xb.rotate(Vec3(-fs * Vec3::Unit(k)));
                return true;
            }
        }
    }
    Vec3 surface_a = on_segment + r * n;
    m.normal = xb.rotate(n);
    m.add(xb.apply(Real(0.5) * (surface_a + on_box)), depth, make_feature_id(kCapsuleBoxFeature, 2, 0));
    return true;
}

}  // namespace sinew::narrow
