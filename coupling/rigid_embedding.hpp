// Embedding soft bodies into the rigid solver (strategy embed-rigid; Fishman 2012, seed 001 ch.4 §2 and
// ch.5 §7): each embedded soft body has one rigid body, its proxy (coupling/rigid_proxy.hpp), dynamic
// (kinematic if the body is anchored, below), that meets every other rigid body, proxy and joint inside
// the rigid solver as a native body would.
// The soft body's own step still runs in the soft system (its springs, pressure, elements, gravity);
// its own contact pass meets no collider (SoftBody::meets_colliders_through_proxy).
//
// Where it acts in the step (docs/ARCHITECTURE.md, the step pipeline):
//  - before rigid IntegrateVelocities: the proxy is measured from the nodes at x_n: mass, centre of mass,
//    Steiner inertia, rotation, the convex hull of the nodes in its frame (RigidSystem::reshape), and
//    its velocity from their momentum and angular momentum. It falls under the rigid solver's gravity
//    (the soft body's gravity scale), counted so that the nodes, which take theirs in their own step, do
//    not get it twice (RigidSystem::gravity_in_solve);
//  - after soft IntegrateVelocities: its velocity is measured again from the nodes' predicted motion
//    ((x_next - x_n) / h: gravity, internal forces), before the rigid broad phase and the solve see it;
//  - after rigid SolveVelocities, and after rigid IntegratePositions (the soft step's relax, split
//    impulses' and joints' position corrections): whatever the rigid solve changed is given to the nodes,
//    the velocity change as the rigid field Δv + Δω × r_i, the position correction (where the proxy
//    went against where the nodes' velocities take them) as a rigid displacement of the nodes' end-of-
//    step positions about their centre of mass;
//  - after soft IntegratePositions: the proxy is placed where the nodes ended, for queries between steps.
// Changes are read as momentum and angular momentum (M Δv, Δ(I ω)), not as velocities: the rigid
// system's gyroscopic update turns ω while keeping I ω, which the nodes already do by moving.
//
// A soft body with a pinned or attached node gets a kinematic proxy (moved by its nodes, pushing rigid
// bodies, pushed by none): a rigid motion of the whole body would move the pinned nodes. It is made anew
// (its joints gone) when the body gains or loses its last pin.
//
// With one proxy per body, applying each velocity change to the nodes inside the solver's iterations
// (so the next constraint sees them, as seed 001 asks) and applying the sum after the solve are the same:
// the nodes are read by nothing else during the rigid solve (the soft body meets colliders only through
// its proxy), and the proxy's velocity is exactly the nodes' rigid part. With one proxy per element
// (CouplingSettings::embed_proxies), shared nodes couple neighbouring proxies inside the loop: those are
// kept by coupling/element_proxies.hpp, a row source of the rigid solver, which this layer drives.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "coupling/coupling_settings.hpp"
#include "coupling/element_proxies.hpp"
#include "coupling/rigid_proxy.hpp"
#include "engine/core/pipeline.hpp"
#include "rigid/rigid_system.hpp"
#include "soft/soft_system.hpp"

namespace sinew {

class RigidEmbedding {
public:
    RigidEmbedding(Pipeline& pipeline, RigidSystem& rigid, SoftSystem& soft);
    ~RigidEmbedding();
    RigidEmbedding(const RigidEmbedding&) = delete;
    RigidEmbedding& operator=(const RigidEmbedding&) = delete;

    /// Creates the proxies of the soft bodies `settings` embeds that have none, destroys those of bodies
    /// that are gone or no longer embedded (their joints with them), and makes anew those whose body
    /// gained or lost its last pin. Runs at every step's start too; call it after creating, destroying or
    /// pinning soft bodies for the proxies to follow at once. Throws CouplingError naming a soft body
    /// whose proxy cannot be made (a node that is not finite) before creating anything.
    void update_membership(const CouplingSettings& settings);
    /// Called first in every step, before the membership is updated: the coupling layer's "auto" strategy
    /// resolves there when bodies came or went (its hooks run after this layer's).
    void set_before_step(std::function<void()> f) { before_step_ = std::move(f); }
    /// Is `rigid` a proxy this layer made (its soft body may be gone since the last update)?
    bool is_proxy(BodyId rigid) const;
    /// The proxy of soft body `id`, or a null id if it is not embedded with one proxy for the body.
    BodyId proxy(SoftBodyId id) const;
    /// The element proxies of soft body `id` (embedded with CouplingSettings::embed_proxies = Elements),
    /// one per element in the order ElementProxies found them; empty if it is not embedded that way.
    const std::vector<BodyId>& element_proxies(SoftBodyId id) const;
    /// Is soft body `id` embedded with one proxy per element (it has no whole-body proxy then)?
    bool embedded_by_elements(SoftBodyId id) const { return !element_proxies(id).empty(); }
    /// The nodes of element e of soft body `id` (empty if none).
    std::vector<std::uint32_t> element_nodes(SoftBodyId id, std::size_t e) const;
    /// The soft body whose proxy `rigid` is, or a null id. Constant time (tools call it per manifold).
    SoftBodyId soft_of(BodyId rigid) const;
    /// One contact point of the last rigid step between a proxy and a body that is not a proxy (contacts
    /// between two proxies are left out: neither is a body the soft bodies push from outside).
    struct ProxyContact {
        std::uint32_t body = 0;       ///< the other body's slot
        SoftBodyId soft;              ///< the soft body whose proxy it is
        Vec3 normal = Vec3::UnitY();  ///< unit, from the proxy into `body`
        Real impulse = 0;             ///< the point's total normal impulse (N s): `body` took normal * impulse
    };
    /// Calls f(const ProxyContact&) for every such point of RigidSystem::contacts(), in their order: the
    /// impulses embedded soft bodies gave other bodies through their proxies (tools sum what they need).
    template <class F>
    void for_each_proxy_contact(F&& f) const {
        for (const ContactManifold& c : rigid_.contacts()) {
            const SoftBodyId sa = soft_of(rigid_.id_of_slot(c.body_a)), sb = soft_of(rigid_.id_of_slot(c.body_b));
            if (sa.is_null() == sb.is_null()) continue;
            // The manifold's normal points from A to B: B takes +n times the normal impulse.
            const bool proxy_a = !sa.is_null();
            const Vec3 normal = proxy_a ? c.manifold.normal : Vec3(-c.manifold.normal);
            for (int k = 0; k < c.manifold.count; ++k)
                f(ProxyContact{proxy_a ? c.body_b : c.body_a, proxy_a ? sa : sb, normal,
                               c.manifold.points[k].total_normal_impulse});
        }
    }
    /// How many soft bodies are embedded now.
    std::size_t count() const;
    /// Relative flatness of the proxies' hulls (make_convex_hull): points within it x the diagonal of a
    /// plane share one face.
    static constexpr Real kHullFlatness = kProxyHullFlatness;

private:
    struct Proxy {
        BodyId body;
        std::uint32_t soft_generation = 0;
        /// Some node is pinned or attached: the proxy is kinematic (it pushes rigid bodies and nothing
        /// pushes it), since a rigid motion of the whole body would move the pinned nodes.
        bool anchored = false;
        std::vector<Vec3> rest;   ///< node offsets from the centre of mass when the proxy was made
        Vec3 com0 = Vec3::Zero(); ///< centre of mass when last written
        Quat q0 = Quat::Identity();  ///< the proxy's orientation when last written
        Mat3 inertia0 = Mat3::Zero();  ///< the nodes' inertia at x_n (world): the Δω of an angular impulse
        Vec3 p_written = Vec3::Zero(), l_written = Vec3::Zero();  ///< the proxy's momenta as last written
        /// Its soft body stepped this step and the proxy was written from its prediction. Not the body's
        /// `stepping`: a body whose nodes diverged steps without it, and the soft system clears `stepping`
        /// in IntegratePositions, before end_step reads this.
        bool stepped = false;
        bool put_to_sleep = false;  ///< this layer put the soft body to sleep with the proxy's island
        std::vector<BodyId> ignored;  ///< bodies its soft body is attached to (no collision with them)
    };
    void begin_step(Real h);
    void after_soft_predict(Real h);
    void after_rigid_solve(Real h);
    void after_rigid_positions(Real h);
    void end_step();
    /// The proxy's momenta now (M v, I_world(q) ω).
    void momenta(const Proxy& px, Vec3& p, Vec3& l) const;
    /// Where a velocity change goes: between steps (velocities), into the soft method's prediction
    /// (before soft SolveVelocities), or after the soft solve (IntegratePositions moves by h times it).
    enum class Into { Between, Predicted, Solved };
    /// What the rigid system did to the proxy since its momenta were last written, given to the nodes
    /// as the rigid field Δv + Δω × r_i about the centre of mass last written; the momenta written now.
    void take_changes(std::uint32_t slot, Proxy& px, Into into, Real h);
    /// The soft body of proxy slot s, if it steps this step.
    bool stepping(std::uint32_t s) const;
    /// Writes pose (and with `reshape` the hull, mass and inertia) and velocity from the nodes. Nodes that
    /// are not finite (a diverged body) leave the proxy as it was: false.
    bool write(std::uint32_t slot, Proxy& px, const std::vector<Vec3>& x, const std::vector<Vec3>& v, bool reshape);
    /// The proxy does not collide with the bodies its soft body is attached to, and again with those it
    /// no longer is.
    void ignore_attachment_targets(const SoftBody& b, Proxy& px);
    BodyId create_proxy(std::uint32_t slot);

    Pipeline& pipeline_;
    RigidSystem& rigid_;
    SoftSystem& soft_;
    CouplingSettings settings_;
    std::function<void()> before_step_;
    std::vector<Proxy> proxies_;  ///< by soft slot (body null: not embedded)
    /// By rigid slot: the soft slot whose proxy took that rigid slot last, or kNoSoft (soft_of and is_proxy
    /// in constant time). Set when a proxy is made, cleared when this layer destroys it; an entry whose
    /// rigid body was destroyed from outside is stale, which the proxy's full id (its generation) tells.
    std::vector<std::uint32_t> soft_slot_of_rigid_;
    static constexpr std::uint32_t kNoSoft = ~std::uint32_t(0);
    /// The soft slot whose proxy `rigid` is (its soft body may be gone since), or kNoSoft.
    std::uint32_t proxy_slot(BodyId rigid) const;
    std::vector<Vec3> scratch_v_, scratch_x_;
    ElementProxies elements_;  ///< after soft_slot_of_rigid_, which it shares
    int hooks_[5] = {0, 0, 0, 0, 0};
};

}  // namespace sinew
