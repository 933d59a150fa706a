// The coupling layer between the rigid and the soft system: every strategy of coupling/coupling_settings.hpp
// in one place, chosen per world and per soft-rigid pair.
//
// What every strategy shares is the one-way part (coupling/one_way_coupling.hpp): rigid bodies become
// the soft system's colliders and carry attached particles. On top of it (docs/ARCHITECTURE.md, the step
// pipeline; seed 001 Figure 9):
//   two-way  the particle rows (coupling/particle_rows.hpp) are a row source of the rigid solver, built
//            from the soft system's collision planes and solved in every rigid iteration and sub-step.
//            The rigid bodies an implicit Euler body's particles touch are unknowns of its own solve,
//            those particles tied to them (soft/implicit_euler.cpp, "Rigid bodies in the solve"): what
//            the ties gave the particles is taken from the bodies inside the rigid solve, so a body feels
//            the springs implicitly, not only the particles' inertia (which alone let a 1 kg ball sink
//            through a 0.5 kg cloth).
//            Before soft SolveVelocities the rows' velocity changes go into the soft bodies' predictions;
//            after it (every velocity solved, no position integrated) the impulses the soft contact pass
//            still had to give those particles go back to the rigid bodies, and the rows are solved again
//            against the result (exchange iterations);
//   hybrid   after soft SolveVelocities the rigid body takes `gain` times the opposite of the impulses the
//            soft contact pass gave the particles.
//   embed-rigid, embed-fem  the embeddings (coupling/rigid_embedding.hpp, coupling/fem_embedding.hpp).
// The impulses soft bodies gave rigid bodies in the last step are kept (impulses()) for events.
#pragma once

#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <vector>

#include "coupling/coupling_settings.hpp"
#include "coupling/fem_embedding.hpp"
#include "coupling/one_way_coupling.hpp"
#include "coupling/particle_rows.hpp"
#include "coupling/rigid_embedding.hpp"
#include "coupling/strategy_picker.hpp"

namespace sinew {

struct CouplingError : std::invalid_argument {
    using std::invalid_argument::invalid_argument;
};

class CouplingLayer {
public:
    /// Registers the hooks and the row source; `rigid` and `soft` must already be systems of `pipeline`.
    CouplingLayer(Pipeline& pipeline, RigidSystem& rigid, SoftSystem& soft);
    ~CouplingLayer();
    CouplingLayer(const CouplingLayer&) = delete;
    CouplingLayer& operator=(const CouplingLayer&) = delete;

    /// The settings as set (the strategy may be "auto").
    const CouplingSettings& settings() const { return requested_; }
    /// The settings acting: as set, or under "auto" one pair per soft body with its pick, then the pairs set.
    const CouplingSettings& effective_settings() const { return settings_; }
    /// Validates (CouplingError naming the field, or the pair and the body it names; nothing changes)
    /// and applies from the next step (under "auto", picks at once).
    void set_settings(const CouplingSettings& s);
    /// The strategy acting between two bodies now.
    CouplingStrategy strategy(SoftBodyId soft, BodyId rigid) const { return coupling_strategy_of(settings_, soft, rigid); }
    /// Under "auto": the last picks, one per soft body, with their reasons, a pair of the settings naming
    /// the soft body (and no rigid body) shown as the pick (empty otherwise). Picked again when the
    /// settings are set, on refresh_embedding() and need_proxy(), and at a step's start when a body was
    /// created or destroyed or a rigid body's type changed since (not when a mass or speed changes).
    const std::vector<StrategyPick>& picks() const { return picks_; }
    /// A joint is to hold soft body `soft` (through its rigid proxy). Under "auto" the body is embedded from
    /// now on, unless a pair of the settings says otherwise (rule 1 of coupling/strategy_picker.hpp; it
    /// stays so after the joint is gone); under any strategy the proxies follow the bodies at once
    /// (refresh_embedding). Throws CouplingError as set_settings, nothing changed then.
    void need_proxy(SoftBodyId soft);
    /// What soft bodies did to rigid bodies in the last step, one record per (particle, rigid body)
    /// contact (two-way rows and reactions sent back; the one-way contacts push nothing back).
    const std::vector<CouplingImpulse>& impulses() const { return impulses_; }
    OneWayCoupling& kinematics() { return kinematics_; }
    /// Proxies follow soft bodies created, destroyed, pinned or attached since the last step now rather
    /// than at the next step's start (RigidEmbedding::update_membership).
    void refresh_embedding();
    /// Embedded soft bodies and their rigid proxies (strategy embed-rigid).
    RigidEmbedding& embedding() { return embedding_; }
    const RigidEmbedding& embedding() const { return embedding_; }
    /// Embedded rigid bodies and their FEM proxies (strategy embed-fem).
    const FemEmbedding& fem_embedding() const { return fem_embedding_; }

private:
    /// Under "auto": the picks for the bodies now, and the effective settings they give.
    CouplingSettings resolve(const CouplingSettings& requested, std::vector<StrategyPick>& picks);
    /// Picks and applies; throws CouplingError as apply does, picks_ unchanged then.
    void apply_auto(const CouplingSettings& requested);
    /// Makes `effective` act (proxies made or dropped, sub-steps set).
    void apply(const CouplingSettings& effective);
    /// Before each step (RigidEmbedding::set_before_step): picks again if bodies came or went.
    void resolve_if_changed();
    void begin_step(Real h);
    /// Before soft IntegratePositions: soft bodies that carried an awake rigid body stay awake.
    void keep_tied_bodies_awake();
    /// Two-way: the impulses the rigid bodies tied to implicit Euler's solve gave its particles
    /// (SoftBody::contact_tie_impulse), sent back inside the rigid solve.
    void send_back_tie_impulses();
    /// Two-way: the rigid bodies tied to implicit body `b`'s particles in this step's solve
    /// (SoftBody::coupled_rigids, contact_rigid).
    void tie_rigid_bodies(SoftBody& b, SoftBodyId id, std::uint32_t slot, Real h);
    /// The attachment's target, if it still exists and is a dynamic body (its frame written this step).
    bool dynamic_target(const Attachment& a, BodyId& out) const;
    /// Sizes b.attachment_impulse when a hybrid or interleaved attachment of b wants its reaction.
    void ask_attachment_reactions(SoftBody& b, SoftBodyId id);
    /// After soft SolveVelocities: hybrid attachments give the opposite of what holding their particle
    /// took, times `gain`, to the body now; interleaved ones as a force over the next step.
    void send_back_attachment_reactions(Real h);
    void before_soft_solve(Real h);
    void after_soft_solve(Real h);
    void after_step();
    /// The opposite of the impulses the soft contact pass gave particles touching dynamic rigid bodies
    /// under `strategy`, times `gain`, applied to those bodies' velocities now.
    void send_back_contact_impulses(CouplingStrategy strategy, Real gain);
    bool any(CouplingStrategy s) const;
    /// Body b is solved with the rigid bodies coupled to it by `s`: two-way, or one-solver for a body the
    /// rigid solver does not take whole (FEM and Verlet bodies).
    /// The friction coefficient of a tie between b and the rigid body in `rigid_slot` (geometric mean).
    Real tie_friction(const SoftBody& b, std::uint32_t rigid_slot) const {
        return std::sqrt(std::max(Real(0), b.def.friction * rigid_.slot_material(rigid_slot).friction));
    }
    static bool ties_with(const SoftBody& b, CouplingStrategy s) {
        return s == CouplingStrategy::TwoWay || (s == CouplingStrategy::OneSolver && !b.solved_by_rows);
    }

    /// Sub-stepping: before soft sub-step j + 1 (coupling substeps > 1).
    void before_soft_substep(int j);
    /// Hybrid with sub-steps: the reaction of a sub-step after the first, kept for the next step.
    void collect_hybrid_reaction();
    void apply_late_impulses();

    // Interleaved (coupling/interleaved_coupling.cpp), in step order.
    /// Before rigid IntegrateVelocities: last step's soft contact forces act on the rigid bodies.
    void apply_interleaved_forces();
    /// After soft DetectCollisions: the colliders as predicted from the rigid bodies' previous motion.
    void snapshot_colliders();
    /// Before soft SolveVelocities, after the one-way refinement: interleaved colliders keep the snapshot.
    void keep_previous_poses();
    /// After soft SolveVelocities: the soft contacts' forces kept for the next step, repairs listed.
    void gather_interleaved_forces(Real h);
    /// After soft IntegratePositions: the repair step.
    void repair_interleaved();

    Pipeline& pipeline_;
    RigidSystem& rigid_;
    SoftSystem& soft_;
    CouplingSettings requested_;
    CouplingSettings settings_;  ///< effective: never "auto"
    std::vector<StrategyPick> picks_;
    std::vector<SoftBodyId> held_;             ///< soft bodies joints hold (need_proxy)
    std::uint64_t picked_revision_[2] = {0, 0};  ///< the rigid and soft systems' structure revisions when applied
    OneWayCoupling kinematics_;
    ParticleRows rows_;
    RigidEmbedding embedding_;
    FemEmbedding fem_embedding_;
    std::vector<CouplingImpulse> impulses_;
    std::vector<CouplingImpulse> sent_back_;  ///< this step's reactions, merged into impulses_ after it
    std::vector<std::uint32_t> rigid_index_;   ///< scratch of tie_rigid_bodies: per rigid slot, its index in the body's coupled_rigids
    std::vector<std::uint32_t> coupled_slots_; ///< scratch of tie_rigid_bodies: the slots given an index
    struct AttachTie {
        std::uint32_t soft, particle, rigid;
        Vec3 arm;  ///< attachment point - centre of mass, at the start of the step
    };
    std::vector<AttachTie> attach_ties_;   ///< this step's two-way attachments tied to their bodies
    /// Per soft slot, per particle: the kinetic friction impulse of a sliding tie (zero: held, or not tied).
    std::vector<std::vector<Vec3>> slip_;
    /// Per soft slot, per particle: tied in the last step (a new tie starts along the normal only).
    std::vector<std::vector<std::uint8_t>> tied_before_;
    int hooks_[8] = {0, 0, 0, 0, 0, 0, 0, 0};

    struct PendingForce {
        std::uint32_t rigid, generation;
        Vec3 local_point;  ///< in the body's frame (origin transform)
        Vec3 force;        ///< N, world
    };
    struct Repair {
        std::uint32_t soft, particle, collider;
    };
    std::vector<Collider> snapshot_;              ///< this step's colliders as first predicted
    std::vector<std::uint8_t> interleaved_;       ///< per collider: some soft body is interleaved against it
    std::vector<PendingForce> pending_forces_;
    std::vector<PendingForce> late_impulses_;     ///< hybrid's sub-step reactions (N s in `force`), next step
    std::vector<Repair> repairs_;
    Real last_repair_ = 0;

public:
    /// Interleaved: the largest distance the last repair step moved a particle (m): the discrepancy
    /// between where the soft bodies were told a rigid body would go and where it went.
    Real last_repair() const { return last_repair_; }
};

}  // namespace sinew
