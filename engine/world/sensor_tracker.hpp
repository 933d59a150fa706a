// Sensors (trigger volumes): which rigid and soft bodies overlap each sensor body after a step, and the
// begin and end events of those overlaps.
//
// A sensor (BodyDef::sensor) never touches anything: the rigid system keeps it out of its pair list,
// the soft colliders and the queries. After every step (a pipeline hook after the last stage, when every
// position is final) the tracker tests each sensor against what its world box overlaps:
//  - a rigid body counts if it is dynamic or kinematic (static geometry does not visit a sensor), is not
//    a sensor, passes the sensor's collision filter, and its shape touches the sensor's (the narrow
//    phase's exact test, depth >= 0 at margin 0, as RigidSystem::overlap_shape), and is no embedded soft
//    body's rigid proxy (the soft body itself is reported);
//  - a soft body counts if it passes the filter and one of its particles, a sphere of the body's
//    thickness, touches the sensor's shape (signed distance <= thickness).
// The overlaps are kept sorted by (sensor slot, rigid before soft, visitor slot); a merge join with the
// previous step's list gives the events, in that order: deterministic on any worker count. Every begin is
// followed by exactly one end, also when the visitor or the sensor is destroyed (the end then names a
// stale id). Box2D v3 computes its sensor events the same way, at the end of the step.
#pragma once

#include <cstdint>
#include <vector>

#include "coupling/coupling_layer.hpp"
#include "engine/core/narrowphase.hpp"
#include "rigid/rigid_system.hpp"
#include "soft/soft_system.hpp"

namespace sinew {

/// One body overlapping one sensor.
struct SensorOverlap {
    BodyId sensor;
    bool soft = false;       ///< the visitor is soft_body (else body)
    BodyId body;             ///< a rigid visitor
    SoftBodyId soft_body;    ///< a soft visitor
};

/// An overlap that began (its first step) or ended (the first step without it).
struct SensorEvent {
    SensorOverlap overlap;
    bool begin = true;
    std::uint64_t step = 0;  ///< the step's index, counted from 1 (the step that found it)
};

class SensorTracker {
public:
    /// Finds the overlaps after step `step` and this step's events (replacing the last step's events).
    void update(const RigidSystem& rigid, const SoftSystem& soft, const CouplingLayer& coupling, std::uint64_t step);
    /// The events of the last update, in (sensor, rigid before soft, visitor) order, ends and begins merged.
    const std::vector<SensorEvent>& step_events() const { return events_; }
    /// What overlaps `sensor` now (as of the last step), in visitor order; empty for a body that is no
    /// sensor. Replaces out's contents.
    void overlaps(BodyId sensor, std::vector<SensorOverlap>& out) const;
    /// Every overlap now, in tracker order.
    std::size_t overlap_count() const { return current_.size(); }

private:
    struct Key {
        std::uint32_t sensor, sensor_generation;
        std::uint32_t soft;  ///< 0 rigid, 1 soft: rigid visitors first
        std::uint32_t slot, generation;
        bool operator<(const Key& o) const;
        bool operator==(const Key& o) const;
    };
    static SensorOverlap overlap_of(const Key& k);
    void find(const RigidSystem& rigid, const SoftSystem& soft, const CouplingLayer& coupling, std::uint32_t sensor);

    std::vector<Key> current_, next_;
    std::vector<SensorEvent> events_;
    ManifoldList manifolds_;  ///< the narrow phase's scratch
};

}  // namespace sinew
