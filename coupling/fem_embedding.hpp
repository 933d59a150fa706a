// Embedding rigid bodies into the FEM system (strategy embed-fem; Parker & O'Brien 2009, seed 001 ch.4 §3,
// ../shared/THEORY.md §6): each dynamic rigid body paired embed-fem with a soft body gets a stiff FEM
// proxy in the soft system, a tetrahedral mesh of its shape (a fan of tets from its centre to a surface
// triangulation: boxes, spheres, capsules, convex hulls), of its mass at uniform density.
//
// Each step, before the soft system's IntegrateVelocities, the proxy is reset to the rigid body's pose and
// velocity field (the gravity the solver will add over the step included), with no gravity of its own, so
// its elements see a rigid motion. It meets only the soft bodies paired with its rigid body, through the
// soft-soft contacts (soft/soft_contacts.hpp), where it moves as one rigid body of the body's mass and
// inertia (SoftBody::as_rigid: the limit of a very stiff proxy); those soft bodies ignore the rigid body's
// own collider. After the soft SolveVelocities (every velocity solved, no position moved: seed 001 Figure
// 9) the impulses the pass gave it, summed to an impulse and an angular impulse about the centre of mass,
// go to the rigid body. What embedding loses (seed 001 ch.4 §3): the contacts act after the soft solve, not
// in it, so the soft side feels the body only through them, a step at a time.
#pragma once

#include <cstdint>
#include <vector>

#include "coupling/coupling_settings.hpp"
#include "coupling/particle_rows.hpp"
#include "coupling/rigid_embedding.hpp"
#include "rigid/rigid_system.hpp"
#include "soft/soft_system.hpp"

namespace sinew {

class FemEmbedding {
public:
    /// `rigid_proxies`: the other embedding, whose rigid proxies of soft bodies get no FEM proxy.
    FemEmbedding(RigidSystem& rigid, SoftSystem& soft, const RigidEmbedding& rigid_proxies)
        : rigid_(rigid), soft_(soft), rigid_proxies_(rigid_proxies) {}

    /// Throws CouplingError naming the pair if a pair embed-fem names a rigid body that is not dynamic or
    /// whose shape has no proxy (planes, meshes, compounds); changes nothing then.
    void check(const CouplingSettings& settings) const;
    /// Before soft IntegrateVelocities: proxies made for newly embedded bodies, dropped for bodies no longer
    /// embedded (or gone), each reset to its body's pose and velocity; partners and ignored colliders set.
    /// `any`: some pair (or the world) is embed-fem.
    void place(const CouplingSettings& settings, bool any, Real h);
    /// After soft DetectCollisions: a proxy a soft body woke wakes its rigid body.
    void wake_touched();
    /// After soft SolveVelocities: each proxy's momentum change to its rigid body; one record per contact.
    void send_back(std::vector<CouplingImpulse>& sent);

    bool is_proxy(SoftBodyId soft) const;
    /// Proxies alive now.
    std::size_t count() const;
    /// The proxy of an embedded rigid body (null if it has none).
    SoftBodyId proxy(BodyId rigid) const;
    /// The proxy's surface and tets in the body's frame for a shape (false: no proxy for that shape).
    static bool proxy_mesh(const Shape& shape, std::vector<Vec3>& nodes, std::vector<std::uint32_t>& tets);

private:
    struct Proxy {
        BodyId rigid;
        SoftBodyId soft;
        std::vector<Vec3> local;  ///< node positions in the rigid body's frame
    };
    bool wanted(const CouplingSettings& settings, std::uint32_t rigid_slot) const;
    /// The soft bodies (slots, not proxies) paired embed-fem with `rigid`.
    void partners(const CouplingSettings& settings, BodyId rigid, std::vector<std::uint32_t>& out) const;
    void drop(Proxy& px);

    RigidSystem& rigid_;
    SoftSystem& soft_;
    const RigidEmbedding& rigid_proxies_;
    std::vector<Proxy> proxies_;
    mutable std::vector<std::uint32_t> partner_scratch_;  ///< of wanted()
};

}  // namespace sinew
