// Jakobsen's articulated particle bodies (Jakobsen 2003, "Advanced Character Physics"): a particle ragdoll
// and a "stick box". Both are meant for the Verlet method: stiff sticks are equality distance constraints,
// and the ragdoll's joint limits are inequality (min-distance) links that only push apart.
//
// Ragdoll particle layout (index: name), `feet` on the ground between the feet, facing +z, up +y:
//    0 head, 1 neck, 2 left shoulder, 3 right shoulder, 4 left elbow, 5 right elbow, 6 left hand,
//    7 right hand, 8 left hip, 9 right hip (the pelvis), 10 left knee, 11 right knee, 12 left foot,
//   13 right foot.
// Sticks (Structural): the torso block (neck, shoulders, hips, all pairs: rigid), head-neck, the limb
// segments. Limits (Other, min_length < rest, max_length huge): head-shoulders (the neck bends but does
// not fold), shoulder-hand and hip-foot (elbows and knees cannot fold flat), knee-knee and foot-foot (legs
// do not cross), elbow-hip (arms stay out of the torso) and hand-hand.
#include <cmath>
#include <string>

#include "soft/builder_common.hpp"

namespace sinew {

using namespace builder;

namespace {

// "No upper bound" for an inequality link: finite, so validation and arithmetic stay safe, and far above
// any distance in a scene (long-range attachments ignore links above 1e12 m as unbounded).
constexpr Real kUnbounded = Real(1e30);

// A stick: equality constraint at the current distance; k_s from the default LinkMaterial so mass-spring
// methods see ordinary springs.
Link stick(const std::vector<Vec3>& x, std::uint32_t a, std::uint32_t b, LinkKind kind) {
    const LinkMaterial m;
    Link l;
    l.a = a;
    l.b = b;
    l.rest = (x[a] - x[b]).norm();
    l.stiffness = kind == LinkKind::Shear ? m.shear : m.stretch;
    l.damping = m.damping;
    l.fraction = 1;
    l.min_length = l.max_length = l.rest;
    l.kind = kind;
    return l;
}

// A joint limit: the distance may not fall below `min_fraction` of the posed distance. Zero stiffness, so
// under mass-spring methods it exerts no force (limits are a Verlet construct).
Link limit(const std::vector<Vec3>& x, std::uint32_t a, std::uint32_t b, Real min_fraction) {
    Link l;
    l.a = a;
    l.b = b;
    l.rest = (x[a] - x[b]).norm();
    l.stiffness = 0;
    l.damping = 0;
    l.fraction = 1;
    l.min_length = min_fraction * l.rest;
    l.max_length = kUnbounded;
    l.kind = LinkKind::Other;
    return l;
}

}  // namespace

SoftBodyDef make_particle_ragdoll(const Vec3& feet, Real height, Real total_mass, SoftBodyDef base) {
    const char* where = "make_particle_ragdoll";
    check_point(where, "feet", feet);
    if (!(is_finite(height) && height > 0)) fail(where, "height must be finite and > 0, got " + std::to_string(height));
    if (!(is_finite(total_mass) && total_mass > 0))
        fail(where, "total_mass must be finite and > 0, got " + std::to_string(total_mass));

    // Proportions as fractions of the standing height (x to the body's left, y up, z forward), and each
    // particle's share of the mass (the torso carries most of it). Knees a little forward so the legs
    // start bent the natural way.
    struct Node { Real x, y, z, mass; };
    const Node nodes[14] = {
        {0, Real(0.94), 0, Real(0.08)},                               // head
        {0, Real(0.87), 0, Real(0.10)},                               // neck
        {Real(0.13), Real(0.82), 0, Real(0.10)},                      // left shoulder
        {Real(-0.13), Real(0.82), 0, Real(0.10)},                     // right shoulder
        {Real(0.17), Real(0.64), 0, Real(0.03)},                      // left elbow
        {Real(-0.17), Real(0.64), 0, Real(0.03)},                     // right elbow
        {Real(0.19), Real(0.47), Real(0.03), Real(0.02)},             // left hand
        {Real(-0.19), Real(0.47), Real(0.03), Real(0.02)},            // right hand
        {Real(0.09), Real(0.53), 0, Real(0.12)},                      // left hip
        {Real(-0.09), Real(0.53), 0, Real(0.12)},                     // right hip
        {Real(0.09), Real(0.28), Real(0.02), Real(0.10)},             // left knee
        {Real(-0.09), Real(0.28), Real(0.02), Real(0.10)},            // right knee
        {Real(0.09), Real(0.02), 0, Real(0.04)},                      // left foot
        {Real(-0.09), Real(0.02), 0, Real(0.04)},                     // right foot
    };
    base.positions.clear();
    base.masses.clear();
    base.links.clear();
    base.triangles.clear();
    for (const Node& n : nodes) {
        base.positions.push_back(feet + height * Vec3(n.x, n.y, n.z));
        base.masses.push_back(total_mass * n.mass);  // the shares sum to 1
    }
    const std::vector<Vec3>& x = base.positions;
    std::vector<Link>& L = base.links;

    // Sticks.
    const std::uint32_t torso[5] = {1, 2, 3, 8, 9};
    for (int i = 0; i < 5; ++i)
        for (int j = i + 1; j < 5; ++j) L.push_back(stick(x, torso[i], torso[j], LinkKind::Structural));
    const std::uint32_t limbs[][2] = {{0, 1}, {2, 4}, {4, 6}, {3, 5}, {5, 7}, {8, 10}, {10, 12}, {9, 11}, {11, 13}};
    for (const auto& s : limbs) L.push_back(stick(x, s[0], s[1], LinkKind::Structural));

    // Limits (Jakobsen's inequality constraints standing in for joint angle limits). The fractions allow
    // a wide but not complete bend: e.g. a knee folds until hip-foot is 60% of the straight-leg distance.
    L.push_back(limit(x, 0, 2, Real(0.7)));    // head-shoulders: neck bends about 45 degrees at most
    L.push_back(limit(x, 0, 3, Real(0.7)));
    L.push_back(limit(x, 2, 6, Real(0.5)));    // shoulder-hand: elbows
    L.push_back(limit(x, 3, 7, Real(0.5)));
    L.push_back(limit(x, 8, 12, Real(0.6)));   // hip-foot: knees
    L.push_back(limit(x, 9, 13, Real(0.6)));
    L.push_back(limit(x, 10, 11, Real(0.7)));  // knee-knee: legs do not cross
    L.push_back(limit(x, 12, 13, Real(0.5)));  // foot-foot
    L.push_back(limit(x, 4, 8, Real(0.5)));    // elbow-hip: arms stay out of the torso
    L.push_back(limit(x, 5, 9, Real(0.5)));
    L.push_back(limit(x, 6, 7, Real(0.3)));    // hand-hand
    return base;
}

SoftBodyDef make_stick_box(const Vec3& centre, const Vec3& half_extents, Real total_mass, SoftBodyDef base) {
    const char* where = "make_stick_box";
    check_point(where, "centre", centre);
    if (!is_finite(half_extents) || !(half_extents.minCoeff() > 0)) fail(where, "half_extents must be finite and > 0");
    if (!(is_finite(total_mass) && total_mass > 0))
        fail(where, "total_mass must be finite and > 0, got " + std::to_string(total_mass));

    base.positions.clear();
    base.masses.clear();
    base.links.clear();
    base.triangles.clear();
    // Corner k has bit 0 -> +x, bit 1 -> +y, bit 2 -> +z.
    for (int k = 0; k < 8; ++k)
        base.positions.push_back(centre + Vec3((k & 1) ? half_extents.x() : -half_extents.x(),
                                               (k & 2) ? half_extents.y() : -half_extents.y(),
                                               (k & 4) ? half_extents.z() : -half_extents.z()));
    base.masses.assign(8, total_mass / Real(8));
    // All 28 pairs: corners differing in one axis are edges, in two face diagonals, in three body
    // diagonals. The diagonals make the 8-particle frame rigid (edges alone would shear freely).
    for (std::uint32_t a = 0; a < 8; ++a)
        for (std::uint32_t b = a + 1; b < 8; ++b) {
            const unsigned bits = a ^ b;
            const int axes = int((bits & 1) != 0) + int((bits & 2) != 0) + int((bits & 4) != 0);
            const LinkKind kind = axes == 1 ? LinkKind::Structural : axes == 2 ? LinkKind::Shear : LinkKind::Other;
            base.links.push_back(stick(base.positions, a, b, kind));
        }
    // Surface, two triangles per face, counter-clockwise seen from outside (for rendering and volume).
    const std::uint32_t faces[6][4] = {
        {0, 4, 6, 2},  // -x
        {1, 3, 7, 5},  // +x
        {0, 1, 5, 4},  // -y
        {2, 6, 7, 3},  // +y
        {0, 2, 3, 1},  // -z
        {4, 5, 7, 6},  // +z
    };
    for (const auto& f : faces) base.triangles.insert(base.triangles.end(), {f[0], f[1], f[2], f[0], f[2], f[3]});
    return base;
}

}  // namespace sinew
