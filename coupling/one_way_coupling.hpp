// One-way coupling, rigid -> soft (seed 001 ch.4, O'Brien 2000's one-way case): rigid bodies push soft
// bodies and carry their attached particles; soft bodies do not push back.
//
// Placement in the pipeline (docs/ARCHITECTURE.md): the soft system's stages run after the rigid
// system's of the same name, and the layer hooks three of them, each time predicting where every rigid
// body will be at the end of the step from its current pose and velocity
// (RigidSystem::unintegrated_time()):
//  - before soft IntegrateVelocities: refresh_attachments() writes every attachment's frame (attached
//    particles follow it; a moving one wakes its body);
//  - before soft DetectCollisions (after the rigid broad phase has refitted its boxes over the coming
//    step): refresh_colliders() fills SoftSystem::colliders() with the rigid bodies whose broad-phase
//    boxes overlap a soft body's reach;
//  - before soft SolveVelocities (after the rigid solve): update() predicts the same colliders and frames
//    again from the solved velocities, so soft contacts and attached particles meet the rigid bodies
//    where IntegratePositions will put them.
// The soft system's ParticleContact records keep the impulses a two-way layer would apply back.
#pragma once

#include <cstdint>

#include "engine/core/pipeline.hpp"
#include "rigid/rigid_system.hpp"
#include "soft/soft_system.hpp"

namespace sinew {

class OneWayCoupling {
public:
    /// Registers the hook; `rigid` and `soft` must already be systems of `pipeline`.
    OneWayCoupling(Pipeline& pipeline, RigidSystem& rigid, SoftSystem& soft);
    ~OneWayCoupling();
    OneWayCoupling(const OneWayCoupling&) = delete;
    OneWayCoupling& operator=(const OneWayCoupling&) = delete;

    /// Writes every attachment's frame from the rigid system's current state.
    void refresh_attachments();
    /// Refills the soft system's colliders from the rigid system's current state, for a soft step of h.
    void refresh_colliders(Real h);
    /// Re-predicts the poses and velocities of the colliders refresh_colliders() chose, and the frames.
    void update();
    /// Sub-stepping: the soft system runs k steps of h/k per step. The colliders and frames of the first
    /// are placed a k-th of the way from each body's pose at the start of the step to its predicted end;
    /// before sub-step j + 1 (j = 1 .. k-1, after the rigid step) place_substep(j) puts them (j+1)/k of
    /// the way to where the body ended (positions interpolated, orientations slerped: exact for constant
    /// velocities), with the body's velocity.
    void set_substeps(int k);
    void place_substep(int j);

private:
    Pipeline& pipeline_;
    RigidSystem& rigid_;
    SoftSystem& soft_;
    int hooks_[3] = {0, 0, 0};
    std::vector<std::uint32_t> mark_;  ///< per rigid slot: step stamp when added as a collider
    std::uint32_t stamp_ = 0;
    int substeps_ = 1;
    std::vector<Transform> start_;  ///< sub-stepping: per rigid slot, its pose at the start of the step
    std::vector<Vec3> start_com_;
    /// Where body `slot` is a fraction f of the way from its start pose to its pose t seconds from now.
    Transform between(std::uint32_t slot, Real t, Real f, Vec3& com) const;
    void place_collider(Collider& c, std::uint32_t slot, Real t, Real f) const;
    void place_attachment(Attachment& a, Real t, Real f) const;
    void place_attachments(Real t, Real f);
};

}  // namespace sinew
