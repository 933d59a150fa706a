// Embedding a soft body into the rigid solver one element at a time (strategy embed-rigid with
// CouplingSettings::embed_proxies = Elements; seed 001 ch.4 §2 and ch.5 §7, extending Fishman 2012).
//
// Each element of an embedded soft body (a tet; a surface triangle if it has no tets; a structural link
// if it has neither) is a rigid body of the rigid system, its proxy: the Steiner quantities of its nodes
// (coupling/rigid_proxy.hpp), the convex hull of its nodes (a triangle's or a link's thickened by the
// body's thickness), dynamic, or kinematic if one of its nodes is pinned or attached. Proxies of one
// body share a negative collision group (they never collide with each other) and otherwise collide as
// the soft body does.
//
// Neighbouring proxies share nodes, so a velocity change of one is a change of its neighbours: as seed
// 001 asks ("if a triangle in an FEM has a rigid-body proxy, the velocity change must be applied to all
// the vertices of the FEM so that the next constraint will have up-to-date values"), this layer is a row
// source of the rigid solver (rigid/constraint_rows.hpp), called in every pass of every solver (the soft
// step's sub-steps and relax passes too) before the contacts: it gives each proxy's velocity change since
// its last call to the element's nodes, then measures every proxy's velocity again from its nodes
// (momentum and angular momentum). Within one pass a proxy sees its neighbours' changes of the pass
// before: a per-constraint exchange would need a call inside the solver's inner loop, and the wide
// solver's colour batches solve many constraints at once.
//
// Elements solved in the same pass would each stop a shared node, and their sum would overshoot it. So a
// node's mass is split between the k dynamic elements holding it, and each element's change Δv + Δω × r_i
// reaches it divided by k (mass splitting: Tonge, Benevolenski & Voroshilov 2012): an impulse J on a
// proxy changes its nodes' momentum by exactly J, and the proxies' masses sum to the body's.
// CouplingSettings::embed_proxy_mass = WholeBody weighs each element's nodes at the whole body's mass
// instead (seed 001: every tet given the whole mesh's mass, for faster convergence): a contact then stops
// an element as the whole body, in fewer passes, but the nodes take only Σ m_i / (k_i M) of the impulse
// the other body took.
//
// The proxies fall under the rigid solver's gravity as the whole-body proxy does (under the soft step a
// sub-step at a time, `pending` until then), and what it adds is never given to the nodes, which have it
// from their own step. Neither they nor the soft body sleep: the proxies would fall asleep island by
// island, each a static obstacle to the rest while the body moves. The rigid
// solve's position work (biased sub-steps, split impulses' pseudo-velocities, joint projection) reaches
// each node as the mean of the rigid displacements of the dynamic elements holding it.
#pragma once

#include <cstdint>
#include <vector>

#include "coupling/coupling_settings.hpp"
#include "rigid/constraint_rows.hpp"
#include "rigid/rigid_system.hpp"
#include "soft/soft_system.hpp"

namespace sinew {

/// A node's velocity over the step as its soft method predicts it: (x_next - x_n) / h, or for fast
/// mass-spring from Liu's inertial target (its first iterate leaves gravity out).
Vec3 predicted_node_velocity(const SoftBody& b, std::uint32_t i, Real h);
/// Where SoftSystem::integrate_positions will put particle i: x_next + h (v - v_solved) (a velocity change
/// made after the soft solve still moves this step), x_next for a pinned or attached one.
inline Vec3 end_of_step_position(const Particles& p, std::size_t i, Real h) {
    return p.inv_mass[i] != 0 ? Vec3(p.x_next[i] + h * (p.v[i] - p.v_solved[i])) : p.x_next[i];
}

class ElementProxies final : public ConstraintRows {
public:
    /// `soft_slot_of_rigid` is the embedding's map from a rigid slot to the soft slot whose proxy it is
    /// (shared with the whole-body proxies, so that RigidEmbedding::soft_of answers for both).
    ElementProxies(RigidSystem& rigid, SoftSystem& soft, std::vector<std::uint32_t>& soft_slot_of_rigid,
                   std::uint32_t no_soft);
    ~ElementProxies() override;
    ElementProxies(const ElementProxies&) = delete;
    ElementProxies& operator=(const ElementProxies&) = delete;

    /// `wanted[s]`: soft slot s is embedded with element proxies. Makes, keeps or drops each body's proxies
    /// (made anew when a node was pinned or freed, or the mass choice changed).
    void update_membership(const std::vector<bool>& wanted, EmbedProxyMass mass);
    /// How many soft bodies have element proxies.
    std::size_t count() const;
    bool embedded(std::uint32_t soft_slot) const;
    /// The generation of the soft body whose element proxies soft slot s holds.
    std::uint32_t generation(std::uint32_t soft_slot) const;
    /// Is `rigid` one of soft slot s's element proxies (its whole id)? Constant time.
    bool holds(std::uint32_t soft_slot, BodyId rigid) const;
    /// The proxies of soft slot s, one per element in the order the elements were found (empty if none).
    const std::vector<BodyId>& proxies(std::uint32_t soft_slot) const;
    /// The nodes of element e of soft slot s.
    std::vector<std::uint32_t> element_nodes(std::uint32_t soft_slot, std::size_t e) const;

    // The embedding's hooks (coupling/rigid_embedding.cpp calls these at its own).
    void begin_step();
    void after_soft_predict(Real h);
    void after_rigid_solve(Real h);
    void after_rigid_positions(Real h);
    void end_step();

    // ConstraintRows: the exchange through shared nodes in every pass.
    void prepare(RigidSystem&, const RowStep& step) override;
    void warm_start(const RigidSystem&, const BodyVelocities&) override {}
    void solve(const RigidSystem& sys, const BodyVelocities& vel, bool use_bias) override;
    bool active() const override { return any_stepping_; }

private:
    struct Set {
        std::uint32_t soft_generation = 0;
        EmbedProxyMass mass = EmbedProxyMass::Physical;
        // Per element e: its entries start[e] .. start[e+1] of `node`, `weight` and `rest`.
        std::vector<std::uint32_t> start, node;
        std::vector<Real> weight;  ///< the node's weight in this element's proxy (kg)
        std::vector<Vec3> rest;    ///< the node's offset from the element's weighted centre when made
        std::vector<BodyId> body;
        std::vector<std::uint8_t> kinematic;  ///< holds a pinned or attached node
        std::vector<Real> inv_valence;        ///< per node: 1 / the dynamic elements holding it (0: none)
        std::vector<Vec3> hull_at;            ///< the node in its element's frame when the hull was made
        std::vector<std::uint8_t> hulled;     ///< per element: has a hull (else the placeholder sphere)
        std::vector<BodyId> ignored;          ///< bodies the soft body is attached to: no collision with them
        // Per step.
        std::vector<Vec3> com;       ///< per element, where it was last measured
        std::vector<Mat3> inv_inertia;  ///< per element, world, at the last measurement
        std::vector<Quat> q0;        ///< per element, the orientation written
        std::vector<Vec3> v_sync, w_sync;  ///< per element, its velocity as this layer last wrote or read it
        std::vector<Vec3> node_v;    ///< per node, its velocity as the rigid solve has changed it
        std::vector<Vec3> node_v0;   ///< per node, node_v when last given to the soft body
        /// Under the soft step: the gravity its sub-steps have yet to give the proxies this step (the nodes
        /// have it from their own step), and what one sub-step gives.
        Vec3 pending = Vec3::Zero(), fall_per_substep = Vec3::Zero();
        int pending_substeps = 0;
        bool stepped = false;
    };
    /// What write() measures: the velocity only (the nodes have not moved since the last write), the pose
    /// too, or the pose and the hull.
    enum class Write { Velocity, Pose, Reshape };
    /// Writes every element's velocity from the nodes at x moving at `v` (and what `what` says). False
    /// (nothing written) if a node is not finite.
    bool write(std::uint32_t slot, Set& set, const std::vector<Vec3>& v, Write what);
    /// Gives each dynamic element's velocity change since v_sync (read from `vel`) to set.node_v; true if
    /// any changed.
    bool scatter(const SoftBody& b, Set& set, const BodyVelocities& vel);
    /// Measures each dynamic element's velocity from set.node_v and writes it into `vel` and v_sync.
    void gather(const SoftBody& b, Set& set, const BodyVelocities& vel);
    /// The node velocity changes the rigid solve made since they were last given (node_v - node_v0),
    /// into the soft method's prediction or (after the soft solve) the velocities.
    void give(std::uint32_t slot, Set& set, bool predicted, Real h);
    void destroy(std::uint32_t slot);
    void create(std::uint32_t slot, EmbedProxyMass mass);
    void create_bodies(std::uint32_t slot, const SoftBody& b, Set& set, const CollisionFilter& filter);
    void ignore_attachment_targets(const SoftBody& b, Set& set);
    bool holds_any(const Set& set, BodyId rigid) const;
    /// Slot s has proxies made of the body now in it (not of one destroyed since, whose slot was reused).
    bool current(std::uint32_t slot) const;
    bool stepping(std::uint32_t slot) const;
    BodyVelocities state_view();

    RigidSystem& rigid_;
    SoftSystem& soft_;
    std::vector<std::uint32_t>& soft_slot_of_rigid_;
    const std::uint32_t no_soft_;
    std::vector<Set> sets_;  ///< by soft slot (no elements: not embedded this way)
    std::vector<std::uint32_t> element_of_rigid_;  ///< by rigid slot: the element whose proxy took it last
    bool any_stepping_ = false;
    std::vector<Vec3> sx_, sv_;  // scratch
};

}  // namespace sinew
