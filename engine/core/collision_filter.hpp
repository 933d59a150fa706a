// Which bodies may touch: category and mask bits and a group index, per body (rigid or soft), with Box2D's
// rule. Read by the rigid broad phase's pair list and by the soft system's colliders.
#pragma once

#include <cstdint>

namespace sinew {

struct CollisionFilter {
    std::uint32_t category = 1;           ///< the bits this body is (usually one)
    std::uint32_t mask = 0xFFFFFFFFu;     ///< the categories it collides with
    /// Bodies of the same non-zero group always collide (> 0) or never (< 0), whatever their bits: a
    /// negative group per ragdoll keeps its limbs apart without spending category bits.
    std::int32_t group = 0;

    bool operator==(const CollisionFilter& o) const { return category == o.category && mask == o.mask && group == o.group; }
    bool operator!=(const CollisionFilter& o) const { return !(*this == o); }
};

/// Box2D's rule (b2ShouldShapesCollide): a shared non-zero group decides; otherwise each body's category
/// must be in the other's mask.
inline bool should_collide(const CollisionFilter& a, const CollisionFilter& b) {
    if (a.group == b.group && a.group != 0) return a.group > 0;
    return (a.category & b.mask) != 0 && (b.category & a.mask) != 0;
}

}  // namespace sinew
