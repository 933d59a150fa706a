// A soft body's rigid proxy: the rigid-body quantities of a set of nodes (Fishman 2012, extended in seed
// 001 ch.5 §7; ../shared/THEORY.md §6), and the rigid motion a change of the proxy's velocity gives them.
//
//   M = Σ m_i,  x_c = Σ m_i x_i / M,  r_i = x_i - x_c,  I = Σ m_i ((r_i·r_i) 1 - r_i r_iᵀ)   (Steiner, point masses)
//   v_c = Σ m_i v_i / M,  L = Σ m_i r_i × v_i,  ω = I⁻¹ L
//   R = the rotation of the polar decomposition of A = Σ m_i r_i s_iᵀ (s_i: the node's rest offset from
//       the rest centre of mass): the rotation that best carries the rest shape onto the nodes (Müller
//       2005's shape matching), so a point fixed in the proxy's frame stays with the nodes around it.
// A velocity change (Δv, Δω) of the proxy is the nodes' Δv_i = Δv + Δω × r_i, which changes their total
// momentum by M Δv and their angular momentum about x_c by I Δω: exactly the proxy's change.
#pragma once

#include <vector>

#include "engine/core/math.hpp"
#include "engine/core/shape.hpp"

namespace sinew {

struct RigidProxyState {
    Real mass = 0;
    Vec3 com = Vec3::Zero();
    Mat3 inertia = Mat3::Zero();   ///< world, about the centre of mass
    Vec3 v = Vec3::Zero();
    Vec3 w = Vec3::Zero();
    Mat3 rotation = Mat3::Identity();
    Vec3 momentum = Vec3::Zero();          ///< Σ m_i v_i
    Vec3 angular_momentum = Vec3::Zero();  ///< Σ m_i r_i × v_i, about com
    /// A set of nodes with no extent along some axis (a rope) has an inertia singular about it: the
    /// smallest principal moment is then raised to 1e-3 of the largest, or to that of a ball of the
    /// nodes' radius (a single node), and the proxy no longer turns exactly as its nodes do about that
    /// axis. True when that happened.
    bool regularised = false;
};

/// The proxy of the nodes `x` with velocities `v`, masses `mass` and rest offsets `rest` (all the same
/// length, masses > 0 in total); `radius` (the nodes' collision radius) bounds the smallest moment from
/// below, 2/5 M radius², so even a single node has an invertible inertia.
RigidProxyState measure_rigid_proxy(const std::vector<Vec3>& x, const std::vector<Vec3>& v,
                                    const std::vector<Real>& mass, const std::vector<Vec3>& rest, Real radius = 0);

/// Points within this share of the diagonal of a plane share one face of a proxy's hull.
constexpr Real kProxyHullFlatness = Real(0.004);

/// Every position finite (a diverged soft body's are not: no proxy is measured from them).
bool all_finite(const std::vector<Vec3>& points);

/// The convex hull of nodes given in the proxy's frame (`local`, used as scratch: nodes may be added),
/// points within `flatness` x the diagonal of a plane sharing one face. A set with no volume (a cloth, a
/// link, one triangle) has each node doubled `thickness` (at least the flatness) to either side along
/// each axis, so the hull has volume to find.
Shape make_proxy_hull(std::vector<Vec3>& local, Real thickness, Real flatness);

/// The rotation of the polar decomposition of a 3x3 matrix (a proper rotation: det +1), computed in double.
/// A rank-deficient matrix (the nodes of a rope or a flat cloth) leaves the rotation about the missing
/// directions free: 1e-6 of its largest singular value is added to the diagonal first, so that freedom resolves towards
/// no turn rather than to whatever the SVD's null vectors happen to be.
Mat3 polar_rotation(const Mat3& a);

}  // namespace sinew
