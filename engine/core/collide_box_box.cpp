// Box against box: separating-axis test over the 15 candidate axes (Gottschalk, Lin & Manocha 1996,
// "OBBTree"), then a contact manifold by reference-face clipping (Sutherland & Hodgman 1974, as in
// Catto's "Contact manifolds", GDC 2007, and Box2D/Bullet/ODE) or one edge-edge point.
//
// This routine runs for every touching box pair every step (a pyramid of 820 boxes has ~2400 pairs), so it
// works on fixed-size arrays in the reference box's frame and allocates nothing.
//
// Stability choices, each because stacks jitter without it:
// - hysteresis in the axis choice: A's face beats B's, and faces beat edges, unless the other is clearly
//   better (relative + absolute tolerance, as Box2D's b2_linearSlop and Bullet's/ODE's fudge factors), so
//   the reference face does not flip between steps on rounding noise;
// - canonical feature ids: a point is named by the box features that made it, numbered the same way on
//   both boxes (vertex 0-7, edge 8-19, face 20-25) and stored as (feature of A, feature of B). A corner of
//   A resting on B's face gets the same id whether A's face clipped B's or B's face had A's vertex, so
//   even a flip of the reference face keeps the warm-start impulses.
#include <algorithm>

#include "engine/core/narrowphase.hpp"

namespace sinew::narrow {

namespace {

constexpr std::uint32_t kBoxBoxFeature = 1;
constexpr std::uint32_t kEdgeBase = 8;
constexpr std::uint32_t kFaceBase = 20;

// Edge axes of nearly parallel edges (sine below this) are skipped: their direction is mostly rounding
// noise, and such a pair is handled by a face axis anyway (parallel edges touch along a face normal).
constexpr Real kEdgeMinSine = Real(1e-3);
// Hysteresis of the axis choice (see the file comment): relative part, per kind of switch.
constexpr Real kFaceSwitchRel = Real(0.02);
constexpr Real kEdgeSwitchRel = Real(0.05);
// Absolute part, as a fraction of the smaller box's smallest half extent (0.5 mm for a unit box).
constexpr Real kSwitchAbs = Real(1e-3);

// Sign bits of a box feature: s[k] is -1 or +1 per axis (only the axes fixed by the feature are read).
std::uint32_t vertex_feature(const int s[3]) {
    return static_cast<std::uint32_t>((s[0] > 0 ? 1 : 0) | (s[1] > 0 ? 2 : 0) | (s[2] > 0 ? 4 : 0));
}
std::uint32_t edge_feature(int axis, const int s[3]) {
    return kEdgeBase + static_cast<std::uint32_t>(4 * axis + (s[(axis + 1) % 3] > 0 ? 1 : 0) +
                                                  (s[(axis + 2) % 3] > 0 ? 2 : 0));
}
std::uint32_t face_feature(int axis, int sign) { return kFaceBase + static_cast<std::uint32_t>(2 * axis + (sign > 0 ? 1 : 0)); }

/// A vertex of the incident polygon while it is being clipped, in the reference frame. The outgoing edge
/// (to the next vertex) is either part of an incident-box edge or lies on a reference side plane; a new
/// vertex made by a clip plane is named by that edge and the plane.
struct ClipVertex {
    Vec3 p;
    std::uint32_t ref_feature;
    std::uint32_t inc_feature;
    std::int8_t out_edge_axis;  ///< incident edge axis (incident frame) of the outgoing edge, or -1
    std::int8_t out_side_axis;  ///< else: reference side plane axis ...
    std::int8_t out_side_sign;  ///< ... and its sign
    std::uint32_t out_edge_feature;  ///< incident edge feature when out_edge_axis >= 0
};

/// What the reference face and the incident polygon share through a clip.
struct ClipContext {
    int ref_axis;
    int ref_sign;
    std::uint32_t inc_face;
};

// A quad clipped by four lines has at most 8 vertices (each convex clip adds at most one); two more slots
// so the overflow guard in clip_side can never fire on a valid polygon.
constexpr int kClipCapacity = 10;

/// Sutherland-Hodgman against the side plane sign * x[axis] <= limit. At most n + 1 vertices out.
int clip_side(const ClipVertex* in, int n, int axis, int sign, Real limit, const ClipContext& ctx, ClipVertex* out) {
    int count = 0;
    for (int k = 0; k < n; ++k) {
        const ClipVertex& cur = in[k];
        const ClipVertex& next = in[(k + 1) % n];
        const Real dc = sign * cur.p[axis] - limit;
        const Real dn = sign * next.p[axis] - limit;
        // Convexity bounds the count; the guard only keeps a rounding accident from writing past the end.
        if (count + 2 > kClipCapacity) break;
        if (dc <= 0) {
            out[count] = cur;
            if (dc == 0 && dn > 0) {  // leaves exactly here: the outgoing edge now runs on the plane
                out[count].out_edge_axis = -1;
                out[count].out_side_axis = static_cast<std::int8_t>(axis);
                out[count].out_side_sign = static_cast<std::int8_t>(sign);
            }
            ++count;
        }
        if ((dc < 0 && dn > 0) || (dc > 0 && dn < 0)) {
            ClipVertex x = cur;
            x.p = cur.p + (dc / (dc - dn)) * (next.p - cur.p);
            x.p[axis] = sign * limit;  // exactly on the plane, not one rounding off it
            int s[3] = {1, 1, 1};
            s[ctx.ref_axis] = ctx.ref_sign;
            s[axis] = sign;
            if (cur.out_edge_axis >= 0) {
                // An incident edge crosses a side plane: the reference edge where that side meets the face.
                const int along = 3 - ctx.ref_axis - axis;
                x.ref_feature = edge_feature(along, s);
                x.inc_feature = cur.out_edge_feature;
            } else {
                // A previous clip line crosses this one: a corner of the reference face.
                s[cur.out_side_axis] = cur.out_side_sign;
                x.ref_feature = vertex_feature(s);
                x.inc_feature = ctx.inc_face;
            }
            if (dc < 0) {  // leaving: the new edge runs along this side plane to where the polygon re-enters
                x.out_edge_axis = -1;
                x.out_side_axis = static_cast<std::int8_t>(axis);
                x.out_side_sign = static_cast<std::int8_t>(sign);
            }  // entering: the rest of cur's edge continues to next, so x keeps cur's outgoing edge
            out[count++] = x;
        }
    }
    return count;
}

struct FacePoint {
    Vec3 p;  ///< reference frame, midway between the surfaces
    Real depth;
    std::uint32_t ref_feature;
    std::uint32_t inc_feature;
};

/// Keeps four of n > 4 coplanar points: the deepest (so the worst penetration is always corrected), the
/// one farthest from it, then on each side of that diagonal the one spanning the largest triangle. This
/// maximises the supporting area as Bullet's sortCachedPoints does. (u, v) are the in-plane axes.
int reduce_to_four(FacePoint* pts, int n, int u, int v) {
    auto area = [&](int i0, int i1, int k) {
        Real ax = pts[i1].p[u] - pts[i0].p[u], ay = pts[i1].p[v] - pts[i0].p[v];
        Real bx = pts[k].p[u] - pts[i0].p[u], by = pts[k].p[v] - pts[i0].p[v];
        return ax * by - ay * bx;
    };
    int i0 = 0;
    for (int k = 1; k < n; ++k)
        if (pts[k].depth > pts[i0].depth) i0 = k;
    int i1 = i0 == 0 ? 1 : 0;
    Real far = -1;
    for (int k = 0; k < n; ++k) {
        if (k == i0) continue;
        Real du = pts[k].p[u] - pts[i0].p[u], dv = pts[k].p[v] - pts[i0].p[v];
        if (du * du + dv * dv > far) {
            far = du * du + dv * dv;
            i1 = k;
        }
    }
    int i2 = -1, i3 = -1;
    Real most = 0, least = 0;
    for (int k = 0; k < n; ++k) {
        if (k == i0 || k == i1) continue;
        Real a = area(i0, i1, k);
        if (i2 < 0 || a > most) {
            most = a;
            i2 = k;
        }
        if (i3 < 0 || a < least) {
            least = a;
            i3 = k;
        }
    }
    // Every area equal (collinear points): any other point will do for the fourth.
    if (i2 == i3) {
        for (int k = 0; k < n; ++k)
            if (k != i0 && k != i1 && k != i2) i3 = k;
    }
    FacePoint kept[4] = {pts[i0], pts[i2], pts[i1], pts[i3]};
    for (int k = 0; k < 4; ++k) pts[k] = kept[k];
    return 4;
}

/// Face contact in the reference box's frame: the incident box (axes R_inc, centre t_inc, half extents
/// h_inc in that frame) is clipped against the reference face sign * x[axis] = h_ref[axis].
int face_contact(const Vec3& h_ref, int axis, int sign, const Mat3& R_inc, const Vec3& t_inc, const Vec3& h_inc,
                 Real margin, FacePoint out[kClipCapacity]) {
    // Incident face: the incident box's face most anti-parallel to the reference normal.
    const Vec3 n_inc = Real(sign) * R_inc.row(axis).transpose();  // reference normal in the incident frame
    int j = 0;
    n_inc.cwiseAbs().maxCoeff(&j);
    const int sj = n_inc[j] > 0 ? -1 : 1;
    const int ju = (j + 1) % 3, jv = (j + 2) % 3;

    ClipVertex poly_a[kClipCapacity], poly_b[kClipCapacity];
    // Corners in order around the face: (+,+) (-,+) (-,-) (+,-) in the face's (u, v) axes; the edge leaving
    // corner k runs along u for even k and along v for odd k.
    static constexpr int kSu[4] = {1, -1, -1, 1};
    static constexpr int kSv[4] = {1, 1, -1, -1};
    const ClipContext ctx{axis, sign, face_feature(j, sj)};
    for (int k = 0; k < 4; ++k) {
        int s[3];
        s[j] = sj;
        s[ju] = kSu[k];
        s[jv] = kSv[k];
        Vec3 c;
        for (int d = 0; d < 3; ++d) c[d] = s[d] * h_inc[d];
        ClipVertex& cv = poly_a[k];
        cv.p = R_inc * c + t_inc;
        cv.ref_feature = face_feature(axis, sign);
        cv.inc_feature = vertex_feature(s);
        const int along = (k % 2 == 0) ? ju : jv;
        cv.out_edge_axis = static_cast<std::int8_t>(along);
        cv.out_edge_feature = edge_feature(along, s);
        cv.out_side_axis = -1;
        cv.out_side_sign = 0;
    }
    int n = 4;
    const int u = (axis + 1) % 3, v = (axis + 2) % 3;
    ClipVertex* in = poly_a;
    ClipVertex* tmp = poly_b;
    const int side_axis[4] = {u, u, v, v};
    const int side_sign[4] = {1, -1, 1, -1};
    for (int plane = 0; plane < 4 && n > 0; ++plane) {
        n = clip_side(in, n, side_axis[plane], side_sign[plane], h_ref[side_axis[plane]], ctx, tmp);
        std::swap(in, tmp);
    }
    // Keep what is below the reference face (or above it by less than the margin).
    int count = 0;
    for (int k = 0; k < n; ++k) {
        const Real depth = h_ref[axis] - sign * in[k].p[axis];
        if (depth < -margin) continue;
        FacePoint& fp = out[count++];
        fp.p = in[k].p;
        fp.p[axis] += Real(0.5) * sign * depth;  // halfway to the reference face
        fp.depth = depth;
        fp.ref_feature = in[k].ref_feature;
        fp.inc_feature = in[k].inc_feature;
    }
    if (count > Manifold::kMaxPoints) count = reduce_to_four(out, count, u, v);
    return count;
}

}  // namespace

bool box_box(const Shape& a, const Transform& xa, const Shape& b, const Transform& xb, Real margin, Manifold& m) {
    m.clear();
    const Vec3& ha = a.half_extents;
    const Vec3& hb = b.half_extents;
    const Mat3 Ra = xa.q.toRotationMatrix();
    const Mat3 Rb = xb.q.toRotationMatrix();
    const Mat3 R = Ra.transpose() * Rb;             // B's axes in A's frame (columns)
    const Mat3 Rabs = R.cwiseAbs();
    const Vec3 t = Ra.transpose() * (xb.p - xa.p);  // B's centre in A's frame
    const Vec3 tb = R.transpose() * t;              // the same offset in B's frame

    // Separation along each axis: centre distance minus both projected radii (negative = overlap). Any
    // axis separating by more than the margin proves the boxes are further apart than that.
    Real sep_a = -kRealMax;
    int axis_a = 0;
    for (int i = 0; i < 3; ++i) {
        const Real s = std::abs(t[i]) - (ha[i] + Rabs.row(i).dot(hb));
        if (s > margin) return false;
        if (s > sep_a) {
            sep_a = s;
            axis_a = i;
        }
    }
    Real sep_b = -kRealMax;
    int axis_b = 0;
    for (int j = 0; j < 3; ++j) {
        const Real s = std::abs(tb[j]) - (Rabs.col(j).dot(ha) + hb[j]);
        if (s > margin) return false;
        if (s > sep_b) {
            sep_b = s;
            axis_b = j;
        }
    }
    Real sep_e = -kRealMax;
    int edge_a = -1, edge_b = -1;
    Vec3 edge_n = Vec3::Zero();
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) {
            Vec3 L = Vec3::Unit(i).cross(R.col(j));
            const Real len = L.norm();
            if (len < kEdgeMinSine) continue;
            L /= len;
            const Real dist = t.dot(L);
            const Real s = std::abs(dist) - ha.dot(L.cwiseAbs()) - hb.dot((R.transpose() * L).cwiseAbs());
            if (s > margin) return false;
            if (s > sep_e) {
                sep_e = s;
                edge_a = i;
                edge_b = j;
                edge_n = dist >= 0 ? L : Vec3(-L);
            }
        }
    }

    const Real abs_tol = kSwitchAbs * std::min(ha.minCoeff(), hb.minCoeff());
    auto clearly_better = [&](Real candidate, Real current, Real rel) {
        return candidate > current + rel * std::abs(current) + abs_tol;
    };
    const bool use_b = clearly_better(sep_b, sep_a, kFaceSwitchRel);
    const Real sep_face = use_b ? sep_b : sep_a;

    if (edge_a >= 0 && clearly_better(sep_e, sep_face, kEdgeSwitchRel)) {
        // Edge-edge: the edge of A furthest along n against the edge of B furthest against it; one point
        // halfway between their closest points (A's frame).
        const Vec3& n = edge_n;
        int sa[3], sb[3];
        const Vec3 nb = R.transpose() * n;
        for (int k = 0; k < 3; ++k) {
            sa[k] = n[k] >= 0 ? 1 : -1;
            sb[k] = nb[k] > 0 ? -1 : 1;
        }
        Vec3 ca, cb;
        for (int k = 0; k < 3; ++k) {
            ca[k] = sa[k] * ha[k];
            cb[k] = sb[k] * hb[k];
        }
        ca[edge_a] = -ha[edge_a];
        cb[edge_b] = -hb[edge_b];
        const Vec3 pa0 = ca;
        const Vec3 da = 2 * ha[edge_a] * Vec3::Unit(edge_a);
        const Vec3 pb0 = R * cb + t;
        const Vec3 db = 2 * hb[edge_b] * R.col(edge_b);
        // Closest points of the two edge lines (not parallel: the axis passed kEdgeMinSine), clamped to
        // the edges in case rounding put them a hair outside.
        const Vec3 r = pa0 - pb0;
        const Real aa = da.dot(da), bb = da.dot(db), ee = db.dot(db), c = da.dot(r), f = db.dot(r);
        const Real denom = aa * ee - bb * bb;
        const Real s = std::clamp((bb * f - c * ee) / denom, Real(0), Real(1));
        const Real u = std::clamp((aa * f - bb * c) / denom, Real(0), Real(1));
        const Vec3 mid = Real(0.5) * ((pa0 + s * da) + (pb0 + u * db));
        m.normal = Ra * n;
        m.add(xa.apply(mid), -sep_e, make_feature_id(kBoxBoxFeature, edge_feature(edge_a, sa), edge_feature(edge_b, sb)));
        return true;
    }

    FacePoint pts[kClipCapacity];
    int count;
    if (!use_b) {
        const int sign = t[axis_a] >= 0 ? 1 : -1;
        count = face_contact(ha, axis_a, sign, R, t, hb, margin, pts);
        m.normal = Real(sign) * Ra.col(axis_a);
        for (int k = 0; k < count; ++k)
            m.add(xa.apply(pts[k].p), pts[k].depth,
                  make_feature_id(kBoxBoxFeature, pts[k].ref_feature, pts[k].inc_feature));
    } else {
        // B is the reference: A's centre in B's frame is -tb, A's axes there are the rows of R.
        const int sign = tb[axis_b] > 0 ? -1 : 1;
        count = face_contact(hb, axis_b, sign, R.transpose(), -tb, ha, margin, pts);
        m.normal = Real(-sign) * Rb.col(axis_b);  // the reference normal points from B to A
        for (int k = 0; k < count; ++k)
            m.add(xb.apply(pts[k].p), pts[k].depth,
                  make_feature_id(kBoxBoxFeature, pts[k].inc_feature, pts[k].ref_feature));
    }
    return m.count > 0;
}

}  // namespace sinew::narrow
