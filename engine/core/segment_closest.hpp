// Closest points of two segments (Ericson, "Real-Time Collision Detection", 5.1.9): capsule collision
// (engine/core/collide_capsule.cpp) and the soft bodies' edge-edge contacts (soft/soft_contacts.cpp).
#pragma once

#include <algorithm>

#include "engine/core/math.hpp"

namespace sinew {

/// Closest points of segments p0 + s d1 and q0 + t d2 (s, t in [0, 1]): minimise |p(s) - q(t)|^2, first
/// unconstrained, then clamp s, solve t for it, and re-solve s if t had to be clamped (Ericson 5.1.9).
inline void closest_segment_params(const Vec3& p0, const Vec3& d1, const Vec3& q0, const Vec3& d2, Real& s, Real& t) {
    const Real tiny = kEpsilon * kEpsilon;
    Vec3 r = p0 - q0;
    Real a = d1.squaredNorm();
    Real e = d2.squaredNorm();
    Real f = d2.dot(r);
    if (a <= tiny && e <= tiny) {
        s = t = 0;
        return;
    }
    if (a <= tiny) {
        s = 0;
        t = std::clamp(f / e, Real(0), Real(1));
        return;
    }
    Real c = d1.dot(r);
    if (e <= tiny) {
        t = 0;
        s = std::clamp(-c / a, Real(0), Real(1));
        return;
    }
    Real b = d1.dot(d2);
    Real denom = a * e - b * b;  // >= 0, zero for parallel segments
    // Parallel: any s works; s = 0 is then corrected by the clamping below.
    s = denom > kEpsilon * a * e ? std::clamp((b * f - c * e) / denom, Real(0), Real(1)) : Real(0);
    t = (b * s + f) / e;
    if (t < 0) {
        t = 0;
        s = std::clamp(-c / a, Real(0), Real(1));
    } else if (t > 1) {
        t = 1;
        s = std::clamp((b - c) / a, Real(0), Real(1));
    }
}

}  // namespace sinew
