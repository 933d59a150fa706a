// "Soft step" (Catto, Solver2D 2024, as in Box2D v3): the step is split into sub-steps; each sub-step
// integrates velocities, warm starts, solves the contacts once with soft constraints (Catto 2011: a
// spring-damper of `contact_hertz` and `contact_damping_ratio`, implicit and so unconditionally stable)
// biased to remove penetration, integrates positions, and relaxes once without the bias so the push-out
// does not turn into kinetic energy. No slop: any penetration gets a restoring push, so a tilted box in a
// tower is levelled instead of creeping within the slop band.
//
// Contacts are detected once per step. Within the step a point's separation follows the bodies' motion to
// first order, s = s0 + n.(dp_B - dp_A) + (r_B x n).dth_B - (r_A x n).dth_A, with dp and dth the
// translation and rotation vector accumulated since the step began: the Jacobian row applied to the
// displacement, as NVIDIA's TGS solver does. It needs no rotated anchors, so a body's solver state is
// four rows (v, w, dp, dth) that 4x4 transposes gather.
//
// Manifolds are graph-coloured (rigid/constraint_colouring.hpp) and a colour is solved eight manifolds
// at a time, one per SIMD lane (rigid/wide_float.hpp, kernels in rigid/soft_step_kernels.inl), as Box2D
// v3 does. Manifolds that fit no colour run one per batch. Pairs of two immovable bodies (asleep, or
// asleep on static ground) are left out: nothing can move them, and their warm-start impulses are kept
// for when they wake. Measured on pyramid-40 (820 boxes, 2,380 manifolds): docs/rigid-solvers.md.
#include <algorithm>
#include <atomic>
#include <vector>

#include "rigid/constraint_colouring.hpp"
#include "rigid/constraint_rows.hpp"
#include "rigid/joint_set.hpp"
#include "rigid/rigid_solver.hpp"
#include "rigid/soft_constraint.hpp"
#include "rigid/wide_float.hpp"

namespace sinew {

namespace {

using Softness = SoftCoefficients;  // rigid/soft_constraint.hpp

/// The stiffest a contact against an immovable body gets: omega h_sub (SoftStepSolver::prepare).
constexpr Real kMaxStaticOmegaH = 2;

/// Point slot k of a batch's manifolds, one per lane. Lanes whose manifold has fewer points keep zero
/// masses and impulses, so they compute nothing.
struct WidePoint {
    // r x n and r x t for A and B. The products with the inverse inertia are not stored: they are
    // recomputed from the batch's inertia rows off the solve's dependency chain, which costs less than
    // streaming 18 more lanes per point through the cache (pyramid-40's contacts outgrow L2).
    Vec3W ra_n, rb_n;
    Vec3W ra_t[2], rb_t[2];
    FloatW normal_mass, tangent_mass[2];
    FloatW normal_impulse, tangent_impulse[2], max_normal_impulse;
    FloatW total_normal_impulse;  // summed over the step's sub-steps (each ends with a relax pass)
    FloatW base_separation;    // separation at detection (negative = overlap)
    FloatW relative_velocity;  // normal velocity at the start of the step (restitution)
};

/// Up to kWideLanes manifolds of one colour, solved side by side. Unused lanes point at the padding body
/// and have zero masses.
struct WideContact {
    std::int32_t a[kWideLanes], b[kWideLanes];    // bodies read (immovable ones and the padding body too)
    std::int32_t wa[kWideLanes], wb[kWideLanes];  // bodies written: a and b where they move, else -1
    Vec3W n, t[2];
    FloatW inv_ma, inv_mb, inv_m_sum, friction, restitution;
    FloatW bias_rate, mass_scale, impulse_scale;  // soft contact (Catto 2011), per lane
    Vec3W ia[3], ib[3];                           // rows of the world inverse inertia of A and B
    std::uint32_t manifold[kWideLanes];           // source manifold, or kNoManifold
    int count[kWideLanes];
    int lanes;      // lanes in use (the rest are padding)
    int max_count;  // most points of any lane
    bool any_restitution;
    WidePoint p[Manifold::kMaxPoints];
};

/// Per-lane inputs of a batch, staged so the kernels compute the arms and masses lanes at a time.
struct BatchInputs {
    Vec3W xa, xb, va, vb, wa, wb;
    Vec3W pos[Manifold::kMaxPoints];
    FloatW valid[Manifold::kMaxPoints];  // 1 where the lane's manifold has point k
    bool any_restitution;                // a batch this worker filled this step bounces
};

constexpr std::uint32_t kNoManifold = 0xFFFFFFFFu;

// ---- kernels: one copy per register type ------------------------------------------------------------
namespace portable {
using R = G4;
constexpr int kR = 4;
inline R splat(Real x) { return splat_g4(x); }
#include "rigid/soft_step_kernels.inl"
}  // namespace portable

#if SINEW_WIDE_X86
namespace sse2 {
using R = F4;
constexpr int kR = 4;
inline R splat(Real x) { return splat_f4(x); }
#include "rigid/soft_step_kernels.inl"
}  // namespace sse2

#pragma GCC push_options
#pragma GCC target("avx")
namespace avx {
using R = F8;
constexpr int kR = 8;
inline R splat(Real x) { return splat_f8(x); }
#include "rigid/soft_step_kernels.inl"
}  // namespace avx
#pragma GCC pop_options
#endif

/// The kernels of one register type: prepare once per batch, the others once per pass over all batches.
struct Kernels {
    void (*prepare)(WideContact&, const BatchInputs&);
    void (*warm_start)(WideContact*, std::size_t, WideBody*, WideBody*);
    void (*solve)(WideContact*, std::size_t, WideBody*, WideBody*, Real, Real, bool);
    void (*restitution)(WideContact*, std::size_t, WideBody*, WideBody*, Real);
};

/// Contact batches a worker claims at least at a time (a region cuts a stage into at most eight blocks
/// per worker): a batch is a few hundred nanoseconds of work, a claim one atomic. One, so that a colour's
/// last block is small and neither thread waits long for the other at the colour's end: on pyramid-40
/// (about 128 stages a step) 2 workers took 0.902-0.908 ms a step with four batches and at most four
/// blocks per worker, 0.884-0.889 ms with one and eight (16 blocks: 0.907-0.909).
constexpr int kBatchesPerBlock = 1;
/// Bodies a worker claims at a time in the per-body loops.
constexpr int kBodiesPerBlock = 64;
/// Manifolds from which the solve runs on the workers (below it, on the calling thread alone).
constexpr std::size_t kParallelManifolds = 128;
/// Joints from which it does too (the joint set solves its groups of joints on the workers): those the
/// last step prepared with a moving body, so idle joints (asleep, static) wake no helper.
constexpr std::size_t kParallelJoints = 64;
/// Manifolds per block of islands in the blocked solve (SoftStepSolver::plan_blocks): a block's batches
/// (about 630 bytes a manifold) and its bodies stay in a core's L2 cache (1 MiB here) through every pass
/// of the step's sub-steps.
constexpr std::size_t kBlockManifolds = 1024;
/// Entries of a block's colour table: each colour's first batch, the overflow's, and the block's end.
constexpr int kColourStarts = ConstraintColouring::kColours + 2;

Kernels kernels_for(SimdKernel k) {
    switch (k) {
#if SINEW_WIDE_X86
        case SimdKernel::Avx:
            return {avx::prepare_batch, avx::warm_start_all, avx::solve_all, avx::restitution_all};
        case SimdKernel::Sse2:
            return {sse2::prepare_batch, sse2::warm_start_all, sse2::solve_all, sse2::restitution_all};
#endif
        default:
            return {portable::prepare_batch, portable::warm_start_all, portable::solve_all, portable::restitution_all};
    }
}

bool cpu_has_avx() {
#if SINEW_WIDE_X86
    static const bool has = __builtin_cpu_supports("avx");
    return has;
#else
    return false;
#endif
}

SimdKernel widest_kernel() {
#if SINEW_WIDE_X86
    return cpu_has_avx() ? SimdKernel::Avx : SimdKernel::Sse2;
#else
    return SimdKernel::Portable;
#endif
}

std::atomic<SimdKernel> g_kernel{SimdKernel::Auto};

/// Body s's velocities between the system's state and the solver's row.
void state_from_row(RigidSystem::State& st, std::uint32_t s, const WideBody& b) {
    st.v[s] = Vec3(b.v[0], b.v[1], b.v[2]);
    st.w[s] = Vec3(b.w[0], b.w[1], b.w[2]);
}
void row_from_state(WideBody& b, const RigidSystem::State& st, std::uint32_t s) {
    for (int j = 0; j < 3; ++j) {
        b.v[j] = st.v[s][j];
        b.w[j] = st.w[s][j];
    }
}

class SoftStepSolver final : public RigidSolver {
public:
    bool integrates_itself() const override { return true; }
    Real unintegrated_time_after_solve(Real) const override { return h_sub_; }
    int last_solve_blocks() const override { return blocked_ ? block_count() : 0; }
    void solve_velocities(RigidSystem& sys, Real h) override;
    void finish_step(RigidSystem& sys, Real h) override;

private:
    /// Runs f() in a parallel region of the system's task system (solve_velocities and finish_step each
    /// run in one), with the per-worker scratch sized for it.
    template <class F>
    void in_region(RigidSystem& sys, F&& f);
    void solve_in_region(RigidSystem& sys, Real h);
    void finish_in_region(RigidSystem& sys);
    /// moving_: the bodies the step may move (dynamic and awake, or with a velocity), in slot order.
    void find_moving(const RigidSystem::State& st);
    void colour(RigidSystem& sys);
    void prepare(RigidSystem& sys, Real h_sub);
    /// Decides whether this step is solved block by block and, if so, groups the islands into blocks.
    void plan_blocks(const RigidSystem& sys);
    /// Every sub-step of block b on one worker (the blocked solve's counterpart of the sub-step loop).
    void substeps_of_block(RigidSystem& sys, int b, int worker, int n_sub, Real inv_h_sub);
    /// Calls f(first batch, count) for each colour of block b with batches, then its overflow.
    template <class F>
    void block_colours(int b, F&& f) {
        const std::uint32_t* cs = block_colour_start_.data() + std::size_t(b) * kColourStarts;
        for (int c = 0; c <= ConstraintColouring::kOverflow; ++c)
            if (cs[c + 1] > cs[c]) f(contacts_.data() + cs[c], std::size_t(cs[c + 1] - cs[c]));
    }
    int block_count() const { return int(block_body_start_.size()) - 1; }
    /// Prepares batch c from up to kWideLanes manifolds of one colour (`lanes` of them).
    void fill_batch(WideContact& c, const std::uint32_t* manifolds, int lanes, const RigidSystem& sys,
                    const Softness& soft, const Softness& static_soft, BatchInputs& in);
    /// Runs f(first batch, count, worker scratch body) over every batch: colour by colour, each colour's
    /// batches split among the region's workers (they share no moving body), then the overflow batches
    /// on the calling thread. The same order as one loop over contacts_ on one thread.
    template <class F>
    void per_colour(F&& f);
    void warm_start() {
        per_colour([&](WideContact* c, std::size_t n, WideBody* scratch) { kernels_.warm_start(c, n, bodies_.data(), scratch); });
    }
    void solve(Real inv_h_sub, Real push_velocity, bool use_bias) {
        per_colour([&](WideContact* c, std::size_t n, WideBody* scratch) {
            kernels_.solve(c, n, bodies_.data(), scratch, inv_h_sub, push_velocity, use_bias);
        });
    }
    void clear_impulses() {
        for (WideContact& c : contacts_)
            for (int k = 0; k < c.max_count; ++k)
                for (FloatW* f : {&c.p[k].normal_impulse, &c.p[k].tangent_impulse[0], &c.p[k].tangent_impulse[1]})
                    *f = FloatW{};
    }
    void restitution(Real threshold) {
        per_colour([&](WideContact* c, std::size_t n, WideBody* scratch) {
            kernels_.restitution(c, n, bodies_.data(), scratch, threshold);
        });
    }
    /// Each moving body's state from its row and each batch's impulses into its manifolds, one stage.
    void store_results(RigidSystem& sys);
    static void store_batch(const WideContact& c, std::vector<ContactManifold>& dst);
    /// worker_order_ for this step's colours and the region's workers.
    void order_batches_by_worker();
    BodyVelocities body_view() { return BodyVelocities::of(bodies_, &WideBody::v, &WideBody::w); }
    void bodies_to_state(RigidSystem::State& st) const;
    // The last sub-step is finished in finish_step(), after the pipeline's coupling hooks.
    /// The sub-step's positions, the sources told, then relax. With `load`, each body's velocities are
    /// first taken from the system's state in the same body stage (finish_step: hooks may have set them).
    void integrate_and_relax(RigidSystem& sys, bool load = false);
    /// Body s's position and rotation over the sub-step, and its motion since the step began.
    void integrate_body_position(RigidSystem& sys, RigidSystem::State& st, std::uint32_t s) {
        WideBody& b = bodies_[s];
        const Vec3 v(b.v[0], b.v[1], b.v[2]), w(b.w[0], b.w[1], b.w[2]);
        if (st.inv_mass[s] == 0 && v.isZero() && w.isZero()) return;
        st.x[s] += h_sub_ * v;
        st.q[s] = sys.turned(s, w, h_sub_);
        // The passes after this one (the relax, the next sub-step) apply impulses at the new orientation:
        // the angular velocity and inverse inertia turn with the body now. Left in the frame of the
        // sub-step's start, a kicked loop of four ball-jointed 1 m x 6 cm bars (inertia 140:1) spun up to
        // 3,700 rad/s about their long axes within 3 s and opened by 0.42 m: an impulse at the new
        // orientation read in the old frame gains a long-axis part, which the small inertia amplifies.
        st.w[s] = w;
        sys.follow_turn(s);
        for (int i = 0; i < 3; ++i) b.w[i] = st.w[s][i];
        for (int i = 0; i < 3; ++i) {
            b.dp[i] += h_sub_ * v[i];
            b.dth[i] += h_sub_ * w[i];
        }
    }

    ConstraintColouring colouring_;
    std::vector<std::uint32_t> by_colour_[ConstraintColouring::kColours + 1];
    std::vector<WideContact> contacts_;
    /// Batches [colour_start_[c], colour_start_[c + 1]) are colour c's; the overflow colour's come last.
    std::uint32_t colour_start_[ConstraintColouring::kColours + 2] = {};
    std::vector<WideBody> bodies_;  // one per body slot, then the padding body (always at rest)
    Kernels kernels_{};
    /// Per worker of the region in progress: staged batch inputs and the row immovable bodies' lanes
    /// write to (kernels' scatter).
    std::vector<BatchInputs> inputs_;
    /// A worker's row on a cache line of its own (WideBody is 16-byte aligned): the workers write theirs
    /// at every batch.
    struct alignas(64) ScratchRow {
        WideBody body;
    };
    std::vector<ScratchRow> scratch_;
    ParallelRegion* region_ = nullptr;
    std::int32_t pad_ = 0;  // index of the padding body
    /// Slots that move in this step's solve (inverse mass, or a velocity: kinematic), in slot order; the
    /// sub-steps' per-body loops run over these alone while moving_only_ (for_each_body).
    std::vector<std::uint32_t> moving_;
    std::vector<std::uint32_t> moved_in_solve_;  ///< the solve's moving_, when finish_step found them anew
    bool moving_only_ = false;
    bool any_restitution_ = false;  ///< a manifold of this step's colours has restitution > 0
    /// The batches in the order the once-per-step batch stages (the fill, the impulses' store) take them:
    /// the first worker's share of every colour, then the second's, and so on. A colour stage gives
    /// each worker its share of the colour (ParallelRegion cuts a stage into one range per worker), so
    /// a worker mostly fills and stores the batches it solves (ranges round to whole blocks, and steal)
    /// and their data stays in its core's cache. In
    /// batch order the first worker filled colours 0-2 and the second 3-5 on pyramid-40, and each
    /// colour stage then read half its batches from the other core.
    std::vector<std::uint32_t> worker_order_;

    // Colours and blocks kept from step to step. The colouring is a function of the active manifolds,
    // the bodies each joins and which of them move; the blocks add the moving bodies. While those stand
    // (a stack at rest: pyramid-40's active list did not change in 340 steps), last step's colours and
    // blocks are this step's, as Box2D v3 keeps a contact's colour while it persists. Colouring and
    // planning pyramid-40's 2,380 manifolds cost about 20 us a step on the calling thread alone.
    std::uint64_t coloured_revision_ = ~std::uint64_t(0);  ///< the active list's revision coloured
    std::vector<std::uint8_t> coloured_moves_;             ///< per slot: inverse mass > 0 when coloured
    std::vector<std::uint8_t> moves_scratch_;
    std::vector<std::uint32_t> immovable_pairs_;  ///< active manifolds between two immovable bodies
    bool colours_kept_ = false;                   ///< this step's colour() kept the last step's colours
    bool plan_kept_ = false;                      ///< the block plan stands for the colours and moving_
    std::vector<std::uint32_t> planned_moving_;   ///< moving_ when the blocks were planned
    /// plan_blocks' work once it must plan anew.
    void make_plan(const RigidSystem& sys);
    template <class F>
    void for_each_body(std::size_t count, F&& f) const;
    bool pending_ = false;
    Real h_sub_ = 0;

    // The blocked solve. A world of many independent islands (many-pyramids) does not fit the cache:
    // colour-major passes stream every batch from memory three times per sub-step (the solve took 3.6 us
    // per box on 5,500 and on 49,500 boxes in pyramids; 2.6-2.7 us in blocks). Islands are then grouped
    // into blocks that are solved one after another through all the sub-steps. Blocks share no moving body, so every body
    // gets the same updates in the same order as in colour-major passes, and the result is bit-identical;
    // a block is one worker's task, with no barrier between colours.
    bool blocked_ = false;
    std::vector<std::uint32_t> block_colour_start_;  ///< kColourStarts batch indices per block
    std::vector<std::uint32_t> block_body_start_;    ///< per block and one past: into block_bodies_
    std::vector<std::uint32_t> block_bodies_;        ///< moving bodies, block by block, in slot order
    std::vector<std::uint32_t> batch_first_;         ///< per batch: its first manifold in batch_manifolds_
    std::vector<std::uint32_t> batch_manifolds_;     ///< manifolds in batch order
    std::vector<std::uint8_t> batch_lanes_;          ///< per batch: manifolds in it
    std::vector<std::uint32_t> island_of_;           ///< scratch: union-find parent per slot, then the root
    std::vector<std::uint32_t> component_;           ///< scratch: per slot, its island's number
    std::vector<std::uint8_t> in_solve_;             ///< scratch: per slot, 1 if in moving_
    std::vector<std::uint32_t> count_scratch_;       ///< scratch: per component, its manifolds, then its block
    std::vector<std::uint32_t> first_scratch_;       ///< scratch: first manifold per block and colour
    std::vector<std::uint32_t> next_scratch_;        ///< scratch: fill positions of the counting sorts
};

void SoftStepSolver::colour(RigidSystem& sys) {
    const RigidSystem::State& st = sys.state();
    auto& src = sys.mutable_contacts();
    const std::size_t nb = st.x.size();
    moves_scratch_.resize(nb);
    for (std::size_t s = 0; s < nb; ++s) moves_scratch_[s] = st.inv_mass[s] > 0;
    colours_kept_ = coloured_revision_ == sys.active_contacts_revision() && moves_scratch_ == coloured_moves_;
    std::swap(moves_scratch_, coloured_moves_);
    if (!colours_kept_) {
        coloured_revision_ = ~std::uint64_t(0);  // until the colouring below is whole
        colouring_.reset(nb);
        for (auto& list : by_colour_) list.clear();
        immovable_pairs_.clear();
        // Only the manifolds detection handed on: sleeping islands' are neither solved nor read.
        for (const std::uint32_t ci : sys.active_contacts()) {
            const std::uint32_t a = src[ci].body_a, b = src[ci].body_b;
            const bool a_moves = st.inv_mass[a] > 0, b_moves = st.inv_mass[b] > 0;
            if (!a_moves && !b_moves) immovable_pairs_.push_back(ci);
            else by_colour_[colouring_.assign(a, a_moves, b, b_moves)].push_back(ci);
        }
        coloured_revision_ = sys.active_contacts_revision();
    }
    // Nothing can move either body: no constraint, nothing applied this step.
    for (const std::uint32_t ci : immovable_pairs_) {
        ContactManifold& cm = src[ci];
        for (int k = 0; k < cm.manifold.count; ++k) cm.manifold.points[k].total_normal_impulse = 0;
    }
}

void SoftStepSolver::fill_batch(WideContact& c, const std::uint32_t* manifolds, int lanes, const RigidSystem& sys,
                                const Softness& soft, const Softness& static_soft, BatchInputs& in) {
    const RigidSystem::State& st = sys.state();
    const auto& src = sys.contacts();
    const bool warm = sys.settings().warm_starting;
    c.lanes = lanes;
    c.max_count = 0;
    c.any_restitution = false;
    // Per-lane data is staged into lanes here; the kernel then computes the arms, Jacobians and effective
    // masses lanes at a time. Unused lanes point at the padding body with zero mass and inertia.
    for (int l = 0; l < kWideLanes; ++l) {
        Softness s{};
        if (l < lanes) {
            const ContactManifold& cm = src[manifolds[l]];
            const std::uint32_t a = cm.body_a, b = cm.body_b;
            c.a[l] = std::int32_t(a);
            c.b[l] = std::int32_t(b);
            c.wa[l] = st.inv_mass[a] > 0 ? std::int32_t(a) : -1;  // the colouring's "moves"
            c.wb[l] = st.inv_mass[b] > 0 ? std::int32_t(b) : -1;
            c.manifold[l] = manifolds[l];
            c.count[l] = cm.manifold.count;
            c.max_count = std::max(c.max_count, cm.manifold.count);
            Vec3 n = cm.manifold.normal, t0, t1;
            tangent_basis(n, t0, t1);  // persistent for a persistent normal (seed 001 ch.5)
            set_lane(c.n, l, n);
            set_lane(c.t[0], l, t0);
            set_lane(c.t[1], l, t1);
            // A body holding up one far heavier looks heavier to this contact alone (rigid_support.cpp).
            Real sa, sb;
            sys.contact_mass_scales(a, b, sa, sb);
            const Real wa = sa * st.inv_mass[a], wb = sb * st.inv_mass[b];
            c.inv_ma.set_lane(l, wa);
            c.inv_mb.set_lane(l, wb);
            c.inv_m_sum.set_lane(l, wa + wb);
            c.friction.set_lane(l, cm.friction);
            c.restitution.set_lane(l, cm.restitution);
            c.any_restitution = c.any_restitution || cm.restitution > 0;
            // Contacts against immovable bodies are twice as stiff since only one body gives way (Box2D v3).
            s = (wa == 0 || wb == 0) ? static_soft : soft;
            set_lane(in.xa, l, st.x[a]);
            set_lane(in.xb, l, st.x[b]);
            set_lane(in.va, l, st.v[a]);
            set_lane(in.vb, l, st.v[b]);
            set_lane(in.wa, l, st.w[a]);
            set_lane(in.wb, l, st.w[b]);
            const Mat3 ia = sa * st.inv_inertia_world[a];
            const Mat3 ib = sb * st.inv_inertia_world[b];
            for (int row = 0; row < 3; ++row) {
                set_lane(c.ia[row], l, ia.row(row).transpose());
                set_lane(c.ib[row], l, ib.row(row).transpose());
            }
        } else {
            c.a[l] = c.b[l] = pad_;
            c.wa[l] = c.wb[l] = -1;
            c.manifold[l] = kNoManifold;
            c.count[l] = 0;
            set_lane(c.n, l, Vec3::UnitY());
            set_lane(c.t[0], l, Vec3::UnitX());
            set_lane(c.t[1], l, Vec3::UnitZ());
            for (FloatW* f : {&c.inv_ma, &c.inv_mb, &c.inv_m_sum, &c.friction, &c.restitution}) f->set_lane(l, 0);
            for (Vec3W* v : {&in.xa, &in.xb, &in.va, &in.vb, &in.wa, &in.wb, &c.ia[0], &c.ia[1], &c.ia[2],
                             &c.ib[0], &c.ib[1], &c.ib[2]})
                set_lane(*v, l, Vec3::Zero());
        }
        c.bias_rate.set_lane(l, s.bias_rate);
        c.mass_scale.set_lane(l, s.mass_scale);
        c.impulse_scale.set_lane(l, s.impulse_scale);
    }
    in.any_restitution = in.any_restitution || c.any_restitution;
    for (int k = 0; k < c.max_count; ++k) {
        WidePoint& p = c.p[k];
        for (int l = 0; l < kWideLanes; ++l) {
            if (k < c.count[l]) {
                const ContactPoint& cp = src[c.manifold[l]].manifold.points[k];
                set_lane(in.pos[k], l, cp.position);
                in.valid[k].set_lane(l, 1);
                p.normal_impulse.set_lane(l, warm ? cp.normal_impulse : 0);
                p.tangent_impulse[0].set_lane(l, warm ? cp.tangent_impulse[0] : 0);
                p.tangent_impulse[1].set_lane(l, warm ? cp.tangent_impulse[1] : 0);
                p.base_separation.set_lane(l, -cp.depth);
            } else {
                // An empty slot: zero arms, masses and impulses, so it computes nothing.
                set_lane(in.pos[k], l, lane(in.xa, l));
                in.valid[k].set_lane(l, 0);
                for (FloatW* f : {&p.normal_impulse, &p.tangent_impulse[0], &p.tangent_impulse[1], &p.base_separation})
                    f->set_lane(l, 0);
            }
            p.total_normal_impulse.set_lane(l, 0);
        }
    }
    kernels_.prepare(c, in);
}

void SoftStepSolver::prepare(RigidSystem& sys, Real h_sub) {
    const RigidSettings& set = sys.settings();
    // Contact stiffness is capped at a quarter of the sub-step rate (Box2D v3). Contacts against immovable
    // bodies are twice as stiff, since only one body gives way (Box2D v3), but no stiffer than
    // omega h_sub = kMaxStaticOmegaH: past about 2.3 the coloured passes feed a rocking mode. Measured on
    // a lone 10-row pyramid, h = 1/60, 5 sub-steps: at 120 Hz (omega h_sub = 2.51) the top box rocked out of
    // plane at about 9 Hz and 0.14 m/s for as long as it ran and never slept; capped at 2.2 it slept by
    // step 34, at 2.0 by step 32 (and 1.8, 1.6 the same).
    const Real hertz = std::min(set.contact_hertz, Real(0.25) / h_sub);
    const Real static_hertz = std::min(2 * hertz, kMaxStaticOmegaH / (2 * kPi * h_sub));
    const Softness soft = soft_coefficients(hertz, set.contact_damping_ratio, h_sub);
    const Softness static_soft = soft_coefficients(static_hertz, set.contact_damping_ratio, h_sub);
    colour(sys);
    plan_blocks(sys);
    pad_ = std::int32_t(bodies_.size() - 1);
    // Whether any batch bounces, from the workers' batches (an OR: the same on any worker count).
    for (BatchInputs& in : inputs_) in.any_restitution = false;
    auto note_bounces = [&] {
        any_restitution_ = false;
        for (const BatchInputs& in : inputs_) any_restitution_ = any_restitution_ || in.any_restitution;
    };
    if (blocked_) {
        contacts_.resize(batch_lanes_.size());
        region_->for_each(int(batch_lanes_.size()), kBatchesPerBlock, [&](int begin, int end, int worker) {
            for (int i = begin; i < end; ++i)
                fill_batch(contacts_[std::size_t(i)], batch_manifolds_.data() + batch_first_[std::size_t(i)],
                           int(batch_lanes_[std::size_t(i)]), sys, soft, static_soft, inputs_[worker]);
        });
        note_bounces();
        return;
    }
    std::size_t batches = by_colour_[ConstraintColouring::kOverflow].size();
    for (int c = 0; c < ConstraintColouring::kColours; ++c)
        batches += (by_colour_[c].size() + kWideLanes - 1) / kWideLanes;
    contacts_.resize(batches);
    std::uint32_t next = 0;
    for (int col = 0; col < ConstraintColouring::kColours; ++col) {
        colour_start_[col] = next;
        next += std::uint32_t((by_colour_[col].size() + kWideLanes - 1) / kWideLanes);
    }
    colour_start_[ConstraintColouring::kOverflow] = next;
    colour_start_[ConstraintColouring::kOverflow + 1] = std::uint32_t(batches);
    order_batches_by_worker();
    // Each batch is filled from its colour's list on its own (batches write only themselves), in
    // worker_order_: each worker fills the batches it will solve.
    region_->for_each(int(batches), kBatchesPerBlock, [&](int begin, int end, int worker) {
        for (int k = begin; k < end; ++k) {
            const int i = int(worker_order_[std::size_t(k)]);
            int col = 0;
            while (std::uint32_t(i) >= colour_start_[col + 1]) ++col;
            const auto& list = by_colour_[col];
            if (col == ConstraintColouring::kOverflow) {
                // Overflow: one manifold per batch, so lanes never share a moving body.
                fill_batch(contacts_[i], &list[i - colour_start_[col]], 1, sys, soft, static_soft, inputs_[worker]);
            } else {
                const std::size_t first = std::size_t(i - colour_start_[col]) * kWideLanes;
                fill_batch(contacts_[i], list.data() + first, int(std::min<std::size_t>(kWideLanes, list.size() - first)),
                           sys, soft, static_soft, inputs_[worker]);
            }
        }
    });
    note_bounces();
}

template <class F>
void SoftStepSolver::per_colour(F&& f) {
    if (blocked_) {
        // One block per task, its colours in order: blocks share no moving body.
        region_->for_each(block_count(), 1, [&](int begin, int end, int worker) {
            for (int b = begin; b < end; ++b)
                block_colours(b, [&](WideContact* c, std::size_t n) { f(c, n, &scratch_[worker].body); });
        });
        return;
    }
    for (int col = 0; col < ConstraintColouring::kColours; ++col) {
        const int first = int(colour_start_[col]), count = int(colour_start_[col + 1]) - first;
        region_->for_each(count, kBatchesPerBlock, [&](int begin, int end, int worker) {
            f(contacts_.data() + first + begin, std::size_t(end - begin), &scratch_[worker].body);
        });
    }
    const std::uint32_t first = colour_start_[ConstraintColouring::kOverflow];
    if (contacts_.size() > first) f(contacts_.data() + first, contacts_.size() - first, &scratch_[0].body);
}

void SoftStepSolver::order_batches_by_worker() {
    const int workers = region_->workers();
    worker_order_.clear();
    for (int w = 0; w < workers; ++w)
        for (int col = 0; col <= ConstraintColouring::kOverflow; ++col) {
            const std::uint32_t first = colour_start_[col], count = colour_start_[col + 1] - first;
            const std::uint32_t begin = first + std::uint32_t(std::uint64_t(count) * std::uint64_t(w) / std::uint64_t(workers));
            const std::uint32_t end = first + std::uint32_t(std::uint64_t(count) * std::uint64_t(w + 1) / std::uint64_t(workers));
            for (std::uint32_t i = begin; i < end; ++i) worker_order_.push_back(i);
        }
}

void SoftStepSolver::store_batch(const WideContact& c, std::vector<ContactManifold>& dst) {
    for (int l = 0; l < kWideLanes; ++l) {
        if (c.manifold[l] == kNoManifold) continue;
        Manifold& m = dst[c.manifold[l]].manifold;
        for (int k = 0; k < c.count[l]; ++k) {
            m.points[k].normal_impulse = c.p[k].normal_impulse.lane(l);
            m.points[k].total_normal_impulse = c.p[k].total_normal_impulse.lane(l);
            m.points[k].tangent_impulse[0] = c.p[k].tangent_impulse[0].lane(l);
            m.points[k].tangent_impulse[1] = c.p[k].tangent_impulse[1].lane(l);
        }
    }
}

void SoftStepSolver::store_results(RigidSystem& sys) {
    // Two loops with nothing in common, in one stage (one wait for the workers, not two): each moving
    // body's state from its row, and each batch's impulses into its manifolds. Items come in worker
    // slices, a slice being a worker's share of the bodies and then of the batches in worker_order_
    // (when solved colour by colour), so each worker mostly stores what it solved: the stage's ranges
    // round to whole blocks, and this region may have another worker count than the solve's.
    RigidSystem::State& st = sys.state();
    std::vector<ContactManifold>& dst = sys.mutable_contacts();
    const bool ordered = !blocked_ && worker_order_.size() == contacts_.size();
    const std::size_t bodies = moving_only_ ? moving_.size() : st.v.size(), batches = contacts_.size();
    const std::size_t slices = std::size_t(region_->workers());
    auto share = [slices](std::size_t n, std::size_t w) { return n * w / slices; };
    region_->for_each(int(bodies + batches), kBodiesPerBlock, [&](int begin, int end, int) {
        std::size_t w = 0;  // the slice of item k
        for (std::size_t k = std::size_t(begin); k < std::size_t(end); ++k) {
            while (w + 1 < slices && share(bodies, w + 1) + share(batches, w + 1) <= k) ++w;
            const std::size_t o = k - share(bodies, w) - share(batches, w);
            const std::size_t in_slice = share(bodies, w + 1) - share(bodies, w);
            if (o < in_slice) {
                const std::size_t i = share(bodies, w) + o;
                const std::uint32_t s = moving_only_ ? moving_[i] : std::uint32_t(i);
                if (st.inv_mass[s] != 0) state_from_row(st, s, bodies_[s]);
            } else {
                const std::size_t i = share(batches, w) + (o - in_slice);
                store_batch(contacts_[ordered ? std::size_t(worker_order_[i]) : i], dst);
            }
        }
    });
    moving_only_ = false;
}

template <class F>
void SoftStepSolver::for_each_body(std::size_t count, F&& f) const {
    // Each call of f touches its own body alone, so the region's workers share the loop.
    if (moving_only_) {
        region_->for_each(int(moving_.size()), kBodiesPerBlock, [&](int begin, int end, int) {
            for (int i = begin; i < end; ++i) f(std::size_t(moving_[std::size_t(i)]));
        });
    } else {
        region_->for_each(int(count), kBodiesPerBlock, [&](int begin, int end, int) {
            for (int s = begin; s < end; ++s) f(std::size_t(s));
        });
    }
}

void SoftStepSolver::bodies_to_state(RigidSystem::State& st) const {
    for_each_body(st.v.size(), [&](std::size_t s) {
        state_from_row(st, std::uint32_t(s), bodies_[s]);
    });
}

void SoftStepSolver::plan_blocks(const RigidSystem& sys) {
    // Worth it only when the batches outgrow the cache; outside rows (joints, coupling) would tie the
    // blocks together through bodies the contacts do not see.
    bool wanted = sys.settings().solve_in_blocks && sys.contacts().size() >= 2 * kBlockManifolds;
    for (const ConstraintRows* rows : sys.row_sources()) wanted = wanted && !rows->active();
    if (!wanted) {
        blocked_ = false;
        plan_kept_ = false;
        return;
    }
    if (plan_kept_ && colours_kept_ && moving_ == planned_moving_) return;  // last step's blocks hold
    plan_kept_ = false;
    make_plan(sys);
    planned_moving_ = moving_;
    plan_kept_ = true;
}

void SoftStepSolver::make_plan(const RigidSystem& sys) {
    blocked_ = false;
    const auto& src = sys.contacts();
    const RigidSystem::State& st = sys.state();
    const std::size_t nb = st.x.size();
    // Islands of this step's solve: bodies it moves, joined by the manifolds between two of them (a
    // static or sleeping body is only read, so it joins nothing). Union by smallest slot.
    in_solve_.assign(nb, 0);
    island_of_.resize(nb);
    for (std::uint32_t s : moving_) {
        in_solve_[s] = 1;
        island_of_[s] = s;
    }
    auto root = [&](std::uint32_t x) {
        while (island_of_[x] != x) x = island_of_[x] = island_of_[island_of_[x]];
        return x;
    };
    for (const auto& list : by_colour_)
        for (std::uint32_t ci : list) {
            const std::uint32_t a = src[ci].body_a, b = src[ci].body_b;
            if (!in_solve_[a] || !in_solve_[b]) continue;
            const std::uint32_t ra = root(a), rb = root(b);
            if (ra < rb) island_of_[rb] = ra;
            else if (rb < ra) island_of_[ra] = rb;
        }
    // Components numbered by smallest slot: moving_ is in slot order and a root is its island's smallest
    // slot, so each root is numbered before the rest of its island.
    for (std::uint32_t s : moving_) island_of_[s] = root(s);
    component_.resize(nb);
    std::uint32_t components = 0;
    for (std::uint32_t s : moving_) component_[s] = island_of_[s] == s ? components++ : component_[island_of_[s]];
    // Blocks: consecutive components up to kBlockManifolds manifolds each.
    std::vector<std::uint32_t>& per_component = count_scratch_;
    per_component.assign(components, 0);
    auto component_of = [&](std::uint32_t ci) {
        const std::uint32_t a = src[ci].body_a;
        return component_[in_solve_[a] ? a : src[ci].body_b];
    };
    for (const auto& list : by_colour_)
        for (std::uint32_t ci : list) ++per_component[component_of(ci)];
    std::uint32_t blocks = 0;
    std::size_t in_block = 0;
    for (std::uint32_t c = 0; c < components; ++c) {
        if (in_block == 0) ++blocks;
        in_block += per_component[c];
        per_component[c] = blocks - 1;  // now the component's block
        if (in_block >= kBlockManifolds) in_block = 0;
    }
    if (blocks < 2) return;
    blocked_ = true;
    // Bodies by block, in slot order within each.
    block_body_start_.assign(blocks + 1, 0);
    for (std::uint32_t s : moving_) ++block_body_start_[per_component[component_[s]] + 1];
    for (std::uint32_t k = 0; k < blocks; ++k) block_body_start_[k + 1] += block_body_start_[k];
    block_bodies_.resize(moving_.size());
    std::vector<std::uint32_t>& next = next_scratch_;
    next.assign(block_body_start_.begin(), block_body_start_.end() - 1);
    for (std::uint32_t s : moving_) block_bodies_[next[per_component[component_[s]]]++] = s;
    // Manifolds by block, then colour, in contact order within each; then the batches: up to
    // kWideLanes manifolds of one colour, one manifold for the overflow.
    constexpr int kLists = ConstraintColouring::kOverflow + 1;
    std::vector<std::uint32_t>& first = first_scratch_;
    first.assign(std::size_t(blocks) * kLists + 1, 0);
    for (int c = 0; c < kLists; ++c)
        for (std::uint32_t ci : by_colour_[c]) ++first[std::size_t(per_component[component_of(ci)]) * kLists + std::size_t(c) + 1];
    for (std::size_t k = 1; k < first.size(); ++k) first[k] += first[k - 1];
    batch_manifolds_.resize(first.back());
    next.assign(first.begin(), first.end() - 1);
    for (int c = 0; c < kLists; ++c)
        for (std::uint32_t ci : by_colour_[c])
            batch_manifolds_[next[std::size_t(per_component[component_of(ci)]) * kLists + std::size_t(c)]++] = ci;
    block_colour_start_.assign(std::size_t(blocks) * kColourStarts, 0);
    batch_first_.clear();
    batch_lanes_.clear();
    for (std::uint32_t k = 0; k < blocks; ++k) {
        std::uint32_t* cs = block_colour_start_.data() + std::size_t(k) * kColourStarts;
        for (int c = 0; c < kLists; ++c) {
            cs[c] = std::uint32_t(batch_lanes_.size());
            const std::uint32_t begin = first[std::size_t(k) * kLists + std::size_t(c)];
            const std::uint32_t end = first[std::size_t(k) * kLists + std::size_t(c) + 1];
            const std::uint32_t lanes = c == ConstraintColouring::kOverflow ? 1 : std::uint32_t(kWideLanes);
            for (std::uint32_t m = begin; m < end; m += lanes) {
                batch_first_.push_back(m);
                batch_lanes_.push_back(std::uint8_t(std::min(lanes, end - m)));
            }
        }
        cs[kColourStarts - 1] = std::uint32_t(batch_lanes_.size());
    }
}

void SoftStepSolver::substeps_of_block(RigidSystem& sys, int b, int worker, int n_sub, Real inv_h_sub) {
    RigidSystem::State& st = sys.state();
    const RigidSettings& set = sys.settings();
    const std::uint32_t* bodies = block_bodies_.data() + block_body_start_[std::size_t(b)];
    const std::size_t count = block_body_start_[std::size_t(b) + 1] - block_body_start_[std::size_t(b)];
    WideBody* scratch = &scratch_[std::size_t(worker)].body;
    // The sub-step loop of solve_in_region() and integrate_and_relax() for this block's bodies and
    // batches alone (no outside rows: plan_blocks found none active).
    for (int i = 0; i < n_sub; ++i) {
        for (std::size_t k = 0; k < count; ++k) {
            if (i > 0) state_from_row(st, bodies[k], bodies_[bodies[k]]);
        }
        sys.integrate_velocities_of(bodies, count, h_sub_);
        for (std::size_t k = 0; k < count; ++k) row_from_state(bodies_[bodies[k]], st, bodies[k]);
        if (set.warm_starting) {
            block_colours(b, [&](WideContact* c, std::size_t n) { kernels_.warm_start(c, n, bodies_.data(), scratch); });
        } else if (i > 0) {
            block_colours(b, [&](WideContact* c, std::size_t n) {
                for (std::size_t q = 0; q < n; ++q)
                    for (int k = 0; k < c[q].max_count; ++k)
                        for (FloatW* f : {&c[q].p[k].normal_impulse, &c[q].p[k].tangent_impulse[0], &c[q].p[k].tangent_impulse[1]})
                            *f = FloatW{};
            });
        }
        block_colours(b, [&](WideContact* c, std::size_t n) {
            kernels_.solve(c, n, bodies_.data(), scratch, inv_h_sub, set.contact_push_velocity, true);
        });
        if (i + 1 == n_sub) break;  // the last sub-step's positions wait for IntegratePositions
        for (std::size_t k = 0; k < count; ++k) integrate_body_position(sys, st, bodies[k]);
        block_colours(b, [&](WideContact* c, std::size_t n) {
            kernels_.solve(c, n, bodies_.data(), scratch, Real(1) / h_sub_, set.contact_push_velocity, false);
        });
    }
    for (std::size_t k = 0; k < count; ++k) {
        state_from_row(st, bodies[k], bodies_[bodies[k]]);
    }
}

void SoftStepSolver::solve_velocities(RigidSystem& sys, Real h) {
    in_region(sys, [&] { solve_in_region(sys, h); });
}

template <class F>
void SoftStepSolver::in_region(RigidSystem& sys, F&& f) {
    struct Reset {
        ParallelRegion*& region;
        ~Reset() { region = nullptr; }
    } reset{region_};
    // Helpers only for enough work: waking them costs more than a small scene's whole solve (a cloth
    // over a static ground ran 0.83x as fast on two workers as on one).
    const bool enough = sys.contacts().size() >= kParallelManifolds || sys.joints().active_count() >= kParallelJoints;
    const TaskSystem* tasks = enough ? sys.task_system() : nullptr;
    sys.region().run(tasks, [&] {
        region_ = &sys.region();
        const std::size_t workers = std::size_t(region_->workers());
        if (inputs_.size() < workers) inputs_.resize(workers);
        if (scratch_.size() < workers) scratch_.resize(workers);
        f();
    });
}

void SoftStepSolver::solve_in_region(RigidSystem& sys, Real h) {
    const RigidSettings& set = sys.settings();
    const int n_sub = set.effective_substeps();
    const Real h_sub = h / Real(n_sub), inv_h_sub = Real(n_sub) / h;
    RigidSystem::State& st = sys.state();
    const std::size_t nb = st.x.size();
    // Zero motion since the step began, the padding body at rest: only the rows the last step's moving
    // bodies wrote are not zero already (50,000 sleeping boxes spent 0.1 ms a step clearing them all).
    for (const std::vector<std::uint32_t>* written : {&moving_, &moved_in_solve_})
        for (const std::uint32_t s : *written)
            if (s < bodies_.size()) bodies_[s] = WideBody{};
    moved_in_solve_.clear();
    if (bodies_.size() > nb) bodies_[nb] = WideBody{};
    bodies_.resize(nb + 1);
    // The sub-steps below touch only the bodies that move.
    find_moving(st);
    kernels_ = kernels_for(active_simd_kernel());
    // Joints and other outside rows are soft too (Box2D v3: twice the contact stiffness, damping ratio 2);
    // they work on the solver's WideBody rows through a view, as the contacts do. Prepared first: the
    // contacts' preparation asks them whether they are active (plan_blocks).
    const RowStep step{h_sub, n_sub, set.warm_starting, RowSoftness{true, false, set.baumgarte, 2 * set.contact_hertz, 2}};
    for (ConstraintRows* rows : sys.row_sources()) rows->prepare(sys, step);
    prepare(sys, h_sub);
    const BodyVelocities vel = body_view();
    h_sub_ = h_sub;
    if (blocked_) {
        region_->for_each(block_count(), 1, [&](int begin, int end, int worker) {
            for (int b = begin; b < end; ++b) substeps_of_block(sys, b, worker, n_sub, inv_h_sub);
        });
        moving_only_ = false;
        pending_ = true;
        return;
    }
    for (int i = 0; i < n_sub; ++i) {
        // Velocities of the moving bodies (the rest have none to integrate), through the system's state
        // and back into the solver's rows: one stage, each body on its own.
        region_->for_each(int(moving_.size()), kBodiesPerBlock, [&](int begin, int end, int) {
            for (int k = begin; k < end; ++k) {
                const std::uint32_t s = moving_[std::size_t(k)];
                if (i > 0) state_from_row(st, s, bodies_[s]);
                sys.integrate_velocities_of(&s, 1, h_sub);
                row_from_state(bodies_[s], st, s);
            }
        });
        if (set.warm_starting)
            for (ConstraintRows* rows : sys.row_sources()) rows->warm_start(sys, vel);
        for (ConstraintRows* rows : sys.row_sources()) rows->solve(sys, vel, true);
        // Without warm starting each sub-step starts from zero impulses: keeping the last sub-step's
        // accumulated impulse without applying it would let the clamp pull and inflate the friction bound.
        if (set.warm_starting) warm_start();
        else if (i > 0) clear_impulses();
        solve(inv_h_sub, set.contact_push_velocity, true);
        if (i + 1 == n_sub) break;  // the last sub-step's positions wait for IntegratePositions
        integrate_and_relax(sys);
    }
    // Hand the velocities to the pipeline: a coupling hook between SolveVelocities and
    // IntegratePositions (seed 001 Figure 9) still changes the last sub-step's positions.
    bodies_to_state(st);
    moving_only_ = false;
    pending_ = true;
}

void SoftStepSolver::integrate_and_relax(RigidSystem& sys, bool load) {
    RigidSystem::State& st = sys.state();
    const std::size_t nb = st.x.size();
    // Positions (kinematic bodies move with their velocity; static and sleeping ones have none).
    for_each_body(nb, [&](std::size_t s) {
        if (load) row_from_state(bodies_[s], st, std::uint32_t(s));
        integrate_body_position(sys, st, std::uint32_t(s));
    });
    // The outside sources move their own bodies over the same sub-step, then relax with the contacts.
    const BodyVelocities vel = body_view();
    for (ConstraintRows* rows : sys.row_sources()) rows->positions_advanced(sys, vel, h_sub_);
    for (ConstraintRows* rows : sys.row_sources()) rows->solve(sys, vel, false);
    solve(Real(1) / h_sub_, sys.settings().contact_push_velocity, false);  // relax: remove the bias velocity
}

void SoftStepSolver::finish_step(RigidSystem& sys, Real) {
    if (!pending_) return;
    pending_ = false;
    in_region(sys, [&] { finish_in_region(sys); });
}

void SoftStepSolver::finish_in_region(RigidSystem& sys) {
    RigidSystem::State& st = sys.state();
    // Coupling layers may have changed velocities since the solve, of any body: the moving ones are
    // found again, as the solve found them (the solve's are kept: their rows are cleared next step).
    std::swap(moved_in_solve_, moving_);
    find_moving(st);
    // A body the solve moved that no longer moves (a hook stopped a kinematic body): its row takes the
    // state's velocity too, since the relax reads it for contacts against the body.
    for (const std::uint32_t s : moved_in_solve_)
        if (st.inv_mass[s] == 0 && st.v[s] == Vec3::Zero() && st.w[s] == Vec3::Zero())
            for (int i = 0; i < 3; ++i) bodies_[s].v[i] = bodies_[s].w[i] = 0;
    integrate_and_relax(sys, true);
    // A restitution pass is a stage per colour: none when no contact of the step bounces.
    if (any_restitution_) restitution(sys.settings().restitution_threshold);
    store_results(sys);
}

void SoftStepSolver::find_moving(const RigidSystem::State& st) {
    // Nothing in the step moves a static, sleeping or resting kinematic body. 50,176 boxes asleep on the
    // ground cost 9.3-10.5 ms a step when each of the sub-steps' copies and integrations ran over every slot.
    const std::size_t nb = st.x.size();
    moving_.clear();
    for (std::uint32_t s = 0; s < nb; ++s)
        if (st.inv_mass[s] != 0 || st.v[s] != Vec3::Zero() || st.w[s] != Vec3::Zero()) moving_.push_back(s);
    moving_only_ = true;
}

}  // namespace

const char* simd_kernel_name(SimdKernel k) {
    switch (k) {
        case SimdKernel::Auto: return "auto";
        case SimdKernel::Portable: return "portable";
        case SimdKernel::Sse2: return "sse2";
        case SimdKernel::Avx: return "avx";
    }
    return "unknown";
}

bool simd_kernel_available(SimdKernel k) {
    switch (k) {
        case SimdKernel::Auto:
        case SimdKernel::Portable: return true;
        case SimdKernel::Sse2: return SINEW_WIDE_X86 != 0;
        case SimdKernel::Avx: return cpu_has_avx();
    }
    return false;
}

bool set_simd_kernel(SimdKernel k) {
    if (!simd_kernel_available(k)) return false;
    g_kernel.store(k);
    return true;
}

SimdKernel active_simd_kernel() {
    const SimdKernel k = g_kernel.load();
    return k == SimdKernel::Auto ? widest_kernel() : k;
}

std::unique_ptr<RigidSolver> make_soft_step_solver() { return std::make_unique<SoftStepSolver>(); }

}  // namespace sinew
