// Exact solve of the joints' point blocks (rigid/joint_point_solve.hpp).
#include "rigid/joint_point_solve.hpp"

#include <algorithm>
#include <limits>
#include <utility>

#include <Eigen/OrderingMethods>
#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>

namespace sinew::joint_detail {

namespace {

// Joints on one movable body past which the exact solve is left out (see prepare()).
constexpr std::uint32_t kMaxJointsPerBody = 32;

using Mat3d = Eigen::Matrix3d;
using Vec3d = Eigen::Vector3d;

Mat3d skew_d(const Vec3d& r) {
    Mat3d s;
    s << 0, -r.z(), r.y(), r.z(), 0, -r.x(), -r.y(), r.x(), 0;
    return s;
}

// One joint's end on a movable body: the joint's place in the solve and its side (-1: A, +1: B).
struct End {
    std::uint32_t joint;
    double sign;
};

// A 3x3 block of the matrix contributed by one body to the pair (joint of end i, joint of end j): the
// nine places of its values in the compressed storage, row-major.
struct Term {
    std::uint32_t body_end_i, body_end_j;  // indices into ends
    std::uint32_t body;
    int value[9];
};

// SimplicialLDLT's factorisation of a matrix already ordered: its factorize() builds an empty matrix (an
// allocation) on each call even when it reads its input where it is.
class OrderedLdlt : public Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Upper, Eigen::NaturalOrdering<int>> {
public:
    void factorize_ordered(const Eigen::SparseMatrix<double>& ap) { this->template factorize_preordered<true>(ap); }
};

// Runs f when it goes out of scope, a throw included: shared scratch is put back to all-zero however a
// prepare() ends (the groups of a joint set share it).
template <class F>
struct OnExit {
    F f;
    ~OnExit() { f(); }
};
template <class F>
OnExit<F> on_exit(F f) {
    return OnExit<F>{std::move(f)};
}

}  // namespace

struct JointPointSolve::Impl {
    std::vector<std::uint32_t> slots;        // joint slots, in matrix order
    std::vector<std::uint32_t> bodies;       // movable bodies with at least one end
    std::vector<std::uint32_t> body_first;   // per body in `bodies`: its first end (CSR), size bodies + 1
    std::vector<End> ends;
    std::vector<Term> terms;
    std::vector<int> diagonal;               // per joint: the nine value places of its own block
    std::vector<std::uint32_t> count;        // scratch of prepare(): ends per body in `bodies`
    std::vector<Eigen::Triplet<double>> pattern;  // scratch of prepare(): the matrix's entries
    // The matrix in joint order (both triangles), and its lower triangle ordered once per pattern as
    // Eigen's SimplicialLDLT<Lower, AMD> orders it for each factorisation (P A Pᵀ, upper triangle,
    // entries in the same places): `ap` takes its values through `ap_source` (a place in `a` per
    // entry) and is factorised where it is. The factor is the one Eigen's compute() gave, bit for bit,
    // without its ordering (AMD) once per step and its copy of the matrix once per pass.
    Eigen::SparseMatrix<double> a, ap;
    std::vector<int> ap_source;
    Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> perm, perm_inv;
    OrderedLdlt ldlt;
    bool factorable = false;
    // The pattern's key: per joint in the solve, its slot and its movable bodies (~0u: immovable end).
    // prepare() keeps the pattern, its ordering and its analysis while the key stands.
    std::vector<std::uint32_t> key, last_key;
    Eigen::VectorXd rhs, dl, ordered;
    std::vector<Vec3d> ra, rb;               // per joint, this pass's arms
    std::vector<Mat3d> own;                  // per joint, its block K_k
    std::vector<double> inv_mass;            // per body in `bodies`
    std::vector<Mat3d> inv_inertia;
};

JointPointSolve::JointPointSolve() : m_(std::make_unique<Impl>()) {}
JointPointSolve::~JointPointSolve() = default;

const std::vector<std::uint32_t>& JointPointSolve::slots() const { return m_->slots; }

void JointPointSolve::prepare(const std::vector<JointData>& joints, const std::vector<JointRows>& rows,
                              const std::uint32_t* active, std::size_t count, std::vector<std::uint32_t>& body_scratch) {
    Impl& m = *m_;
    m.slots.clear();
    // A body holding many joints couples them all: its block of the matrix is dense (a hub of 500 joints
    // would factor a 1,500-row dense matrix every pass). The joints on a body past kMaxJointsPerBody are
    // left to the sweeps alone; the rest are solved.
    // Only the movable bodies' entries of the scratch are touched: the groups of a joint set prepare
    // at once on different workers, and share no movable body.
    std::vector<std::uint32_t>& joints_on = body_scratch;  // joints per movable body, zero again on return
    const std::uint32_t* const end = active + count;
    {
        const auto zero_again = on_exit([&] {
            for (const std::uint32_t* s = active; s != end; ++s) {
                if (rows[*s].ma != 0) joints_on[rows[*s].a] = 0;
                if (rows[*s].mb != 0) joints_on[rows[*s].b] = 0;
            }
        });
        for (const std::uint32_t* s = active; s != end; ++s) {
            if (!has_point_block(joints[*s].def.type)) continue;
            const JointRows& r = rows[*s];
            if (r.ma != 0) ++joints_on[r.a];
            if (r.mb != 0) ++joints_on[r.b];
        }
        for (const std::uint32_t* s = active; s != end; ++s) {
            if (!has_point_block(joints[*s].def.type)) continue;
            const JointRows& r = rows[*s];
            if ((r.ma != 0 && joints_on[r.a] > kMaxJointsPerBody) || (r.mb != 0 && joints_on[r.b] > kMaxJointsPerBody))
                continue;
            m.slots.push_back(*s);
        }
    }
    m.key.clear();
    for (std::uint32_t s : m.slots) {
        const JointRows& r = rows[s];
        m.key.insert(m.key.end(), {s, r.ma != 0 ? r.a : ~0u, r.mb != 0 ? r.b : ~0u});
    }
    if (m.slots.empty() || m.key != m.last_key) {
        m.last_key.clear();  // a build that throws leaves no key to match
        build_pattern(m, rows, body_scratch);
    }
    m.last_key.swap(m.key);
    if (m.slots.empty()) return;
    for (std::size_t p = 0; p < m.bodies.size(); ++p) {
        // Any end's rows carry the body's inverse mass and world inverse inertia for this step.
        const End& e = m.ends[m.body_first[p]];
        const JointRows& r = rows[m.slots[e.joint]];
        const bool is_a = e.sign < 0;
        m.inv_mass[p] = double(is_a ? r.ma : r.mb);
        m.inv_inertia[p] = (is_a ? r.ia : r.ib).cast<double>();
    }
}

void JointPointSolve::build_pattern(Impl& m, const std::vector<JointRows>& rows, std::vector<std::uint32_t>& body_scratch) {
    m.bodies.clear();
    m.terms.clear();
    m.factorable = false;
    if (m.slots.empty()) return;
    const std::size_t n = m.slots.size();
    // Movable bodies (in the order of their first end) and their ends, grouped by body (counting sort).
    // place[b] is 1 + b's index in `bodies`, 0 for none, and 0 again at the end.
    std::vector<std::uint32_t>& place_of = body_scratch;
    const auto zero_again = on_exit([&] {
        for (std::uint32_t b : m.bodies) place_of[b] = 0;
    });
    std::vector<std::uint32_t>& count = m.count;  // reused from step to step
    count.clear();
    for (std::uint32_t k = 0; k < n; ++k) {
        const JointRows& r = rows[m.slots[k]];
        for (int side = 0; side < 2; ++side) {
            const std::uint32_t b = side ? r.b : r.a;
            if ((side ? r.mb : r.ma) == 0) continue;
            if (place_of[b] == 0) {
                m.bodies.push_back(b);
                place_of[b] = std::uint32_t(m.bodies.size());
                count.push_back(0);
            }
            ++count[place_of[b] - 1];
        }
    }
    m.body_first.assign(m.bodies.size() + 1, 0);
    for (std::size_t i = 0; i < m.bodies.size(); ++i) m.body_first[i + 1] = m.body_first[i] + count[i];
    m.ends.resize(m.body_first.back());
    std::fill(count.begin(), count.end(), 0u);
    for (std::uint32_t k = 0; k < n; ++k) {
        const JointRows& r = rows[m.slots[k]];
        for (int side = 0; side < 2; ++side) {
            const std::uint32_t b = side ? r.b : r.a;
            if ((side ? r.mb : r.ma) == 0) continue;
            const std::uint32_t place = place_of[b] - 1;
            m.ends[m.body_first[place] + count[place]++] = {k, side ? 1.0 : -1.0};
        }
    }
    // The pattern: every pair of joints sharing a movable body, their 3x3 blocks, and each joint's own.
    std::vector<Eigen::Triplet<double>>& pattern = m.pattern;
    pattern.clear();
    const auto add_block = [&](std::uint32_t k, std::uint32_t l) {
        for (int u = 0; u < 3; ++u)
            for (int v = 0; v < 3; ++v) pattern.emplace_back(int(3 * k) + u, int(3 * l) + v, 0.0);
    };
    for (std::uint32_t k = 0; k < n; ++k) add_block(k, k);
    for (std::size_t p = 0; p < m.bodies.size(); ++p)
        for (std::uint32_t i = m.body_first[p]; i < m.body_first[p + 1]; ++i)
            for (std::uint32_t j = m.body_first[p]; j < m.body_first[p + 1]; ++j)
                if (m.ends[i].joint != m.ends[j].joint) add_block(m.ends[i].joint, m.ends[j].joint);
    const auto dim = Eigen::Index(3 * n);
    m.a.resize(dim, dim);
    m.a.setFromTriplets(pattern.begin(), pattern.end());  // duplicates summed: zeros stay zeros
    m.a.makeCompressed();
    // Where each block's values live.
    const auto place = [&](std::uint32_t k, std::uint32_t l, int* out) {
        for (int u = 0; u < 3; ++u)
            for (int v = 0; v < 3; ++v) {
                const Eigen::Index row = Eigen::Index(3 * k) + u, col = Eigen::Index(3 * l) + v;
                const int* inner = m.a.innerIndexPtr();
                const int begin = m.a.outerIndexPtr()[col], end = m.a.outerIndexPtr()[col + 1];
                out[3 * u + v] = int(std::lower_bound(inner + begin, inner + end, int(row)) - inner);
            }
    };
    m.diagonal.resize(9 * n);
    for (std::uint32_t k = 0; k < n; ++k) place(k, k, &m.diagonal[9 * k]);
    for (std::size_t p = 0; p < m.bodies.size(); ++p)
        for (std::uint32_t i = m.body_first[p]; i < m.body_first[p + 1]; ++i)
            for (std::uint32_t j = m.body_first[p]; j < m.body_first[p + 1]; ++j) {
                Term t;
                t.body_end_i = i;
                t.body_end_j = j;
                t.body = std::uint32_t(p);
                place(m.ends[i].joint, m.ends[j].joint, t.value);
                m.terms.push_back(t);
            }
    // The ordering, as SimplicialLDLT<Lower, AMDOrdering> finds it (SimplicialCholeskyBase::ordering),
    // and the ordered upper triangle built by the same assignment from a copy of `a` whose values are
    // their own places, so each entry of `ap` names the entry of `a` it copies.
    {
        Eigen::SparseMatrix<double> full;
        full = m.a.selfadjointView<Eigen::Lower>();
        Eigen::AMDOrdering<int> amd;
        amd(full, m.perm_inv);
    }
    m.perm = m.perm_inv.inverse();
    Eigen::SparseMatrix<double> places = m.a;
    for (Eigen::Index q = 0; q < places.nonZeros(); ++q) places.valuePtr()[q] = double(q);
    m.ap.resize(dim, dim);
    m.ap.selfadjointView<Eigen::Upper>() = places.selfadjointView<Eigen::Lower>().twistedBy(m.perm);
    m.ap.makeCompressed();
    m.ap_source.resize(std::size_t(m.ap.nonZeros()));
    for (std::size_t q = 0; q < m.ap_source.size(); ++q) m.ap_source[q] = int(m.ap.valuePtr()[q]);
    m.ldlt.analyzePattern(m.ap);
    m.factorable = m.ldlt.info() == Eigen::Success;
    m.rhs.resize(dim);
    m.dl.resize(dim);
    m.ordered.resize(dim);
    m.ra.resize(n);
    m.rb.resize(n);
    m.own.resize(n);
    m.inv_mass.resize(m.bodies.size());
    m.inv_inertia.resize(m.bodies.size());
}

void JointPointSolve::solve(std::vector<JointData>& joints, const std::vector<JointRows>& rows,
                            const RigidSystem::State& st, RowPass& pass, const Softness& bias) {
    Impl& m = *m_;
    const std::size_t n = m.slots.size();
    if (n == 0 || !m.factorable) return;
    // The bodies' world inverse inertia as the rows hold it now (the soft step turns it with each body
    // between its passes: JointSet::positions_advanced), so K and the impulses' effect agree.
    for (std::size_t p = 0; p < m.bodies.size(); ++p) {
        const End& e = m.ends[m.body_first[p]];
        const JointRows& r = rows[m.slots[e.joint]];
        m.inv_inertia[p] = (e.sign < 0 ? r.ia : r.ib).cast<double>();
    }
    // gamma = impulse_scale / mass_scale: the soft rows' compliance relative to their own block.
    const double gamma = bias.mass_scale > 0 ? double(bias.impulse_scale) / double(bias.mass_scale) : 0.0;
    // Arms, errors and relative velocities at the anchors, before any impulse of this solve.
    for (std::uint32_t k = 0; k < n; ++k) {
        const JointData& j = joints[m.slots[k]];
        const JointRows& r = rows[m.slots[k]];
        const PairPose pose(st, j, r);
        const PairVelocity p(pass, r);
        m.ra[k] = pose.ra.cast<double>();
        m.rb[k] = pose.rb.cast<double>();
        const Vec3 cdot = p.vb + p.wb.cross(pose.rb) - p.va - p.wa.cross(pose.ra);
        const Vec3 target = cdot + bias.bias_rate * bias.cap(pose.d);
        m.rhs.segment<3>(Eigen::Index(3 * k)) = -target.cast<double>();
        m.own[k].setZero();
    }
    // J M^-1 J^T, written in place; each joint's own block K_k kept for the compliance.
    double* values = m.a.valuePtr();
    std::fill(values, values + m.a.nonZeros(), 0.0);
    for (const Term& t : m.terms) {
        const End& ei = m.ends[t.body_end_i];
        const End& ej = m.ends[t.body_end_j];
        const Vec3d& arm_i = ei.sign < 0 ? m.ra[ei.joint] : m.rb[ei.joint];
        const Vec3d& arm_j = ej.sign < 0 ? m.ra[ej.joint] : m.rb[ej.joint];
        const Mat3d block = ei.sign * ej.sign *
                            (m.inv_mass[t.body] * Mat3d::Identity() - skew_d(arm_i) * m.inv_inertia[t.body] * skew_d(arm_j));
        for (int u = 0; u < 3; ++u)
            for (int v = 0; v < 3; ++v) values[t.value[3 * u + v]] += block(u, v);
        if (ei.joint == ej.joint) m.own[ei.joint] += block;
    }
    // The compliance, plus a ridge that keeps redundant joints (a door on two hinges has no stiffness
    // along the line through both anchors; two joints at one point; a closed loop) factorable. It is
    // set at Real's resolution: the relative velocity along such a line is rounding noise, which a
    // smaller ridge turned into impulses of kilonewton-seconds that the reaction forces (and breakable
    // joints) saw; a well-posed solve moves by the same relative amount.
    const double ridge = 100 * double(std::numeric_limits<Real>::epsilon());
    for (std::uint32_t k = 0; k < n; ++k) {
        const Mat3d extra = (gamma + ridge) * m.own[k];
        for (int u = 0; u < 3; ++u)
            for (int v = 0; v < 3; ++v) values[m.diagonal[9 * k + 3 * u + v]] += extra(u, v);
        if (gamma > 0) m.rhs.segment<3>(Eigen::Index(3 * k)) -= gamma * m.own[k] * joints[m.slots[k]].impulses.point.cast<double>();
    }
    double* ordered_values = m.ap.valuePtr();
    for (std::size_t q = 0; q < m.ap_source.size(); ++q) ordered_values[q] = values[m.ap_source[q]];
    m.ldlt.factorize_ordered(m.ap);
    if (m.ldlt.info() != Eigen::Success) return;  // singular (cannot be with one movable body per joint)
    // x = Pᵀ (L D Lᵀ)⁻¹ P b, as SimplicialLDLT's solve applies its ordering.
    m.ordered = m.perm * m.rhs;
    m.dl = m.ldlt.solve(m.ordered);
    m.dl = m.perm_inv * m.dl;
    if (!m.dl.allFinite()) return;
    for (std::uint32_t k = 0; k < n; ++k) {
        JointData& j = joints[m.slots[k]];
        const JointRows& r = rows[m.slots[k]];
        const Vec3 impulse = m.dl.segment<3>(Eigen::Index(3 * k)).cast<Real>();
        j.impulses.point += impulse;
        PairVelocity p(pass, r);
        apply_linear(p, r, m.ra[k].cast<Real>(), m.rb[k].cast<Real>(), impulse);
        p.store(pass, r);
    }
}

}  // namespace sinew::joint_detail
