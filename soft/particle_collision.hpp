// Particles against rigid shapes, one-way (the shapes are not pushed back): each particle is a sphere of
// radius `thickness`, projected out of every collider it penetrates (Jakobsen 2003: collisions by
// projection), each collider stood for by the particle's collision plane against it, found once per step. The final pass fixes velocities: the normal relative velocity is removed (or reflected by
// the restitution, as Jakobsen's reflection of the old position) and friction takes up to mu times the
// normal velocity change from the tangential one (Coulomb, as an impulse per particle). Verlet bodies get
// their friction at the position level inside the relaxation (project_positions), as Jakobsen's friction
// approximation reads the penetration depth; finish() then only handles restitution for them.
#pragma once

#include <vector>

#include "soft/collider.hpp"
#include "soft/soft_body.hpp"

namespace sinew {

/// A resting particle is reported as touching while it is this close to the surface (fraction of its
/// thickness), so contacts do not flicker on and off between steps.
constexpr Real kContactSlop = Real(0.1);

/// Signed distance query of a point against a placed shape: the closest surface point, the outward
/// normal there and the signed distance (< 0 inside). Returns false when the point is further than
/// `max_distance` from the shape (nothing else is written then).
bool point_shape_distance(const Vec3& point, const Shape& shape, const Transform& xf, Real max_distance,
                          Vec3& surface_point, Vec3& normal, Real& distance);

class ParticleCollision {
public:
    /// DetectCollisions, once per step: picks the colliders whose boxes overlap the body's reach this step
    /// and, for every particle that can reach one of them, finds its collision plane against it (as Jolt
    /// does): the closest surface point and the outward normal at the particle's predicted end-of-step
    /// position (Particles::x_next, where the contact pass tests it), kept in the collider's frame so the plane moves with the collider if a coupling layer
    /// refines its pose before the solve. The iterations then test planes, not shapes. For a convex
    /// shape the plane is a supporting plane, so a particle outside it is outside the shape.
    void begin(const SoftBody& b, const std::vector<Collider>& colliders, Real h);
    bool empty() const { return planes_.empty(); }
    /// Pushes particles out of their collision planes and applies Coulomb friction at the position
    /// level (Müller et al. 2007 / Macklin et al. 2014: the tangential motion over the step, relative to
    /// the collider, is cancelled up to mu times the push); returns how many it moved. Used by
    /// position-based methods inside their relaxation, where friction must act before the links are
    /// solved again (moving particles afterwards would bend a stick box or a ragdoll).
    int project_positions(SoftBody& b, Real h);
    /// The last pass: projects positions, corrects velocities (restitution, friction) and appends one
    /// ParticleContact per touching (particle, collider) to `out`.
    void finish(SoftBody& b, std::uint32_t body_slot, Real h, std::vector<ParticleContact>& out);

    /// One collision plane as a coupling layer reads it between DetectCollisions and SolveVelocities: the
    /// particle, the collider (index into the step's colliders) and the plane at the collider's current pose.
    struct PlaneView {
        std::uint32_t particle = 0;
        std::uint32_t collider = 0;
        Vec3 point = Vec3::Zero();   ///< on the collider's surface (world)
        Vec3 normal = Vec3::UnitY(); ///< outward unit normal, from the collider towards the particle
        Vec3 velocity = Vec3::Zero(); ///< of the collider's surface at `point` (m/s)
        Real friction = 0;            ///< the particle's and the collider's coefficients combined
    };
    std::size_t plane_count() const { return planes_.size(); }
    /// Plane k (k < plane_count()), grouped by collider, then by particle.
    PlaneView plane(std::size_t k) const;
    /// Plane k's particle alone (plane(k) also places the plane at its collider's pose).
    std::uint32_t plane_particle(std::size_t k) const { return planes_[k].particle; }
    /// A method that holds its particles on their planes inside its own solve (fast mass-spring) records
    /// the normal impulse plane k applied there (N s; negative when the plane pulled, which finish()
    /// reports as it is and leaves out of the friction budget and restitution) and the particle's approach
    /// speed that holding removed (m/s, >= 0: its normal speed into the plane before the solve). finish()
    /// counts the impulse as normal velocity change for the friction budget and reports it in the
    /// contact's impulse; restitution reflects the approach only (the impulse also carries the load the
    /// particle's links press it down with, which must not bounce it).
    void set_held(std::size_t k, Real impulse, Real approach) {
        held_[k] = impulse;
        held_approach_[k] = approach;
    }
    /// The solve also applied plane k's friction (the tangential impulse `impulse`, N s, within the
    /// Coulomb cone of its normal one): finish() applies none there and reports this one with the contact.
    void set_held_friction(std::size_t k, const Vec3& impulse) {
        held_friction_[k] = impulse;
        friction_held_[k] = 1;
    }

private:
    /// A particle's collision plane against one collider, in the world at the collider's pose when it
    /// was found (moved with the collider if the pose changes before the solve).
    struct Plane {
        std::uint32_t particle;
        std::uint32_t collider;
        Vec3 point;   ///< closest surface point
        Vec3 normal;  ///< outward unit normal there
    };
    /// The plane in the world at the collider's current pose: returns the signed distance of x from it
    /// (minus nothing: the particle radius is the caller's), and the point of the plane under x.
    Real world_plane(const Plane& pl, const Collider& col, const Vec3& x, Vec3& normal, Vec3& surface) const;

    const std::vector<Collider>* colliders_ = nullptr;
    std::vector<std::uint32_t> candidates_;  ///< scratch of begin(): colliders near the body
    std::vector<Plane> planes_;              ///< by collider (in candidate order), then by particle
    std::vector<Transform> found_at_;        ///< by collider index: its pose when the planes were found
    std::vector<Transform> start_at_;        ///< scratch of begin(): candidates' poses at the start of the step
    std::vector<Aabb> swept_;                ///< scratch of begin(): each collider's box over the step
    /// Per particle: the net position correction project_positions() made this step (push and friction,
    /// m). A position-based method (Verlet) absorbs the approach velocity in these pushes; finish() counts
    /// its normal part over h as normal velocity change (restitution, friction budget) and reports
    /// correction * m / h in the particle's first contact impulse.
    std::vector<Vec3> correction_;
    /// Per plane: the normal impulse a solve held it with and the approach speed it removed (set_held),
    /// 0 if none.
    std::vector<Real> held_;
    std::vector<Real> held_approach_;
    std::vector<Vec3> held_friction_;         ///< per plane: the tangential impulse a solve held it with
    std::vector<std::uint8_t> friction_held_;  ///< per plane: 1 if the solve applied its friction
    Real body_friction_ = 0;                  ///< the body's coefficient, for PlaneView::friction
};

}  // namespace sinew
