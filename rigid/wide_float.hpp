// Four lanes of Real for the graph-coloured contact solver: each lane holds one contact manifold, so one
// instruction advances four independent constraints (Box2D v3's "wide" solver, Catto 2024). With float
// on x86-64 a lane group is one SSE register (SSE2 is part of the x86-64 baseline, so no flag is needed);
// in double precision or elsewhere it is a plain array the compiler may vectorise.
#pragma once

#include <cmath>

#include "engine/core/math.hpp"

#if defined(__SSE2__) && !defined(SINEW_DOUBLE)
#define SINEW_WIDE_SSE 1
#include <emmintrin.h>
#include <xmmintrin.h>
#else
#define SINEW_WIDE_SSE 0
#endif

namespace sinew {

constexpr int kWideLanes = 4;

#if SINEW_WIDE_SSE

struct FloatW {
    __m128 m;
    /// Lane access for preparing and storing (not in solver loops); __m128 may alias float.
    Real lane(int i) const { return reinterpret_cast<const float*>(&m)[i]; }
    void set_lane(int i, Real x) { reinterpret_cast<float*>(&m)[i] = x; }
};
inline FloatW splat(Real x) { return {_mm_set1_ps(x)}; }
inline FloatW zero_w() { return {_mm_setzero_ps()}; }
inline FloatW operator+(FloatW a, FloatW b) { return {_mm_add_ps(a.m, b.m)}; }
inline FloatW operator-(FloatW a, FloatW b) { return {_mm_sub_ps(a.m, b.m)}; }
inline FloatW operator*(FloatW a, FloatW b) { return {_mm_mul_ps(a.m, b.m)}; }
inline FloatW operator/(FloatW a, FloatW b) { return {_mm_div_ps(a.m, b.m)}; }
inline FloatW max_w(FloatW a, FloatW b) { return {_mm_max_ps(a.m, b.m)}; }
inline FloatW min_w(FloatW a, FloatW b) { return {_mm_min_ps(a.m, b.m)}; }
inline FloatW sqrt_w(FloatW a) { return {_mm_sqrt_ps(a.m)}; }
/// Lane mask: all bits set where a > b.
inline FloatW greater_w(FloatW a, FloatW b) { return {_mm_cmpgt_ps(a.m, b.m)}; }
inline FloatW less_w(FloatW a, FloatW b) { return {_mm_cmplt_ps(a.m, b.m)}; }
inline FloatW and_w(FloatW a, FloatW b) { return {_mm_and_ps(a.m, b.m)}; }
/// mask ? a : b, lane by lane.
inline FloatW select_w(FloatW mask, FloatW a, FloatW b) {
    return {_mm_or_ps(_mm_and_ps(mask.m, a.m), _mm_andnot_ps(mask.m, b.m))};
}

#else

struct FloatW {
    Real v[kWideLanes];
    Real lane(int i) const { return v[i]; }
    void set_lane(int i, Real x) { v[i] = x; }
};
inline FloatW splat(Real x) { return {{x, x, x, x}}; }
inline FloatW zero_w() { return splat(0); }
#define SINEW_WIDE_BINARY(name, expr)                                  \
    inline FloatW name(FloatW a, FloatW b) {                           \
        FloatW r;                                                      \
        for (int i = 0; i < kWideLanes; ++i) r.v[i] = (expr);          \
        return r;                                                      \
    }
SINEW_WIDE_BINARY(operator+, a.v[i] + b.v[i])
SINEW_WIDE_BINARY(operator-, a.v[i] - b.v[i])
SINEW_WIDE_BINARY(operator*, a.v[i] * b.v[i])
SINEW_WIDE_BINARY(operator/, a.v[i] / b.v[i])
SINEW_WIDE_BINARY(max_w, a.v[i] > b.v[i] ? a.v[i] : b.v[i])
SINEW_WIDE_BINARY(min_w, a.v[i] < b.v[i] ? a.v[i] : b.v[i])
// Masks are 1 (true) or 0 (false) in the portable form.
SINEW_WIDE_BINARY(greater_w, a.v[i] > b.v[i] ? Real(1) : Real(0))
SINEW_WIDE_BINARY(less_w, a.v[i] < b.v[i] ? Real(1) : Real(0))
SINEW_WIDE_BINARY(and_w, (a.v[i] != 0 && b.v[i] != 0) ? Real(1) : Real(0))
#undef SINEW_WIDE_BINARY
inline FloatW sqrt_w(FloatW a) {
    FloatW r;
    for (int i = 0; i < kWideLanes; ++i) r.v[i] = std::sqrt(a.v[i]);
    return r;
}
inline FloatW select_w(FloatW mask, FloatW a, FloatW b) {
    FloatW r;
    for (int i = 0; i < kWideLanes; ++i) r.v[i] = mask.v[i] != 0 ? a.v[i] : b.v[i];
    return r;
}

#endif

inline FloatW& operator+=(FloatW& a, FloatW b) { return a = a + b; }
inline FloatW& operator-=(FloatW& a, FloatW b) { return a = a - b; }

/// Three FloatW: one 3-vector per lane.
struct Vec3W {
    FloatW x, y, z;
};
inline Vec3W operator+(const Vec3W& a, const Vec3W& b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline Vec3W operator-(const Vec3W& a, const Vec3W& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Vec3W operator*(FloatW s, const Vec3W& a) { return {s * a.x, s * a.y, s * a.z}; }
inline FloatW dot(const Vec3W& a, const Vec3W& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec3W& operator+=(Vec3W& a, const Vec3W& b) { return a = a + b; }
inline Vec3W& operator-=(Vec3W& a, const Vec3W& b) { return a = a - b; }
inline Vec3W cross(const Vec3W& a, const Vec3W& b) {
    return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline void set_lane(Vec3W& a, int i, const Vec3& v) {
    a.x.set_lane(i, v.x());
    a.y.set_lane(i, v.y());
    a.z.set_lane(i, v.z());
}
inline Vec3 lane(const Vec3W& a, int i) { return Vec3(a.x.lane(i), a.y.lane(i), a.z.lane(i)); }

/// One 3x3 matrix per lane (row-major rows r[0..2]).
struct Mat3W {
    Vec3W r[3];
};
inline Vec3W operator*(const Mat3W& m, const Vec3W& v) { return {dot(m.r[0], v), dot(m.r[1], v), dot(m.r[2], v)}; }
inline void set_lane(Mat3W& m, int i, const Mat3& a) {
    for (int row = 0; row < 3; ++row) set_lane(m.r[row], i, Vec3(a(row, 0), a(row, 1), a(row, 2)));
}

/// A body's solver state as four rows of four Reals (x, y, z, unused): velocity, angular velocity, and
/// the translation and rotation vector accumulated since the step began. Aligned so a row is one load.
struct alignas(16) WideBody {
    Real v[4], w[4], dp[4], dth[4];
};

/// One body per lane, gathered for a solve: velocities (read and written) and accumulated motion (read).
struct BodyW {
    Vec3W v, w, dp, dth;
};

#if SINEW_WIDE_SSE

inline void transpose_rows(const float* r0, const float* r1, const float* r2, const float* r3, Vec3W& out) {
    __m128 a = _mm_load_ps(r0), b = _mm_load_ps(r1), c = _mm_load_ps(r2), d = _mm_load_ps(r3);
    _MM_TRANSPOSE4_PS(a, b, c, d);
    out.x.m = a;
    out.y.m = b;
    out.z.m = c;
}
inline void store_rows(const Vec3W& in, float* r0, float* r1, float* r2, float* r3) {
    __m128 a = in.x.m, b = in.y.m, c = in.z.m, d = _mm_setzero_ps();
    _MM_TRANSPOSE4_PS(a, b, c, d);
    _mm_store_ps(r0, a);
    _mm_store_ps(r1, b);
    _mm_store_ps(r2, c);
    _mm_store_ps(r3, d);
}

#else

inline void transpose_rows(const Real* r0, const Real* r1, const Real* r2, const Real* r3, Vec3W& out) {
    const Real* r[4] = {r0, r1, r2, r3};
    for (int i = 0; i < kWideLanes; ++i) {
        out.x.v[i] = r[i][0];
        out.y.v[i] = r[i][1];
        out.z.v[i] = r[i][2];
    }
}
inline void store_rows(const Vec3W& in, Real* r0, Real* r1, Real* r2, Real* r3) {
    Real* r[4] = {r0, r1, r2, r3};
    for (int i = 0; i < kWideLanes; ++i) {
        r[i][0] = in.x.v[i];
        r[i][1] = in.y.v[i];
        r[i][2] = in.z.v[i];
        r[i][3] = 0;
    }
}

#endif

/// Gathers the four lanes' bodies (indices into `bodies`).
inline BodyW gather_bodies(const WideBody* bodies, const std::int32_t idx[kWideLanes]) {
    const WideBody &b0 = bodies[idx[0]], &b1 = bodies[idx[1]], &b2 = bodies[idx[2]], &b3 = bodies[idx[3]];
    BodyW g;
    transpose_rows(b0.v, b1.v, b2.v, b3.v, g.v);
    transpose_rows(b0.w, b1.w, b2.w, b3.w, g.w);
    transpose_rows(b0.dp, b1.dp, b2.dp, b3.dp, g.dp);
    transpose_rows(b0.dth, b1.dth, b2.dth, b3.dth, g.dth);
    return g;
}

/// Writes the four lanes' velocities back. Lanes may share a body only if its inverse mass and inertia
/// are zero (static, kinematic, asleep, or the padding body): its velocity is then unchanged, so the
/// order of the writes does not matter.
inline void scatter_velocities(WideBody* bodies, const std::int32_t idx[kWideLanes], const BodyW& g) {
    WideBody &b0 = bodies[idx[0]], &b1 = bodies[idx[1]], &b2 = bodies[idx[2]], &b3 = bodies[idx[3]];
    store_rows(g.v, b0.v, b1.v, b2.v, b3.v);
    store_rows(g.w, b0.w, b1.w, b2.w, b3.w);
}

}  // namespace sinew
