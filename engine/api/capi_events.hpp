// Events of a C API world (sinew_world_get_events): contact begin/end, sleep/wake and joint breaks,
// gathered by pipeline hooks around every fixed step.
//
// - Sleep/wake: the awake flags of the dynamic rigid bodies are saved before the step (a hook before the
//   rigid system's first stage) and compared after it, so changes the game made between steps (waking a
//   body by pushing it) are not reported, only what the step did.
// - Contacts: the sorted set of touching body pairs (slot and generation of both bodies) after each step
//   is merge-joined with the previous step's: pairs only in the new set began, pairs only in the old one
//   ended. RigidSystem::contacts() is sorted by body pair, so building the set is one linear pass.
// - Joint breaks: RigidSystem::broken_joints() after the step; the definition of a broken joint is gone
//   by then, so the bodies and user data come from a table filled when joints are created.
// - Sensors: World::sensor_events() (engine/world/sensor_tracker.hpp), copied after the stepping call.
// - Soft contacts: the coupling layer's impulses of the step (CouplingLayer::impulses()), summed per
//   (soft body, rigid body) pair.
// All buffers use the world's host allocator and keep their capacity: no allocation in a steady state.
#pragma once

#include <cstdint>

#include "engine/api/capi_alloc.hpp"
#include "engine/api/sinew.h"
#include "engine/world/world.hpp"

namespace sinew::capi {

/// The C form of a sensor overlap (`step` 0 for a current overlap).
sinew_sensor_event sensor_event_c(std::uint32_t world_tag, const SensorOverlap& o, std::uint64_t step);

class WorldEvents {
public:
    /// Registers the hooks on world's pipeline. `world_tag` is the packed world id put in handles.
    WorldEvents(World& world, const HostHooks& hooks);
    ~WorldEvents();
    WorldEvents(const WorldEvents&) = delete;
    WorldEvents& operator=(const WorldEvents&) = delete;

    void set_world_tag(std::uint32_t tag) { tag_ = tag; }
    /// Called at the start of each stepping call: the previous call's events are dropped.
    void clear();
    /// Remembers a joint's bodies and user data for its break event (throws std::bad_alloc).
    void remember_joint(JointId id, const JointDef& def);
    /// Sensor events of the stepping call (World::sensor_events()), gathered after it returns: the
    /// world's sensor tracker runs after the pipeline, past this class's hooks.
    void gather_sensors(const std::vector<SensorEvent>& events);
    /// Pointers into the buffers, valid until the next clear().
    sinew_events view() const;

private:
    struct Pair {
        std::uint32_t a, ga, b, gb;  ///< slots and generations, a < b
        std::uint32_t first;         ///< this step: index of the pair's first manifold in contacts()
        bool operator<(const Pair& o) const;
        bool operator==(const Pair& o) const { return a == o.a && ga == o.ga && b == o.b && gb == o.gb; }
    };
    struct JointMeta {
        std::uint32_t generation = 0;
        BodyId a, b;
        std::uint64_t user_data = 0;
    };

    void before_step();
    /// After the rigid system's DetectCollisions, before any solve: the approach speed of each pair that
    /// touches now and did not after the last step (a begin event to come).
    void before_solve();
    void after_step(std::uint64_t step);
    void gather_sleep(std::uint64_t step);
    void gather_contacts(std::uint64_t step);
    void gather_breaks(std::uint64_t step);
    void gather_soft_contacts(std::uint64_t step);
    sinew_body_id handle(std::uint32_t slot, std::uint32_t generation) const { return {tag_, slot, generation}; }

    World& world_;
    std::uint32_t tag_ = 0;
    int hook_before_ = 0, hook_solve_ = 0, hook_after_ = 0;
    int dropped_ = 0;

    HostVector<sinew_contact_begin_event> begin_;
    HostVector<sinew_contact_end_event> end_;
    HostVector<sinew_sleep_event> sleep_;
    HostVector<sinew_joint_break_event> breaks_;
    HostVector<sinew_soft_contact_event> soft_;
    HostVector<sinew_sensor_event> sensor_begin_, sensor_end_;
    struct SoftSum {
        std::uint32_t rigid, soft;
        Vec3 impulse, weighted_point;
        Real weight;
        int particles;
    };
    HostVector<SoftSum> soft_sums_;  ///< scratch of gather_soft_contacts
    HostVector<std::uint8_t> awake_before_;         ///< per rigid slot, 2 = not a live dynamic body
    HostVector<std::uint32_t> generation_before_;  ///< per rigid slot
    HostVector<Pair> pairs_, new_pairs_;
    struct Approach {
        Pair pair;
        float speed;
    };
    HostVector<Approach> approach_;  ///< this step's new pairs, in pair order (before_solve)
    HostVector<JointMeta> joints_;                  ///< per joint slot
};

}  // namespace sinew::capi
