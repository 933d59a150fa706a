// The soft step solver's contact kernels, written once for a register type `R` of `kR` lanes and
// included by rigid/soft_step_solver.cpp once per type (portable, SSE2, AVX), each time in its own
// namespace, the AVX one inside a target pragma. The including file defines R, kR and splat(Real), and
// the batch structures (WideContact, WidePoint, BatchInputs) before including this.
//
// A batch stores kWideLanes lanes; a kernel of kR < kWideLanes lanes runs it in kWideLanes / kR parts.
// Lanes of one batch never share a moving body (graph colouring), so the parts are independent.

struct V3 {
    R x, y, z;
};
inline V3 operator+(const V3& a, const V3& b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline V3 operator-(const V3& a, const V3& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline V3 operator*(R s, const V3& a) { return {s * a.x, s * a.y, s * a.z}; }
inline R dot(const V3& a, const V3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline V3 cross(const V3& a, const V3& b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
inline R ld(const FloatW& w, int part) { return load_r(w, part, static_cast<R*>(nullptr)); }
inline V3 ld(const Vec3W& w, int part) { return {ld(w.x, part), ld(w.y, part), ld(w.z, part)}; }
inline void st(FloatW& w, int part, R r) { store_r(w, part, r); }
inline void st(Vec3W& w, int part, const V3& r) {
    store_r(w.x, part, r.x);
    store_r(w.y, part, r.y);
    store_r(w.z, part, r.z);
}

/// A batch part's inverse inertia rows (A or B), for I^-1 (r x d) products.
struct InertiaR {
    V3 r[3];
    V3 operator*(const V3& v) const { return {dot(r[0], v), dot(r[1], v), dot(r[2], v)}; }
};
inline InertiaR ld(const Vec3W (&rows)[3], int part) { return {{ld(rows[0], part), ld(rows[1], part), ld(rows[2], part)}}; }

/// The kR bodies of one side of a batch part: velocities (read and written), motion since the step
/// began (read).
struct BodyR {
    V3 v, w, dp, dth;
};

inline BodyR gather(const WideBody* bodies, const std::int32_t* idx) {
    const Real* rows[kR];
    BodyR g;
    for (int i = 0; i < kR; ++i) rows[i] = bodies[idx[i]].v;
    gather_rows(rows, g.v.x, g.v.y, g.v.z);
    for (int i = 0; i < kR; ++i) rows[i] = bodies[idx[i]].w;
    gather_rows(rows, g.w.x, g.w.y, g.w.z);
    for (int i = 0; i < kR; ++i) rows[i] = bodies[idx[i]].dp;
    gather_rows(rows, g.dp.x, g.dp.y, g.dp.z);
    for (int i = 0; i < kR; ++i) rows[i] = bodies[idx[i]].dth;
    gather_rows(rows, g.dth.x, g.dth.y, g.dth.z);
    return g;
}

/// Writes velocities back to the moving bodies. `widx` is -1 for a lane whose body the solve cannot move
/// (static, kinematic, asleep, or the padding body): its unchanged velocity goes to the worker's scratch
/// row instead, so batches of one colour solved on different threads never write the same body (many
/// share the ground).
inline void scatter(WideBody* bodies, const std::int32_t* widx, WideBody* scratch, const BodyR& g) {
    Real* rows[kR];
    for (int i = 0; i < kR; ++i) rows[i] = widx[i] >= 0 ? bodies[widx[i]].v : scratch->v;
    scatter_rows(rows, g.v.x, g.v.y, g.v.z);
    for (int i = 0; i < kR; ++i) rows[i] = widx[i] >= 0 ? bodies[widx[i]].w : scratch->w;
    scatter_rows(rows, g.w.x, g.w.y, g.w.z);
}

/// Arms, Jacobians and effective masses of a batch from its staged inputs (one part).
inline void prepare_part(WideContact& c, const BatchInputs& in, int part) {
    const R zero = splat(0), one = splat(1), tiny = splat(Real(1e-30));
    const V3 n = ld(c.n, part), t[2] = {ld(c.t[0], part), ld(c.t[1], part)};
    const V3 xa = ld(in.xa, part), xb = ld(in.xb, part);
    const V3 va = ld(in.va, part), vb = ld(in.vb, part), wa = ld(in.wa, part), wb = ld(in.wb, part);
    const V3 ia[3] = {ld(c.ia[0], part), ld(c.ia[1], part), ld(c.ia[2], part)};
    const V3 ib[3] = {ld(c.ib[0], part), ld(c.ib[1], part), ld(c.ib[2], part)};
    const R inv_m_sum = ld(c.inv_m_sum, part);
    auto mul_a = [&](const V3& v) { return V3{dot(ia[0], v), dot(ia[1], v), dot(ia[2], v)}; };
    auto mul_b = [&](const V3& v) { return V3{dot(ib[0], v), dot(ib[1], v), dot(ib[2], v)}; };
    for (int k = 0; k < c.max_count; ++k) {
        WidePoint& p = c.p[k];
        const R has = greater_r(ld(in.valid[k], part), zero);
        const V3 pos = ld(in.pos[k], part);
        const V3 ra = pos - xa, rb = pos - xb;
        const V3 ra_n = cross(ra, n), rb_n = cross(rb, n);
        const V3 ia_n = mul_a(ra_n), ib_n = mul_b(rb_n);
        st(p.ra_n, part, ra_n);
        st(p.rb_n, part, rb_n);
        const R kn = inv_m_sum + dot(ra_n, ia_n) + dot(rb_n, ib_n);
        st(p.normal_mass, part, select_r(and_r(has, greater_r(kn, zero)), one / max_r(kn, tiny), zero));
        for (int j = 0; j < 2; ++j) {
            const V3 ra_t = cross(ra, t[j]), rb_t = cross(rb, t[j]);
            const V3 ia_t = mul_a(ra_t), ib_t = mul_b(rb_t);
            st(p.ra_t[j], part, ra_t);
            st(p.rb_t[j], part, rb_t);
            const R kt = inv_m_sum + dot(ra_t, ia_t) + dot(rb_t, ib_t);
            st(p.tangent_mass[j], part, select_r(and_r(has, greater_r(kt, zero)), one / max_r(kt, tiny), zero));
        }
        st(p.max_normal_impulse, part, zero);
        st(p.relative_velocity, part, dot(n, vb + cross(wb, rb) - va - cross(wa, ra)));
    }
}

inline void prepare_batch(WideContact& c, const BatchInputs& in) {
    for (int part = 0; part * kR < c.lanes; ++part) prepare_part(c, in, part);
}

inline void warm_start_all(WideContact* contacts, std::size_t count, WideBody* bodies, WideBody* scratch) {
    for (std::size_t ci = 0; ci < count; ++ci) {
        WideContact& c = contacts[ci];
        for (int part = 0; part * kR < c.lanes; ++part) {
            const std::int32_t *ia = c.a + part * kR, *ib = c.b + part * kR;
            BodyR A = gather(bodies, ia), B = gather(bodies, ib);
            // The points share n and t, so their linear impulses add up before touching the velocities.
            // The angular impulses add up too (sum of r x j), then one product with each inverse inertia.
            R pn = splat(0), p0 = splat(0), p1 = splat(0);
            V3 la{pn, pn, pn}, lb{pn, pn, pn};
            for (int k = 0; k < c.max_count; ++k) {
                const WidePoint& p = c.p[k];
                const R ln = ld(p.normal_impulse, part), l0 = ld(p.tangent_impulse[0], part),
                        l1 = ld(p.tangent_impulse[1], part);
                pn = pn + ln;
                p0 = p0 + l0;
                p1 = p1 + l1;
                la = la + ln * ld(p.ra_n, part) + l0 * ld(p.ra_t[0], part) + l1 * ld(p.ra_t[1], part);
                lb = lb + ln * ld(p.rb_n, part) + l0 * ld(p.rb_t[0], part) + l1 * ld(p.rb_t[1], part);
            }
            const V3 j = pn * ld(c.n, part) + p0 * ld(c.t[0], part) + p1 * ld(c.t[1], part);
            A.v = A.v - ld(c.inv_ma, part) * j;
            B.v = B.v + ld(c.inv_mb, part) * j;
            A.w = A.w - ld(c.ia, part) * la;
            B.w = B.w + ld(c.ib, part) * lb;
            scatter(bodies, c.wa + part * kR, scratch, A);
            scatter(bodies, c.wb + part * kR, scratch, B);
        }
    }
}

inline void solve_all(WideContact* contacts, std::size_t count, WideBody* bodies, WideBody* scratch, Real inv_h_sub, Real push_velocity,
                      bool use_bias) {
    const R zero = splat(0), one = splat(1), inv_h = splat(inv_h_sub), min_bias = splat(-push_velocity);
    const R tiny = splat(Real(1e-30));
    for (std::size_t ci = 0; ci < count; ++ci) {
        WideContact& c = contacts[ci];
        for (int part = 0; part * kR < c.lanes; ++part) {
            const std::int32_t *ia = c.a + part * kR, *ib = c.b + part * kR;
            BodyR A = gather(bodies, ia), B = gather(bodies, ib);
            const V3 n = ld(c.n, part), t0 = ld(c.t[0], part), t1 = ld(c.t[1], part);
            const R inv_m_sum = ld(c.inv_m_sum, part);
            const InertiaR ia_rows = ld(c.ia, part), ib_rows = ld(c.ib, part);
            const R dpn = dot(n, B.dp - A.dp);
            // The linear part of each row's velocity, n.(vB - vA) and t.(vB - vA), is the same for all
            // points of a manifold, and an impulse along n changes only the n part (n, t0, t1 are
            // orthonormal) by dl (1/mA + 1/mB). Tracking the three projections and applying the summed
            // linear impulse once at the end is exact and saves a third of the arithmetic.
            const V3 dv = B.v - A.v;
            R vn_lin = dot(n, dv), vt0_lin = dot(t0, dv), vt1_lin = dot(t1, dv);
            R pn = zero, p0 = zero, p1 = zero;
            R bias_rate = zero, mass_scale_soft = one, impulse_scale_soft = zero;
            if (use_bias) {
                bias_rate = ld(c.bias_rate, part);
                mass_scale_soft = ld(c.mass_scale, part);
                impulse_scale_soft = ld(c.impulse_scale, part);
            }
            for (int k = 0; k < c.max_count; ++k) {
                WidePoint& p = c.p[k];
                const V3 ra_n = ld(p.ra_n, part), rb_n = ld(p.rb_n, part);
                const R s = ld(p.base_separation, part) + dpn + dot(rb_n, B.dth) - dot(ra_n, A.dth);
                // A gap (s > 0) is speculative: the bodies may close it this sub-step. An overlap gets
                // the soft push in the biased pass and nothing in the relax pass.
                const R gap = greater_r(s, zero);
                R bias, mass_scale = one, impulse_scale = zero;
                if (use_bias) {
                    bias = select_r(gap, s * inv_h, max_r(bias_rate * s, min_bias));
                    mass_scale = select_r(gap, one, mass_scale_soft);
                    impulse_scale = select_r(gap, zero, impulse_scale_soft);
                } else {
                    bias = select_r(gap, s * inv_h, zero);
                }
                const R old = ld(p.normal_impulse, part);
                const R vn = vn_lin + dot(rb_n, B.w) - dot(ra_n, A.w);
                const R impulse = zero - ld(p.normal_mass, part) * mass_scale * (vn + bias) - impulse_scale * old;
                const R acc = max_r(old + impulse, zero);
                const R dl = acc - old;
                st(p.normal_impulse, part, acc);
                st(p.max_normal_impulse, part, max_r(ld(p.max_normal_impulse, part), dl));
                // A sub-step ends with its relax pass: what has accumulated by then is its impulse.
                if (!use_bias) st(p.total_normal_impulse, part, ld(p.total_normal_impulse, part) + acc);
                vn_lin = vn_lin + dl * inv_m_sum;
                pn = pn + dl;
                A.w = A.w - dl * (ia_rows * ra_n);
                B.w = B.w + dl * (ib_rows * rb_n);
            }
            // Friction after the normals (Box2D v3 order within a sub-step), bounded by each point's
            // normal impulse (seed 001 ch.5), on two persistent tangents; both rows from the same
            // velocities, then clamped together to the friction circle (a square cone is up to sqrt 2
            // too strong).
            const R friction = ld(c.friction, part);
            for (int k = 0; k < c.max_count; ++k) {
                WidePoint& p = c.p[k];
                const R max_f = friction * ld(p.normal_impulse, part);
                const V3 ra_t0 = ld(p.ra_t[0], part), rb_t0 = ld(p.rb_t[0], part);
                const V3 ra_t1 = ld(p.ra_t[1], part), rb_t1 = ld(p.rb_t[1], part);
                const R vt0 = vt0_lin + dot(rb_t0, B.w) - dot(ra_t0, A.w);
                const R vt1 = vt1_lin + dot(rb_t1, B.w) - dot(ra_t1, A.w);
                const R old0 = ld(p.tangent_impulse[0], part), old1 = ld(p.tangent_impulse[1], part);
                R l0 = old0 - ld(p.tangent_mass[0], part) * vt0;
                R l1 = old1 - ld(p.tangent_mass[1], part) * vt1;
                const R len2 = l0 * l0 + l1 * l1;
                const R over = greater_r(len2, max_f * max_f);
                const R scale = select_r(over, max_f / sqrt_r(max_r(len2, tiny)), one);
                l0 = l0 * scale;
                l1 = l1 * scale;
                const R d0 = l0 - old0, d1 = l1 - old1;
                st(p.tangent_impulse[0], part, l0);
                st(p.tangent_impulse[1], part, l1);
                vt0_lin = vt0_lin + d0 * inv_m_sum;
                vt1_lin = vt1_lin + d1 * inv_m_sum;
                p0 = p0 + d0;
                p1 = p1 + d1;
                A.w = A.w - (d0 * (ia_rows * ra_t0) + d1 * (ia_rows * ra_t1));
                B.w = B.w + (d0 * (ib_rows * rb_t0) + d1 * (ib_rows * rb_t1));
            }
            const V3 j = pn * n + p0 * t0 + p1 * t1;
            A.v = A.v - ld(c.inv_ma, part) * j;
            B.v = B.v + ld(c.inv_mb, part) * j;
            scatter(bodies, c.wa + part * kR, scratch, A);
            scatter(bodies, c.wb + part * kR, scratch, B);
        }
    }
}

inline void restitution_all(WideContact* contacts, std::size_t count, WideBody* bodies, WideBody* scratch, Real threshold) {
    const R zero = splat(0), min_speed = splat(-threshold);
    for (std::size_t ci = 0; ci < count; ++ci) {
        WideContact& c = contacts[ci];
        if (!c.any_restitution) continue;
        for (int part = 0; part * kR < c.lanes; ++part) {
            const std::int32_t *ia = c.a + part * kR, *ib = c.b + part * kR;
            BodyR A = gather(bodies, ia), B = gather(bodies, ib);
            const V3 n = ld(c.n, part);
            const R e = ld(c.restitution, part), inv_ma = ld(c.inv_ma, part), inv_mb = ld(c.inv_mb, part);
            for (int k = 0; k < c.max_count; ++k) {
                WidePoint& p = c.p[k];
                const R rel = ld(p.relative_velocity, part), old = ld(p.normal_impulse, part);
                // Only impacts faster than the threshold that actually pushed (Box2D v3).
                const R bounce = and_r(and_r(less_r(rel, min_speed), greater_r(ld(p.max_normal_impulse, part), zero)),
                                       greater_r(e, zero));
                const V3 ra_n = ld(p.ra_n, part), rb_n = ld(p.rb_n, part);
                const R vn = dot(n, B.v - A.v) + dot(rb_n, B.w) - dot(ra_n, A.w);
                const R impulse = zero - ld(p.normal_mass, part) * (vn + e * rel);
                const R dl = select_r(bounce, max_r(old + impulse, zero) - old, zero);
                st(p.normal_impulse, part, old + dl);
                st(p.total_normal_impulse, part, ld(p.total_normal_impulse, part) + dl);
                A.v = A.v - (dl * inv_ma) * n;
                B.v = B.v + (dl * inv_mb) * n;
                A.w = A.w - dl * (ld(c.ia, part) * ra_n);
                B.w = B.w + dl * (ld(c.ib, part) * rb_n);
            }
            scatter(bodies, c.wa + part * kR, scratch, A);
            scatter(bodies, c.wb + part * kR, scratch, B);
        }
    }
}
