// One-way coupling, rigid -> soft (seed 001 ch.4, O'Brien 2000's one-way case): rigid bodies push soft
// bodies and carry their attached particles; soft bodies do not push back.
//
// Placement in the pipeline (docs/ARCHITECTURE.md): a hook before the soft system's IntegratePositions,
// which runs after the rigid system's IntegratePositions, so the soft system collides against the rigid
// bodies' end-of-step poses and attached particles follow where their bodies are now. The layer fills
// SoftSystem::colliders() with the rigid bodies whose broad-phase boxes overlap a soft body's box, and
// writes every attachment's frame. The soft system's ParticleContact records keep the impulses a two-way
// layer would apply back.
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

    /// Refills the soft system's colliders and attachment frames from the rigid system's current state,
    /// for a soft step of h.
    void refresh(Real h);

private:
    Pipeline& pipeline_;
    RigidSystem& rigid_;
    SoftSystem& soft_;
    int hook_ = 0;
    std::vector<std::uint32_t> mark_;  ///< per rigid slot: step stamp when added as a collider
    std::uint32_t stamp_ = 0;
};

}  // namespace sinew
