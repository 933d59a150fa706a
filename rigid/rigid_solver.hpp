// Interface between the rigid system and its velocity solvers. One virtual call per step: the solvers'
// inner loops run on plain arrays they prepare themselves.
#pragma once

#include <cmath>

#include "rigid/rigid_system.hpp"

namespace sinew {

class RigidSolver {
public:
    virtual ~RigidSolver() = default;
    /// Solves contacts (and later joints) for one step of h: writes new velocities into the system's
    /// state, accumulated impulses back into its contacts, and pseudo-velocities for position correction.
    virtual void solve_velocities(RigidSystem& sys, Real h) = 0;
    /// The solver's part of IntegratePositions, after the system integrated positions (if the solver
    /// does not integrate itself) and told the outside rows: split impulses' pseudo-velocity correction,
    /// Guendelman's penetration projection, or the soft step's last sub-step (positions, relax pass,
    /// restitution) and its impulses stored back into the manifolds.
    virtual void finish_step(RigidSystem& sys, Real h) = 0;
    /// Runs at the start of IntegrateVelocities, before forces (Guendelman's collision passes).
    virtual void before_integrate_velocities(RigidSystem&, Real) {}
    /// Whether DetectCollisions should place bodies at their candidate poses x + h v (Guendelman) rather
    /// than their current poses (Catto).
    virtual bool detects_at_candidate_poses() const { return false; }
    /// Whether the solver integrates velocities and positions itself inside SolveVelocities (sub-stepping
    /// solvers); the system then skips its own integration in the other stages.
    virtual bool integrates_itself() const { return false; }
    /// After solve_velocities: the time IntegratePositions will still integrate with the current
    /// velocities (the whole step, or a sub-stepping solver's last sub-step).
    virtual Real unintegrated_time_after_solve(Real h) const { return h; }
    /// Blocks of independent islands the last solve worked through one at a time (the soft step on a
    /// world of many islands; 0: passes over the whole world).
    virtual int last_solve_blocks() const { return 0; }
};

/// Writes each prepared constraint's accumulated impulses back into its manifold's points, where the
/// contact cache carries them to the next step (warm starting) and events and coupling read them.
/// `Constraint` has `manifold`, `count` and `p[k].{normal_impulse, tangent_impulse[2]}`.
template <class Constraint>
void store_contact_impulses(const std::vector<Constraint>& constraints, std::vector<ContactManifold>& contacts) {
    for (const Constraint& c : constraints) {
        Manifold& m = contacts[c.manifold].manifold;
        for (int k = 0; k < c.count; ++k) {
            m.points[k].normal_impulse = c.p[k].normal_impulse;
            m.points[k].total_normal_impulse = c.p[k].normal_impulse;
            m.points[k].tangent_impulse[0] = c.p[k].tangent_impulse[0];
            m.points[k].tangent_impulse[1] = c.p[k].tangent_impulse[1];
        }
    }
}

/// Clamps a point's two accumulated tangent impulses together to the friction circle |l| <= max_f.
/// Clamping each row to its own bound would make a square cone, up to sqrt(2) too strong on the
/// diagonal and wrong on a slope not aligned with the first tangent.
inline void clamp_to_friction_circle(Real& l0, Real& l1, Real max_f) {
    const Real len2 = l0 * l0 + l1 * l1;
    if (len2 > max_f * max_f) {
        const Real scale = max_f / std::sqrt(len2);
        l0 *= scale;
        l1 *= scale;
    }
}

/// The soft step solver's contact kernels: the same arithmetic in lanes of different widths. Auto (the
/// default) picks the widest this CPU runs; the others exist to compare them (`sinew bench rigid --simd`)
/// and give bit-identical results, since no kernel fuses multiply-adds.
enum class SimdKernel : std::uint8_t {
    Auto,
    Portable,  ///< four lanes in plain arrays (double precision and non-x86 builds)
    Sse2,      ///< four floats per instruction (the x86-64 baseline)
    Avx        ///< eight floats per instruction, if the CPU has AVX
};
const char* simd_kernel_name(SimdKernel k);
bool simd_kernel_available(SimdKernel k);
/// Process-wide; call it between steps, not during one. False (and no change) if `k` is unavailable.
bool set_simd_kernel(SimdKernel k);
/// The kernel the next step will use (Auto resolved).
SimdKernel active_simd_kernel();

std::unique_ptr<RigidSolver> make_sequential_impulse_solver();
std::unique_ptr<RigidSolver> make_newton_impulse_solver();
std::unique_ptr<RigidSolver> make_soft_step_solver();

}  // namespace sinew
