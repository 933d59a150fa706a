// The rigid-body system: bodies, broad phase, contact cache and a solver, run as pipeline stages.
//
// Hot state lives in flat arrays indexed by body slot (pose, velocity, inverse mass and inertia), prepared
// once per step; cold data (shape, material, user data) sits apart. Body slots are reused through a free
// list; BodyId's generation detects stale handles.
#pragma once

#include <algorithm>
#include <atomic>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "engine/core/dynamic_tree.hpp"
#include "engine/core/manifold.hpp"
#include "engine/core/mass_properties.hpp"
#include "engine/core/narrowphase.hpp"
#include "engine/core/pipeline.hpp"
#include "engine/core/ray_cast.hpp"
#include "engine/core/shape_cast.hpp"
#include "engine/core/slots.hpp"
#include "engine/core/step_fault.hpp"
#include "engine/core/task_system.hpp"
#include "rigid/contact_levels.hpp"
#include "rigid/joint.hpp"
#include "rigid/rigid_body.hpp"
#include "rigid/rigid_settings.hpp"

namespace sinew {

/// Bad user data given to the rigid system (negative mass, NaN pose, stale id, ...).
struct RigidError : std::invalid_argument {
    using std::invalid_argument::invalid_argument;
};

/// What a pre-solve callback (RigidSystem::set_pre_solve) sees of one touching manifold, and may change.
struct PreSolveContact {
    BodyId body_a, body_b;
    Vec3 normal = Vec3::UnitY();  ///< unit, from A to B
    int point_count = 0;          ///< 1..4
    Vec3 points[Manifold::kMaxPoints];
    Real depths[Manifold::kMaxPoints] = {0, 0, 0, 0};  ///< m, > 0 penetrating, < 0 apart (speculative)
    Real friction = 0;     ///< the combined value; a change holds for this step (finite, >= 0)
    Real restitution = 0;  ///< the combined value; a change holds for this step (clamped to [0, 1])
};
/// Returns false to leave the contact out of this step's solve (a one-way platform letting a body through).
using PreSolveFn = std::function<bool(PreSolveContact&)>;

/// A manifold between two bodies, with the combined material, as solvers and coupling layers read it.
struct ContactManifold {
    std::uint32_t body_a = 0;  ///< body slot indices
    std::uint32_t body_b = 0;
    Real friction = 0;
    Real restitution = 0;
    Manifold manifold;
    // Where the narrow phase last ran for this pair, so a pair whose relative pose barely changed can
    // reuse its manifold (Jolt's body-pair cache): B's origin in A's frame, the normal in A's frame, and
    // each point's depth at that time.
    Transform relative;
    Vec3 normal_local_a = Vec3::UnitY();
    Real detected_depth[Manifold::kMaxPoints] = {0, 0, 0, 0};
};

class RigidSolver;
class JointSet;
class ConstraintRows;

/// The fastest a body may be set moving (m/s, rad/s): a velocity given at creation or by set_velocity
/// beyond these is refused (a rifle bullet flies at about 1e3 m/s; FLT_MAX made the next step's positions
/// non-finite). The solvers themselves do not clamp.
constexpr Real kMaxBodySpeed = Real(1e4);
constexpr Real kMaxBodySpin = Real(1e4);
/// The range of a dynamic body's mass (kg), given or from its density: outside it the solvers' float
/// arithmetic fails (issue 18: a 0.3 mm sphere at 1000 kg/m^3, 1.1e-7 kg, and masses of 1e30 or 1e-38
/// went non-finite within two steps). A 1 mg bead to a 1e12 kg asteroid.
constexpr Real kMinBodyMass = Real(1e-6);
constexpr Real kMaxBodyMass = Real(1e12);
/// Why (v, w) cannot be given to a body, or empty.
std::string velocity_problem(const Vec3& v, const Vec3& w);

class RigidSystem final : public System {
public:
    explicit RigidSystem(const RigidSettings& settings = {});
    ~RigidSystem() override;
    RigidSystem(const RigidSystem&) = delete;
    RigidSystem& operator=(const RigidSystem&) = delete;

    const char* name() const override { return "rigid"; }
    /// The threads a step may use (engine/core/task_system.hpp); null or serial: one. The world sets it.
    void set_task_system(const TaskSystem* tasks) { tasks_ = tasks; }
    const TaskSystem* task_system() const { return tasks_; }
    /// The region the system's parallel stages run in (one at a time).
    ParallelRegion& region() { return region_; }
    void run_stage(Stage stage, const StepContext& ctx) override;

    const RigidSettings& settings() const { return settings_; }
    /// Blocks of islands the last step's solve worked through one at a time (0: whole-world passes).
    int last_solve_blocks() const;
    /// Validates and applies new settings (throws RigidError naming the bad field).
    void set_settings(const RigidSettings& s);

    // ---- bodies -------------------------------------------------------------------------------------
    BodyId create_body(const BodyDef& def);   ///< validates def; throws RigidError and changes nothing
    void destroy_body(BodyId id);
    bool valid(BodyId id) const;
    std::size_t body_count() const { return slots_.count(); }
    /// Counts bodies created or destroyed and types changed: layers that decide from the set of bodies (the
    /// "auto" coupling strategy) look again when it moves.
    std::uint64_t structure_revision() const { return structure_revision_; }
    /// Ids of all live bodies in slot order.
    std::vector<BodyId> bodies() const;
    BodyId id_of_slot(std::uint32_t slot) const { return {slot, slots_.generation(slot)}; }
    std::size_t slot_count() const { return slots_.size(); }
    bool slot_alive(std::uint32_t slot) const { return slots_.alive(slot); }

    /// Body origin transform (not the centre of mass).
    Transform transform(BodyId id) const;
    void set_transform(BodyId id, const Transform& xf);
    Vec3 linear_velocity(BodyId id) const;
    Vec3 angular_velocity(BodyId id) const;
    /// Throws RigidError (nothing changed) for a non-finite or too fast velocity (kMaxBodySpeed, kMaxBodySpin)
    /// and for a non-zero one on a static body.
    void set_velocity(BodyId id, const Vec3& v, const Vec3& w);
    /// Moves a kinematic (or dynamic) body to `target` (its origin's pose) over the next step of `h`
    /// seconds by setting the velocities that take it there (Box2D's b2Body_SetTargetTransform, Jolt's
    /// MoveKinematic): the contacts it pushes and the soft bodies it carries see the motion, as they would
    /// not if it were teleported. The rotation takes the shorter way (at most half a turn per step).
    /// Throws RigidError (nothing changed) for a static body, a non-finite target, a zero quaternion,
    /// h <= 0, or a velocity past set_velocity's limits.
    void set_target_transform(BodyId id, const Transform& target, Real h);
    /// Pose and velocity of a moving body that something else drives every step (a soft body's proxy,
    /// coupling/rigid_embedding.hpp): unlike set_transform and set_velocity it wakes nothing, so the body's
    /// island may still fall asleep when the driven motion is slow. Not checked beyond the id.
    void place(BodyId id, const Transform& xf, const Vec3& v, const Vec3& w);
    void apply_force(BodyId id, const Vec3& force, const Vec3& world_point);
    void apply_impulse(BodyId id, const Vec3& impulse, const Vec3& world_point);
    BodyType type(BodyId id) const;
    Real mass(BodyId id) const;
    /// Inverse inertia about the centre of mass in the body's own axes (zero for static and kinematic bodies).
    const Mat3& inverse_inertia_local(BodyId id) const;
    Real linear_damping(BodyId id) const;   ///< 1/s, as created
    Real angular_damping(BodyId id) const;  ///< 1/s, as created
    Real gravity_scale(BodyId id) const;
    /// From the next step; wakes the body. Throws RigidError for a non-finite scale.
    void set_gravity_scale(BodyId id, Real scale);
    /// From the next step (1/s, v *= 1 / (1 + h c)); wakes the body. Throws RigidError for a negative or
    /// non-finite value.
    void set_damping(BodyId id, Real linear, Real angular);
    bool allow_sleep(BodyId id) const;
    const Shape& shape(BodyId id) const;
    const Material& material(BodyId id) const;
    /// Friction and restitution take effect from the next step (density only matters at creation and
    /// is kept). Throws RigidError for a negative or non-finite friction or a restitution outside [0, 1].
    void set_material(BodyId id, const Material& m);
    /// Replaces a moving body's shape and (dynamic only) mass properties: `shape` in a body frame whose
    /// origin is the centre of mass, `inertia` about it in that frame. The pose stays where the centre of mass is (the
    /// origin becomes it). For bodies whose shape changes between steps (a soft body's rigid proxy,
    /// coupling/rigid_proxy.hpp): the pair cache computes such a body's manifolds afresh, and its
    /// inverse mass and inertia take effect at once, inside a step too. Throws RigidError (nothing
    /// changed) for a static body, a shape a dynamic body cannot carry, a mass <= 0 or an inertia
    /// that is not finite, symmetric and positive definite.
    void reshape(BodyId id, const Shape& shape, Real mass, const Mat3& inertia);
    /// Bodies a and b never collide while `ignore` holds (a soft body's proxy and the bodies the soft body
    /// is attached to). Forgotten when either body is destroyed. Throws RigidError for a bad id.
    void ignore_pair(BodyId a, BodyId b, bool ignore);
    /// Called once per touching manifold each step, after collision detection and before the solve, on
    /// the thread that steps the world, in the contacts' order (sorted by body pair): deterministic. A
    /// contact it disables has no points for the rest of the step (the solvers, islands and contact
    /// queries skip it) and starts the next step cold. It must not create, destroy or move bodies. An empty
    /// function removes it.
    void set_pre_solve(PreSolveFn fn) { pre_solve_ = std::move(fn); }
    const CollisionFilter& filter(BodyId id) const;
    /// Takes effect at the next step's broad phase: pairs it now excludes lose their contacts then, pairs
    /// it now admits are found (the body is woken, so a resting pair meets again).
    void set_filter(BodyId id, const CollisionFilter& filter);
    const CollisionFilter& slot_filter(std::uint32_t slot) const { return filter_[slot]; }
    /// Changes the body's type (Box2D's b2Body_SetType), keeping its origin's pose: a dynamic body gets
    /// the mass properties it was created with (its mass, or its material's density); a static one
    /// stops. The bodies it touched are woken, its pairs found afresh at the next step. Throws
    /// RigidError (nothing changed) for a shape only a static body may have.
    void set_type(BodyId id, BodyType type);
    /// Takes the body out of the simulation (false) or puts it back (true), as Box2D's b2Body_Disable:
    /// a disabled body keeps its pose, has no contacts, is found by no query, sensor or soft collision,
    /// is not moved by gravity or its joints (which are not solved meanwhile) and stays asleep whatever
    /// touches it; its velocity is zeroed. Enabled again it is awake. The bodies it touched are woken.
    void set_enabled(BodyId id, bool enabled);
    bool enabled(BodyId id) const;
    bool slot_enabled(std::uint32_t slot) const { return enabled_[slot] != 0; }
    /// A sensor (BodyDef::sensor): it is in the broad phase for the sensor queries only.
    bool is_sensor(BodyId id) const;
    /// Whether continuous collision treats the body as a bullet (BodyDef::bullet); set_bullet changes it
    /// (ignored for a body that is not dynamic, which cannot be one). Throws RigidError for a bad id.
    bool is_bullet(BodyId id) const;
    void set_bullet(BodyId id, bool bullet);
    bool slot_sensor(std::uint32_t slot) const { return sensor_[slot] != 0; }
    /// The live sensors' slots, ascending.
    const std::vector<std::uint32_t>& sensor_slots() const { return sensor_slots_; }
    bool awake(BodyId id) const;
    /// Dynamic bodies awake now.
    std::size_t awake_count() const;
    void wake(BodyId id);
    /// Puts a dynamic body's island (as of the last step) to sleep now, velocities zeroed, whether or not
    /// automatic sleeping is on (Box2D's b2Body_SetAwake(false)): it stays asleep until something wakes
    /// it (a contact with an awake body, wake(), a change made to it). Throws RigidError for a body
    /// that is not dynamic.
    void sleep(BodyId id);
    /// The centre of mass in the body's frame (m; zero for static and kinematic bodies).
    Vec3 local_center(BodyId id) const;
    /// The inertia about the centre of mass in the body's axes (kg m^2; zero unless dynamic).
    const Mat3& inertia_local(BodyId id) const;
    std::uint64_t user_data(BodyId id) const;

    // ---- joints (rigid/joint.hpp) ---------------------------------------------------------------------
    JointId create_joint(const JointDef& def);  ///< validates; throws RigidError and changes nothing
    void destroy_joint(JointId id);
    JointSet& joints() { return *joints_; }
    const JointSet& joints() const { return *joints_; }
    /// Joints that broke during the last step.
    const std::vector<JointId>& broken_joints() const;

    // ---- rows from outside the manifolds (rigid/constraint_rows.hpp) ---------------------------------
    /// Adds a source of constraint rows that every solver solves in each of its iterations, before the
    /// contacts, after the joints and the sources added earlier (a coupling layer's particle contacts, a
    /// proxy's rows). Not owned: remove it before it is destroyed. Throws RigidError if it is null or
    /// already added.
    void add_rows(ConstraintRows* rows);
    /// Removes a source added by add_rows (nothing happens if it is not there).
    void remove_rows(ConstraintRows* rows);
    /// The sources in solve order: the joints first.
    const std::vector<ConstraintRows*>& row_sources() const { return row_sources_; }

    // ---- queries (rigid/rigid_queries.cpp); all bodies but sensors count, asleep or not -------------
    struct RayResult {
        BodyId body;
        RayHit hit;
    };
    /// The closest body the segment from -> to enters. False if none. Throws RigidError for a non-finite
    /// point. With `filter`, only bodies that would collide with a body of that filter count
    /// (should_collide: a group < 0 skips one's own ragdoll, a mask picks categories).
    bool ray_cast(const Vec3& from, const Vec3& to, RayResult& out) const;
    bool ray_cast(const Vec3& from, const Vec3& to, const CollisionFilter& filter, RayResult& out) const;
    /// Every body the segment enters, one hit each (its entry), by fraction then slot (replaces out).
    void ray_cast_all(const Vec3& from, const Vec3& to, const CollisionFilter& filter, std::vector<RayResult>& out) const;
    struct ShapeCastResult {
        BodyId body;
        ShapeCastHit hit;
    };
    /// Sweeps `shape` (a sphere, box, capsule, hull or compound) from `xf` along `translation`, keeping its
    /// rotation, and finds the first body it touches (engine/core/shape_cast.hpp: within kCastTolerance of
    /// the exact time of impact; ties go to the lower slot). A shape already overlapping a body at the
    /// start hits it at fraction 0. Throws RigidError for a non-finite transform or translation or a
    /// shape that cannot be cast.
    bool shape_cast(const Shape& shape, const Transform& xf, const Vec3& translation, const CollisionFilter& filter,
                    ShapeCastResult& out) const;
    /// The closest points of `shape` at `xf` and body `id`'s shape, if they are at most `max_distance`
    /// apart (negative distance: overlapping). Throws RigidError as shape_cast, and for a bad id.
    bool closest_points(const Shape& shape, const Transform& xf, BodyId id, Real max_distance, ClosestPoints& out) const;
    /// Bodies whose shapes' world bounds overlap `box`, in slot order (replaces out's contents).
    void overlap_aabb(const Aabb& box, std::vector<BodyId>& out) const;
    /// Bodies whose shapes overlap (or touch) `shape` placed at `xf`, in slot order. The query shape must
    /// be a sphere, box, capsule, hull or compound (throws RigidError otherwise).
    void overlap_shape(const Shape& shape, const Transform& xf, std::vector<BodyId>& out) const;

    /// Calls f(slot) for every live body but the sensors whose fattened broad-phase box overlaps `box`
    /// (coupling layers find the rigid shapes near a soft body this way).
    template <class F>
    void query_bodies(const Aabb& box, F&& f) const {
        tree_.query(box, [&](std::int32_t proxy) {
            const std::uint32_t slot = tree_.user_data(proxy);
            if (!sensor_[slot]) f(slot);
            return true;
        });
    }
    /// The same, sensors included (the sensor queries).
    template <class F>
    void query_all_bodies(const Aabb& box, F&& f) const {
        tree_.query(box, [&](std::int32_t proxy) {
            f(tree_.user_data(proxy));
            return true;
        });
    }
    /// Body origin transform by slot (no check), for coupling layers.
    Transform slot_transform(std::uint32_t slot) const { return origin_transform(slot); }
    /// Where body `slot` will be after moving t seconds with its current velocities (no check): the
    /// end-of-step pose a coupling layer predicts with t = unintegrated_time().
    Transform predicted_transform(std::uint32_t slot, Real t) const;
    /// Seconds of motion the current step still has to integrate into positions with the current
    /// velocities: the step h from IntegrateVelocities until the solve, then h for solvers that integrate
    /// in IntegratePositions and the last sub-step for the soft step (which has integrated the others
    /// inside SolveVelocities), 0 after IntegratePositions. Coupling layers read it from their hooks.
    Real unintegrated_time() const { return unintegrated_time_; }
    /// Whether the solver gives moving bodies the step's gravity and forces inside SolveVelocities, a
    /// sub-step at a time (the soft step, which integrates itself), rather than all at once in
    /// IntegrateVelocities: a coupling hook between the two stages then sees velocities without them.
    bool gravity_in_solve() const;
    /// Shape and material by slot (no check), for coupling layers.
    const Shape& slot_shape(std::uint32_t slot) const { return shape_[slot]; }
    const Material& slot_material(std::uint32_t slot) const { return material_[slot]; }

    /// Kinetic energy of all dynamic bodies (J).
    double kinetic_energy() const;
    /// Deepest penetration among current contacts (m, >= 0).
    Real max_penetration() const;
    /// False if any body's state is NaN or infinite.
    bool all_finite() const;

    /// Contacts found by the last DetectCollisions stage (solver order; impulses after the solve).
    const std::vector<ContactManifold>& contacts() const { return contacts_; }
    /// Indices into contacts(), ascending, of the manifolds this step's solve must see: every pair with a
    /// body awake after detection, and sleeping pairs in the step they fell asleep (a solver clears what
    /// they carried). The rest are pairs of sleeping islands, kept untouched until they wake: a world at
    /// rest costs no manifold work (Box2D v3 keeps them in its sleeping solver sets).
    const std::vector<std::uint32_t>& active_contacts() const { return active_contacts_; }
    /// Moves on whenever active_contacts() may name other manifolds than before, or the same indices
    /// other pairs: while it stands, each listed index holds the same pair of bodies as at the last
    /// change (a solver may keep its colouring; Box2D v3 keeps colours while contacts persist).
    std::uint64_t active_contacts_revision() const { return active_revision_; }
    /// For solvers (accumulated impulses) and coupling layers.
    std::vector<ContactManifold>& mutable_contacts() { return contacts_; }
    /// Runs the broad and narrow phase now (solvers that detect more than once per step call it).
    void detect_contacts_now(Real h) { detect_collisions(h); }
    /// Bodies whose state was not finite at the end of the last step: each was put back where the step
    /// found it, at rest, and its contacts' and joints' accumulated impulses cleared (step_fault.hpp).
    const std::vector<StepFault>& faults() const { return faults_; }
    /// Body type by slot, for solvers.
    BodyType slot_type(std::uint32_t slot) const { return type_[slot]; }

    // ---- hot state, for solvers and coupling layers ---------------------------------------------------
    struct State {
        std::vector<Vec3> x;          ///< centre of mass, world
        std::vector<Quat> q;          ///< orientation
        std::vector<Vec3> v;          ///< linear velocity of the centre of mass
        std::vector<Vec3> w;          ///< angular velocity, world
        std::vector<Real> inv_mass;   ///< 0 for static, kinematic and sleeping bodies in the solve
        std::vector<Mat3> inv_inertia_world;
        std::vector<Vec3> force;      ///< accumulated this step, cleared after integration
        std::vector<Vec3> torque;
    };
    State& state() { return state_; }
    const State& state() const { return state_; }

    /// Gravity, forces and damping into the velocities of moving bodies over h (solvers that sub-step
    /// call it once per sub-step).
    void integrate_velocities(Real h);
    /// The same for the listed slots only, on the calling thread (a solver working through one block of
    /// independent islands at a time).
    void integrate_velocities_of(const std::uint32_t* slots, std::size_t count, Real h);
    /// Body s's orientation turned by angular velocity w over h (solvers that integrate positions call
    /// it): with the gyroscopic term on and an anisotropic body, about w taken at the mid-step
    /// orientation with the angular momentum kept (rigid/rigid_integration.cpp), else about w itself.
    Quat turned(std::uint32_t s, const Vec3& w, Real h) const;
    /// Body s was just turned by a solver between two passes of the same step (the soft step's sub-steps):
    /// its angular velocity follows the rotation with its angular momentum kept, and its world inverse
    /// inertia is turned with it, so impulses of the next pass (computed at the new orientation) land in
    /// the frame the angular velocity is in (rigid/rigid_integration.cpp).
    void follow_turn(std::uint32_t s);
    /// Inverse-mass scales for a contact between slots a and b this step (1 and 1 unless the contact
    /// holds a body up under one more than RigidSettings::contact_mass_ratio times heavier: then the
    /// supporting body's inverse mass and inverse inertia are scaled so the ratio seen by the contact is
    /// that bound; rigid/rigid_support.cpp). Valid from SolveVelocities on.
    void contact_mass_scales(std::uint32_t a, std::uint32_t b, Real& scale_a, Real& scale_b) const {
        scale_a = scale_b = 1;
        if (!support_level_.empty()) support_scales(a, b, scale_a, scale_b);
    }

private:
    /// Whether two bodies may touch at all: neither a sensor, not joined by a joint that filters the pair,
    /// filters agreeing, the pair not ignored (the broad phase's test, rigid_contacts.cpp).
    bool may_touch(std::uint32_t a, std::uint32_t b) const;
    /// Continuous collision after the step (rigid_continuous.cpp): a body whose centre passed into a static
    /// or kinematic body this step is put back where its shape first touched it.
    void continuous_collisions();
    /// Contact-graph levels (support_level_) when some contact pairs two moving bodies whose masses
    /// differ by more than contact_mass_ratio; cleared otherwise.
    void compute_support_levels();
    void support_scales(std::uint32_t a, std::uint32_t b, Real& scale_a, Real& scale_b) const;
    void integrate_velocity(std::uint32_t s, Real h);
    void check(BodyId id, const char* where) const;
    void prepare_mass_state();
    void detect_collisions(Real h);
    bool can_reuse(const Transform& cached, const Transform& now) const;
    /// Pass 3 of detect_collisions for pair i: its cached manifolds carried to this step's poses where
    /// they are in contacts_ (the pair is then kept), or the narrow phase's appended to the worker's list
    /// (pair_work_[i] records where).
    void detect_pair(std::size_t i, Real h, Real margin, int worker);
    /// DetectCollisions inside its parallel region: refit, pairs, passes 1-4 (rigid_contacts.cpp).
    void detect_in_region(Real h);
    /// active_contacts_ from this step's pairs, after the wakes.
    void list_active_contacts();
    /// IntegratePositions inside its parallel region (the solver's finish joins it).
    void integrate_positions_in_region(Real h);
    /// The task system for the per-body stages' regions, or null when the step is too small for helpers.
    const TaskSystem* body_stage_tasks() const;
    /// Whether body s's state is what contain_non_finite accepts (a sleeping or static body always is).
    bool state_is_sound(std::uint32_t s) const;
    void add_fresh_manifolds(std::uint32_t a, std::uint32_t b, const Transform& xa, const Transform& xb,
                             const Transform& relative, std::size_t prev_i, std::size_t prev_end, ManifoldList& fresh,
                             std::vector<ContactManifold>& out) const;
    /// Where shapes are placed for collision detection: current poses, or candidate poses x + h v.
    Transform detection_transform(std::uint32_t slot, Real h) const;
    void solve_velocities(Real h);
    void integrate_positions(Real h);
    /// IntegratePositions, last: puts back the bodies whose state is not finite (faults()).
    void contain_non_finite();
    /// The gyroscopic effect of body s's rotation since its angular velocity was last set (w_frame_): the
    /// world angular momentum kept while the inertia turns (rigid/rigid_integration.cpp).
    void follow_rotation(std::uint32_t s);
    void update_sleep(Real h);
    void wake_island(std::uint32_t slot);
    /// Wakes the islands of the bodies slot s touches (its manifolds), as when it goes away.
    void wake_touching(std::uint32_t s);
    /// Removes slot s's manifolds from this and last step's contacts (it is destroyed or disabled).
    void drop_contacts_of(std::uint32_t s);
    /// Mass properties for a dynamic body of slot s's shape and creation mass or density (throws RigidError).
    MassProperties dynamic_mass_properties(std::uint32_t s, const char* where) const;
    std::uint32_t find_root(std::uint32_t slot);
    Transform origin_transform(std::uint32_t slot) const;

    RigidSettings settings_;
    State state_;
    // cold per-slot data
    Slots slots_;  ///< body slots and generations (engine/core/slots.hpp)
    std::vector<Vec3> start_x_;    ///< state_.x and state_.q at the start of the step (or at creation), to
    std::vector<Quat> start_q_;    ///<   put back a body whose state turned non-finite (contain_non_finite)
    std::vector<StepFault> faults_;
    std::vector<BodyType> type_;
    std::vector<Shape> shape_;
    std::vector<Material> material_;
    std::vector<CollisionFilter> filter_;
    std::vector<std::uint8_t> sensor_;          ///< 1 for a sensor (BodyDef::sensor)
    std::vector<std::uint8_t> bullet_;          ///< 1 for a bullet (BodyDef::bullet)
    std::vector<std::uint8_t> enabled_;         ///< 0 while set_enabled(false): no proxy, asleep
    std::vector<Real> def_mass_;                ///< BodyDef::mass as created (0: from density), for set_type
    std::vector<std::uint32_t> sensor_slots_;   ///< the live sensors, ascending
    std::vector<Real> mass_;
    std::vector<Real> body_inv_mass_;     ///< the body's own inverse mass (0 if not dynamic)
    std::vector<Mat3> inv_inertia_local_;
    std::vector<Mat3> inertia_local_;     ///< about the centre of mass, body axes (zero if not dynamic)
    /// The orientation the angular velocity was last made for (by the solve, the user or the gyroscopic
    /// update): the free motion since then keeps the angular momentum that w had there.
    std::vector<Quat> w_frame_;
    /// 1 if the inertia is the same about every axis (cubes, spheres, regular solids): turning it changes
    /// nothing, so the gyroscopic update is skipped.
    std::vector<std::uint8_t> spherical_inertia_;
    std::vector<Vec3> local_com_;
    /// 1 if reshape() changed the body's shape since the last detection: its cached manifolds are stale.
    std::vector<std::uint8_t> reshaped_;
    std::vector<Real> linear_damping_, angular_damping_, gravity_scale_;
    std::vector<bool> allow_sleep_, awake_;
    std::vector<Real> sleep_timer_;
    std::vector<std::uint64_t> user_data_;
    std::vector<std::int32_t> proxy_;
    std::vector<std::uint32_t> island_;   ///< union-find parent: awake bodies' rebuilt each step by update_sleep(), sleeping islands' kept
    std::vector<Real> island_min_timer_;
    std::vector<std::uint64_t> pair_keys_;
    // The broad phase's pairs are recomputed only when the tree or the joint filter changed since.
    std::uint64_t structure_revision_ = 0;
    std::uint64_t pairs_tree_revision_ = ~std::uint64_t(0), pairs_filter_revision_ = ~std::uint64_t(0);
    std::vector<std::uint64_t> ignored_pairs_;  ///< sorted slot pair keys (ignore_pair)
    bool ignored_changed_ = false;

    DynamicTree tree_;
    std::vector<std::pair<std::int32_t, std::int32_t>> candidate_pairs_;
    std::vector<Transform> detect_xf_;  ///< per slot: where DetectCollisions places the body this step
    std::vector<Mat3> detect_rot_;      ///< its rotation as a matrix
    /// Per slot: detect_xf_ is this step's (set by pass 1's pairs, on any worker; atomics of one byte,
    /// since several pairs mark one body).
    std::unique_ptr<std::atomic<std::uint8_t>[]> detect_placed_;
    std::size_t detect_placed_capacity_ = 0;
    std::vector<std::size_t> sleeping_per_worker_;  ///< pass 1: sleeping pairs found by each worker
    std::vector<Aabb> detect_box_;             ///< per slot: the moving body's box this step (refit)
    std::vector<std::uint8_t> detect_moves_;   ///< per slot: its box left its fat box (re-inserted)
    std::vector<ContactManifold> contacts_;       ///< this step's, sorted by (body pair, sub_key)
    /// Per slot: contacts between the body and an immovable one (0 for those; breadth first), or empty
    /// when no contact needs them this step (compute_support_levels).
    ContactLevels support_level_;
    /// Smallest and largest inverse mass of the dynamic bodies as this step began (prepare_mass_state),
    /// and per worker while it is found.
    std::pair<Real, Real> dynamic_inv_mass_{0, 0};
    std::vector<std::pair<Real, Real>> inv_mass_range_;
    /// A body's mass changed (between steps, or within one after prepare_mass_state): the range takes it
    /// in until the next step finds it anew.
    void widen_inv_mass_range(Real w) {
        if (!(w > 0)) return;
        dynamic_inv_mass_.first = std::min(dynamic_inv_mass_.first, w);
        dynamic_inv_mass_.second = std::max(dynamic_inv_mass_.second, w);
    }
    PreSolveFn pre_solve_;
    /// Manifolds the pre-solve callback disabled this step: index into contacts_ and its point count,
    /// given back (impulses cleared) when the next detection starts, so the contact cache sees them whole.
    std::vector<std::pair<std::uint32_t, int>> disabled_;
    void restore_disabled();
    void apply_pre_solve();
    std::vector<std::uint32_t> active_contacts_;
    std::vector<std::uint32_t> last_active_contacts_;  ///< the list before, to compare with
    std::uint64_t active_revision_ = 0;
    /// Pass 4 put some pair's manifolds at other indices of contacts_ since the list was last made.
    bool layout_moved_ = true;
    /// No pair of this step's detection sleeps (pass 1): the active list is every manifold.
    bool all_pairs_awake_ = false;
    /// Per candidate pair of this step's detection: its cached manifolds (last step's, at their old
    /// place in contacts_ until pass 4), whether it sleeps, the slot it wakes (or kNoSlot), and where its
    /// fresh manifolds went in detect_out_ (first and worker; unused for a kept pair). Kept between steps: while the pair list stands, last step's offset
    /// and count say where a pair's manifolds are, with no search.
    struct PairWork {
        std::uint32_t prev_begin, prev_end;
        std::uint32_t wakes;
        std::uint32_t first, count;
        std::uint32_t offset;  ///< where its manifolds go in contacts_
        std::uint32_t stored;  ///< how many it has there after pass 4
        int worker;
        bool asleep;
        /// Its manifolds stay in contacts_ where the last step left them (asleep, or carried in place
        /// by the body-pair cache); pass 4 moves them only if the pairs before changed their counts.
        bool kept;
        bool left_asleep;      ///< a sleeping pair this step, out of the active contacts from the next one
        bool was_left_asleep;  ///< left_asleep as the last step ended (the active list reads this)
    };
    /// pair_work_ describes contacts_ as it is (false after a body's contacts were dropped).
    bool pair_layout_valid_ = false;
    /// A body woke since active_contacts_ was listed: list it again before the solve reads it.
    bool active_stale_ = false;
    void refresh_active_contacts() {
        if (active_stale_) list_active_contacts();
    }
    /// Pass 4: the manifolds of kept pairs (PairWork::kept) moved to their new offsets within contacts_.
    void move_kept_manifolds();
    static constexpr std::uint32_t kNoSlot = 0xFFFFFFFFu;
    std::vector<PairWork> pair_work_;
    std::vector<std::vector<ContactManifold>> detect_out_;  ///< per worker
    std::vector<ManifoldList> detect_scratch_;              ///< per worker: the narrow phase's output
    std::unique_ptr<RigidSolver> solver_;
    std::unique_ptr<JointSet> joints_;
    std::vector<ConstraintRows*> row_sources_;  ///< joints_ first, then add_rows() order
    Real unintegrated_time_ = 0;
    const TaskSystem* tasks_ = nullptr;
    ParallelRegion region_;
};

}  // namespace sinew
