// Contact manifolds: what the narrow phase produces and what solvers consume.
#pragma once

#include <cstdint>

#include "engine/core/math.hpp"

namespace sinew {

/// One contact point. `depth` > 0 means penetration. Positions are stored in both bodies' local frames
/// so a cached point can be matched by proximity after the bodies moved (seed 001, ch.5).
struct ContactPoint {
    Vec3 position = Vec3::Zero();  ///< world, midway between the two surfaces (symmetric under A/B swap)
    Vec3 local_a = Vec3::Zero();   ///< the point in A's shape frame (filled by the contact cache)
    Vec3 local_b = Vec3::Zero();   ///< the point in B's shape frame (filled by the contact cache)
    Real depth = 0;                ///< penetration depth along the normal (m), negative = separated
    std::uint32_t feature_id = 0;  ///< which features (faces/edges/vertices) made the point; stable under small motion
    // Accumulated impulses carried across steps for warm starting (N·s).
    Real normal_impulse = 0;
    Real tangent_impulse[2] = {0, 0};
    /// Normal impulse the solver applied at this point over the whole last step (N·s). Split impulses
    /// and Baumgarte copy normal_impulse; the soft step keeps per-sub-step impulses in normal_impulse
    /// and sums them here; the Newtonian solver (no warm starting) writes its contact and shock passes'
    /// impulse. Events and coupling layers read this one.
    Real total_normal_impulse = 0;
};

/// Up to four points sharing one normal, pointing from shape A to shape B.
struct Manifold {
    static constexpr int kMaxPoints = 4;
    Vec3 normal = Vec3::UnitY();
    int count = 0;
    /// Distinguishes several manifolds of one body pair: compound child pair, or mesh triangle.
    std::uint32_t sub_key = 0;
    ContactPoint points[kMaxPoints];

    void clear() { count = 0; }
    ContactPoint& add(const Vec3& position, Real depth, std::uint32_t feature_id) {
        ContactPoint& p = points[count++];
        p = ContactPoint{};
        p.position = position;
        p.depth = depth;
        p.feature_id = feature_id;
        return p;
    }
};

/// Packs feature indices into a point's feature id: which feature of A and B, and of which kind.
inline std::uint32_t make_feature_id(std::uint32_t kind, std::uint32_t index_a, std::uint32_t index_b) {
    return (kind << 28) | ((index_a & 0x3FFFu) << 14) | (index_b & 0x3FFFu);
}

}  // namespace sinew
