// Lanes of Real for the graph-coloured contact solver: each lane holds one contact manifold, so one
// instruction advances several independent constraints (Box2D v3's "wide" solver, Catto 2024).
//
// Storage is eight lanes (FloatW). The solver's kernels run on a register type chosen at run time:
//   F8 (AVX, 8 floats): compiled for AVX with a target pragma and used only if the CPU has AVX;
//   F4 (SSE2, 4 floats): the x86-64 baseline, so it needs no compiler flag; a batch is two halves;
//   G4 (4 Reals in a plain array): double precision and other architectures.
// No fused multiply-add is used (the solver's file is compiled with -ffp-contract=off), so every kernel
// rounds exactly the same way and all give bit-identical results (tests/test_rigid_simd.cpp checks it).
#pragma once

#include <cmath>
#include <cstdint>

#include "engine/core/math.hpp"

// GCC only: the AVX kernels rely on `#pragma GCC target`, which clang ignores (clang builds use the
// portable kernel).
#if (defined(__x86_64__) || defined(__i386__)) && defined(__SSE2__) && !defined(SINEW_DOUBLE) && \
    defined(__GNUC__) && !defined(__clang__)
#define SINEW_WIDE_X86 1
#include <immintrin.h>
#else
#define SINEW_WIDE_X86 0
#endif

namespace sinew {

constexpr int kWideLanes = 8;

/// Eight lanes in memory; the kernels load four or eight at a time.
struct alignas(32) FloatW {
    Real v[kWideLanes];
    Real lane(int i) const { return v[i]; }
    void set_lane(int i, Real x) { v[i] = x; }
};

/// Eight 3-vectors, one per lane.
struct Vec3W {
    FloatW x, y, z;
};
inline void set_lane(Vec3W& a, int i, const Vec3& v) {
    a.x.v[i] = v.x();
    a.y.v[i] = v.y();
    a.z.v[i] = v.z();
}
inline Vec3 lane(const Vec3W& a, int i) { return Vec3(a.x.v[i], a.y.v[i], a.z.v[i]); }

/// A body's solver state as four rows of four Reals (x, y, z, unused): velocity, angular velocity, and
/// the translation and rotation vector accumulated since the step began. Aligned so a row is one load.
struct alignas(16) WideBody {
    Real v[4], w[4], dp[4], dth[4];
};

// ---- G4: four Reals in a plain array (double precision, other architectures) ----------------------
struct G4 {
    Real v[4];
};
#define SINEW_G4_BINARY(name, expr)                     \
    inline G4 name(G4 a, G4 b) {                        \
        G4 r;                                           \
        for (int i = 0; i < 4; ++i) r.v[i] = (expr);    \
        return r;                                       \
    }
SINEW_G4_BINARY(operator+, a.v[i] + b.v[i])
SINEW_G4_BINARY(operator-, a.v[i] - b.v[i])
SINEW_G4_BINARY(operator*, a.v[i] * b.v[i])
SINEW_G4_BINARY(operator/, a.v[i] / b.v[i])
SINEW_G4_BINARY(max_r, a.v[i] > b.v[i] ? a.v[i] : b.v[i])
// Masks are 1 (true) or 0 (false) in the portable form.
SINEW_G4_BINARY(greater_r, a.v[i] > b.v[i] ? Real(1) : Real(0))
SINEW_G4_BINARY(less_r, a.v[i] < b.v[i] ? Real(1) : Real(0))
SINEW_G4_BINARY(and_r, (a.v[i] != 0 && b.v[i] != 0) ? Real(1) : Real(0))
#undef SINEW_G4_BINARY
inline G4 splat_g4(Real x) { return {{x, x, x, x}}; }
inline G4 sqrt_r(G4 a) {
    for (Real& x : a.v) x = std::sqrt(x);
    return a;
}
inline G4 select_r(G4 mask, G4 a, G4 b) {
    G4 r;
    for (int i = 0; i < 4; ++i) r.v[i] = mask.v[i] != 0 ? a.v[i] : b.v[i];
    return r;
}
inline G4 load_r(const FloatW& w, int half, G4*) {
    G4 r;
    for (int i = 0; i < 4; ++i) r.v[i] = w.v[4 * half + i];
    return r;
}
inline void store_r(FloatW& w, int half, G4 r) {
    for (int i = 0; i < 4; ++i) w.v[4 * half + i] = r.v[i];
}
/// Rows x, y, z of four bodies' 4-vectors (body i's row at rows[i]) as lanes.
inline void gather_rows(const Real* const rows[4], G4& x, G4& y, G4& z) {
    for (int i = 0; i < 4; ++i) {
        x.v[i] = rows[i][0];
        y.v[i] = rows[i][1];
        z.v[i] = rows[i][2];
    }
}
inline void scatter_rows(Real* const rows[4], G4 x, G4 y, G4 z) {
    for (int i = 0; i < 4; ++i) {
        rows[i][0] = x.v[i];
        rows[i][1] = y.v[i];
        rows[i][2] = z.v[i];
        rows[i][3] = 0;
    }
}

#if SINEW_WIDE_X86

// ---- F4: SSE2, four floats ----------------------------------------------------------------------
struct F4 {
    __m128 m;
};
inline F4 operator+(F4 a, F4 b) { return {_mm_add_ps(a.m, b.m)}; }
inline F4 operator-(F4 a, F4 b) { return {_mm_sub_ps(a.m, b.m)}; }
inline F4 operator*(F4 a, F4 b) { return {_mm_mul_ps(a.m, b.m)}; }
inline F4 operator/(F4 a, F4 b) { return {_mm_div_ps(a.m, b.m)}; }
inline F4 max_r(F4 a, F4 b) { return {_mm_max_ps(a.m, b.m)}; }
inline F4 sqrt_r(F4 a) { return {_mm_sqrt_ps(a.m)}; }
/// Lane masks: all bits set where true.
inline F4 greater_r(F4 a, F4 b) { return {_mm_cmpgt_ps(a.m, b.m)}; }
inline F4 less_r(F4 a, F4 b) { return {_mm_cmplt_ps(a.m, b.m)}; }
inline F4 and_r(F4 a, F4 b) { return {_mm_and_ps(a.m, b.m)}; }
inline F4 select_r(F4 mask, F4 a, F4 b) { return {_mm_or_ps(_mm_and_ps(mask.m, a.m), _mm_andnot_ps(mask.m, b.m))}; }
inline F4 splat_f4(float x) { return {_mm_set1_ps(x)}; }
inline F4 load_r(const FloatW& w, int half, F4*) { return {_mm_load_ps(w.v + 4 * half)}; }
inline void store_r(FloatW& w, int half, F4 r) { _mm_store_ps(w.v + 4 * half, r.m); }
inline void gather_rows(const float* const rows[4], F4& x, F4& y, F4& z) {
    __m128 a = _mm_load_ps(rows[0]), b = _mm_load_ps(rows[1]), c = _mm_load_ps(rows[2]), d = _mm_load_ps(rows[3]);
    _MM_TRANSPOSE4_PS(a, b, c, d);
    x.m = a;
    y.m = b;
    z.m = c;
}
inline void scatter_rows(float* const rows[4], F4 x, F4 y, F4 z) {
    __m128 a = x.m, b = y.m, c = z.m, d = _mm_setzero_ps();
    _MM_TRANSPOSE4_PS(a, b, c, d);
    _mm_store_ps(rows[0], a);
    _mm_store_ps(rows[1], b);
    _mm_store_ps(rows[2], c);
    _mm_store_ps(rows[3], d);
}

// ---- F8: AVX, eight floats (compiled for AVX here, called only when the CPU has it) --------------
#pragma GCC push_options
#pragma GCC target("avx")
#define SINEW_AVX_FN inline __attribute__((target("avx"), always_inline))
struct F8 {
    __m256 m;
};
SINEW_AVX_FN F8 operator+(F8 a, F8 b) { return {_mm256_add_ps(a.m, b.m)}; }
SINEW_AVX_FN F8 operator-(F8 a, F8 b) { return {_mm256_sub_ps(a.m, b.m)}; }
SINEW_AVX_FN F8 operator*(F8 a, F8 b) { return {_mm256_mul_ps(a.m, b.m)}; }
SINEW_AVX_FN F8 operator/(F8 a, F8 b) { return {_mm256_div_ps(a.m, b.m)}; }
SINEW_AVX_FN F8 max_r(F8 a, F8 b) { return {_mm256_max_ps(a.m, b.m)}; }
SINEW_AVX_FN F8 sqrt_r(F8 a) { return {_mm256_sqrt_ps(a.m)}; }
SINEW_AVX_FN F8 greater_r(F8 a, F8 b) { return {_mm256_cmp_ps(a.m, b.m, _CMP_GT_OQ)}; }
SINEW_AVX_FN F8 less_r(F8 a, F8 b) { return {_mm256_cmp_ps(a.m, b.m, _CMP_LT_OQ)}; }
SINEW_AVX_FN F8 and_r(F8 a, F8 b) { return {_mm256_and_ps(a.m, b.m)}; }
SINEW_AVX_FN F8 select_r(F8 mask, F8 a, F8 b) { return {_mm256_blendv_ps(b.m, a.m, mask.m)}; }
SINEW_AVX_FN F8 splat_f8(float x) { return {_mm256_set1_ps(x)}; }
SINEW_AVX_FN F8 load_r(const FloatW& w, int, F8*) { return {_mm256_load_ps(w.v)}; }
SINEW_AVX_FN void store_r(FloatW& w, int, F8 r) { _mm256_store_ps(w.v, r.m); }
/// Rows of eight bodies: bodies i and i + 4 share a 256-bit register, then each 128-bit half is
/// transposed as in the SSE version.
SINEW_AVX_FN void gather_rows(const float* const rows[8], F8& x, F8& y, F8& z) {
    __m256 r[4];
    for (int i = 0; i < 4; ++i)
        r[i] = _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_load_ps(rows[i])), _mm_load_ps(rows[i + 4]), 1);
    __m256 t0 = _mm256_unpacklo_ps(r[0], r[1]);  // x0 x1 y0 y1
    __m256 t1 = _mm256_unpackhi_ps(r[0], r[1]);  // z0 z1 . .
    __m256 t2 = _mm256_unpacklo_ps(r[2], r[3]);  // x2 x3 y2 y3
    __m256 t3 = _mm256_unpackhi_ps(r[2], r[3]);  // z2 z3 . .
    x.m = _mm256_shuffle_ps(t0, t2, _MM_SHUFFLE(1, 0, 1, 0));
    y.m = _mm256_shuffle_ps(t0, t2, _MM_SHUFFLE(3, 2, 3, 2));
    z.m = _mm256_shuffle_ps(t1, t3, _MM_SHUFFLE(1, 0, 1, 0));
}
SINEW_AVX_FN void scatter_rows(float* const rows[8], F8 x, F8 y, F8 z) {
    const __m256 zero = _mm256_setzero_ps();
    __m256 t0 = _mm256_unpacklo_ps(x.m, y.m);  // x0 y0 x1 y1
    __m256 t1 = _mm256_unpackhi_ps(x.m, y.m);  // x2 y2 x3 y3
    __m256 t2 = _mm256_unpacklo_ps(z.m, zero);  // z0 0 z1 0
    __m256 t3 = _mm256_unpackhi_ps(z.m, zero);  // z2 0 z3 0
    __m256 r[4] = {_mm256_shuffle_ps(t0, t2, _MM_SHUFFLE(1, 0, 1, 0)), _mm256_shuffle_ps(t0, t2, _MM_SHUFFLE(3, 2, 3, 2)),
                   _mm256_shuffle_ps(t1, t3, _MM_SHUFFLE(1, 0, 1, 0)), _mm256_shuffle_ps(t1, t3, _MM_SHUFFLE(3, 2, 3, 2))};
    for (int i = 0; i < 4; ++i) {
        _mm_store_ps(rows[i], _mm256_castps256_ps128(r[i]));
        _mm_store_ps(rows[i + 4], _mm256_extractf128_ps(r[i], 1));
    }
}
#undef SINEW_AVX_FN
#pragma GCC pop_options

#endif  // SINEW_WIDE_X86

}  // namespace sinew
