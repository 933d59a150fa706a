// Soft bodies made of particles: Jakobsen/Verlet constraint bodies, mass-spring bodies (cloth, ropes,
// pressure bodies) and tetrahedral FEM solids (docs/fem.md), their definitions, handles and runtime data.
//
// One SoftBody holds its particles, its links (springs for mass-spring methods, distance constraints for
// Verlet), its surface triangles (pressure, rendering), pins, attachments to rigid bodies and long-range
// attachments. The method decides how links act; the same builder output runs under every method, so
// methods can be compared on one scene. Equations: Jakobsen 2003 (Verlet), Baraff & Witkin 1998 (springs,
// implicit Euler), Liu et al. 2013 (fast mass-spring), Matyka & Ollila 2003 (pressure); docs/theory.md.
#pragma once

#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "engine/core/aabb.hpp"
#include "engine/core/collision_filter.hpp"
#include "soft/fem_material.hpp"
#include "soft/particles.hpp"

namespace sinew {

/// Bad user data given to the soft system (a NaN position, a negative mass, a link to a missing particle,
/// an unknown handle, ...). The message names the value and where it is.
struct SoftError : std::invalid_argument {
    using std::invalid_argument::invalid_argument;
};

/// How a body's links act and how its particles are advanced.
enum class SoftMethod : std::uint8_t {
    Verlet,             ///< Jakobsen 2003: Verlet integration, links relaxed as distance constraints
    ExplicitEuler,      ///< springs, FEM; x += h v_n, v += h a(x_n, v_n) (unstable undamped at any h)
    SemiImplicitEuler,  ///< springs, FEM; v += h a(x_n, v_n), x += h v_{n+1} (stable iff omega h < 2)
    ImplicitEuler,      ///< springs, FEM; Baraff-Witkin 1998, one Newton step solved by preconditioned CG
    FastMassSpring,     ///< springs and linear tets: Liu 2013 / Bouaziz 2014 local/global, a sparse Cholesky factored once
    Count
};
const char* soft_method_name(SoftMethod m);
/// Explicit, semi-implicit or implicit Euler: the methods that read the force models (FEM needs one).
inline bool is_force_based(SoftMethod m) {
    return m == SoftMethod::ExplicitEuler || m == SoftMethod::SemiImplicitEuler || m == SoftMethod::ImplicitEuler;
}
/// The methods a body with tets may use: the force-based ones, whose FEM force model is stiffness-warped
/// elements, and fast-ms, which on tets is projective dynamics (Bouaziz 2014; soft/fast_mass_spring.cpp).
inline bool accepts_tets(SoftMethod m) { return is_force_based(m) || m == SoftMethod::FastMassSpring; }
/// Parses "verlet", "explicit", "semi-implicit", "implicit", "fast-ms"; returns false if unknown.
bool parse_soft_method(const char* text, SoftMethod& out);

/// What a link stands for in a cloth (for stretch statistics and per-kind stiffness).
enum class LinkKind : std::uint8_t { Structural, Shear, Bend, Other };

/// A spring (mass-spring methods) or a distance constraint (Verlet) between particles a and b.
struct Link {
    std::uint32_t a = 0, b = 0;
    Real rest = 1;            ///< rest length (m), > 0
    Real stiffness = 1000;    ///< k_s (N/m), mass-spring methods
    Real damping = 0;         ///< k_d (N s/m) along the link, mass-spring methods
    // Verlet (Jakobsen) only:
    Real fraction = 1;        ///< stiffness fraction k in (0, 1] applied per relaxation
    Real min_length = 0;      ///< inequality constraint: acts only when the length leaves
    Real max_length = 0;      ///<   [min_length, max_length]; equality when both equal rest
    std::uint16_t max_iterations = 0;  ///< relax only in the first N iterations (softer); 0 = all
    LinkKind kind = LinkKind::Structural;
};

/// Unilateral max-distance constraint of a particle to a pinned particle (Kim, Chentanez, Müller 2012;
/// seed 004): |x_particle - x_anchor| <= max_length. The cheap cure for stretchy Gauss-Seidel cloth.
struct LongRangeAttachment {
    std::uint32_t particle = 0;
    std::uint32_t anchor = 0;  ///< a pinned particle
    Real max_length = 0;       ///< m: the rest distance to the anchor (geodesic in the rest mesh)
};

/// A particle following a point of a rigid body (kinematic: the particle's inverse mass is 0).
/// `target` is opaque to the soft layer (the world stores a packed rigid BodyId); the layer that owns
/// the rigid system writes `frame` and `frame_com`/`v`/`w` before each step.
struct Attachment {
    std::uint32_t particle = 0;
    std::uint64_t target = 0;
    Vec3 local_point = Vec3::Zero();  ///< in the target body's frame
    Transform frame;                  ///< the target's body frame, written each step
    Vec3 frame_com = Vec3::Zero();
    Vec3 frame_v = Vec3::Zero();
    Vec3 frame_w = Vec3::Zero();
    bool frame_valid = false;         ///< false once the target is gone: the particle stays where it is
};

/// CG's preconditioner in implicit Euler (SoftBodyDef::preconditioner).
enum class SoftPreconditioner : std::uint8_t {
    BlockJacobi,  ///< each particle's 3x3 diagonal block, inverted (any body)
    RestFactor,   ///< FEM bodies: the rest shape's system factored once, turned with the nodes
    Count
};
const char* soft_preconditioner_name(SoftPreconditioner p);
/// Parses "block-jacobi" or "rest-factor"; false if unknown.
bool parse_soft_preconditioner(const std::string& text, SoftPreconditioner& out);

/// The order of Verlet's relaxation sweeps over the links (SoftBodyDef::relaxation).
enum class SoftRelaxation : std::uint8_t {
    InOrder,   ///< Gauss-Seidel in the builder's order: a pin's pull goes down a cloth in one sweep
    ByColour,  ///< colour by colour (no two links of a colour share a particle), each colour on the workers
    Count
};
const char* soft_relaxation_name(SoftRelaxation r);
/// Parses "in-order" or "by-colour"; false if unknown.
bool parse_soft_relaxation(const std::string& text, SoftRelaxation& out);

struct SoftBodyDef {
    SoftMethod method = SoftMethod::Verlet;
    // geometry (builders in soft/soft_builders.hpp fill these)
    std::vector<Vec3> positions;            ///< m, world
    std::vector<Real> masses;               ///< kg per particle (> 0), same size as positions
    std::vector<Link> links;
    std::vector<std::uint32_t> triangles;   ///< 3 per triangle, counter-clockwise seen from outside
    /// Tetrahedral FEM (soft/tet_mesh.hpp): 4 (or 10, see tet_order) particles per tet, positively oriented, the positions the
    /// rest shape. A body with tets is an FEM body: its elements are a force model of the force-based
    /// methods (explicit, semi-implicit, implicit), and fast-ms steps linear ones by projective dynamics;
    /// `triangles` should be its boundary (the builder sets it).
    std::vector<std::uint32_t> tets;
    /// FEM: 1 for linear tets (4 particles each), 2 for quadratic tets (10 each: the corners, then the
    /// midpoints of the edges (0 1) (1 2) (0 2) (0 3) (1 3) (2 3); soft/tet_mesh.hpp), which bend without
    /// locking. Plasticity needs order 1.
    int tet_order = 1;
    /// FEM: the rest shape, one per particle; empty = `positions` (a saved, deformed body gives both).
    std::vector<Vec3> rest_positions;
    /// FEM: each tet's plastic strain to start from; empty = none (a saved plastic body gives it).
    std::vector<Strain6> plastic_strain;
    std::vector<std::uint32_t> pinned;      ///< particles fixed in space (inverse mass 0)
    std::vector<Attachment> attachments;    ///< particles following rigid bodies
    Vec3 initial_velocity = Vec3::Zero();

    // solver
    int iterations = 10;        ///< Verlet relaxations, CG iteration cap, fast-ms local/global iterations
    Real cg_tolerance = Real(1e-4);  ///< implicit: relative residual at which CG stops
    Real isotropic_blend = 0;   ///< implicit: Volino's blend, 0 = anisotropic spring Jacobian, 1 = isotropic
    Real implicit_lambda = 1;   ///< implicit: 1 = backward Euler, 0.5 = implicit midpoint (Volino's λ)
    bool long_range_attachments = false;  ///< add LRA constraints to the pins (any method)
    /// implicit FEM bodies: CG's preconditioner. RestFactor factors the rest shape's system once and turns
    /// it with the nodes (soft/fem_rest_factor.hpp): for stiff solids, where block Jacobi runs to its cap.
    SoftPreconditioner preconditioner = SoftPreconditioner::BlockJacobi;
    /// Verlet: the order of the relaxation's sweeps over the links. ByColour changes the method's
    /// results (a sweep carries a pull one link per colour, not down the cloth) and lets a large body's
    /// sweeps run on the workers (docs/soft-bodies.md, "Verlet by colour").
    SoftRelaxation relaxation = SoftRelaxation::InOrder;

    // material
    Real drag = 0;              ///< velocity damping (1/s): v *= 1/(1 + h drag); Verlet uses it as k_d = h drag
    Real pressure = 0;          ///< Matyka's P_c (N m = J), needs a closed triangle surface; 0 = none
    Real friction = Real(0.5);  ///< particle-collider Coulomb coefficient
    Real restitution = 0;       ///< [0, 1]
    Real thickness = Real(0.01);  ///< particle radius for collisions (m), > 0
    /// The body's particles meet its own triangles too (cloth folding on itself; soft/soft_contacts.hpp),
    /// all but those within one edge of the particle.
    bool self_collision = false;
    Real gravity_scale = 1;
    /// Which rigid bodies the particles meet (their colliders' filters; engine/core/collision_filter.hpp).
    CollisionFilter filter;
    FemMaterial fem;            ///< the elements' material, read when the body has tets
    bool allow_sleep = true;
    std::uint64_t user_data = 0;
};

/// Generational handle, as BodyId (zero generation = null).
struct SoftBodyId {
    std::uint32_t index = 0;
    std::uint32_t generation = 0;
    bool is_null() const { return generation == 0; }
    bool operator==(const SoftBodyId& o) const { return index == o.index && generation == o.generation; }
    bool operator!=(const SoftBodyId& o) const { return !(*this == o); }
};

struct ImplicitEulerCache;   // soft/implicit_euler.cpp
class ParallelRegion;        // engine/core/task_system.hpp
struct FastMassSpringCache;  // soft/fast_mass_spring.cpp
struct FemState;             // soft/fem_elements.hpp

/// A live soft body. Integrators and the soft system work on it directly.
struct SoftBody {
    SoftBody();
    ~SoftBody();
    SoftBody(SoftBody&&) noexcept;
    SoftBody& operator=(SoftBody&&) noexcept;

    SoftBodyDef def;            ///< settings as created (geometry vectors emptied after creation)
    Particles p;
    std::vector<Link> links;
    std::vector<std::uint32_t> triangles;
    std::vector<LongRangeAttachment> lra;
    /// Verlet by colour: the links grouped by colour (no two links of a colour share a particle), each
    /// colour's in ascending order, and the links' ends they were built for (2 per link): built on the
    /// body's first such step, again whenever a link's ends change.
    std::vector<std::uint32_t> colour_start, colour_links, coloured_ends;
    std::vector<Attachment> attachments;
    Real rest_volume = 0;       ///< m^3 of the closed surface at creation (0 if not closed)
    bool closed_surface = false;  ///< the triangles close a volume (soft-soft contacts know inside from outside)
    /// Per particle, the contact the last step's contact pass found: its unit normal (zero: none) and the
    /// collider's velocity along it there (m/s). Implicit Euler holds these particles' normal velocity
    /// in its solve (Baraff & Witkin 1998's constraint filter); empty until the first contact pass.
    std::vector<Vec3> contact_normal;
    std::vector<Real> contact_speed;
    /// Per particle, the normal velocity change (m/s, >= 0) the solve's contact constraint gave it this
    /// step: the contact pass adds it to its Coulomb friction budget (mu times the normal change), since
    /// the solve, not the pass, stopped the particle. Empty: none.
    std::vector<Real> contact_dvn;
    /// Per particle, with contact_normal: the owner of the collider it touched (Collider::owner), for a
    /// two-way coupling layer's rigid bodies in the solve (contact_rigid below).
    std::vector<std::uint32_t> contact_owner;
    /// Implicit Euler holds this body's contacts in its solve (recorded by the contact pass). Always for
    /// FEM bodies; for mass-spring bodies when a two-way coupling layer asks (its rigid bodies join the solve through the recorded contacts).
    bool hold_contacts = false;
    /// A dynamic rigid body a two-way coupling layer joins to this body's implicit Euler solve
    /// (soft/implicit_euler.cpp, "Rigid bodies in the solve"): its velocity and inertia become unknowns of
    /// the same linear system, tied to the particles that touch it (contact_rigid).
    struct CoupledRigid {
        Vec3 com = Vec3::Zero();  ///< centre of mass at the start of the step
        Vec3 v = Vec3::Zero();    ///< velocity at the start of the step, the step's gravity included
        Vec3 w = Vec3::Zero();    ///< angular velocity at the start of the step
        Real mass = 0;            ///< kg
        Mat3 inertia = Mat3::Zero();  ///< world inertia tensor (kg m²)
        bool rotates = false;     ///< false: the rotation is locked (its inverse inertia singular) and stays
        std::uint32_t owner = 0;  ///< the body's Collider::owner (its rigid slot)
        Vec3 dv = Vec3::Zero();   ///< written by the solve: the change of v it found
        Vec3 dw = Vec3::Zero();   ///< written by the solve: the change of w it found
        Vec3 point_velocity(const Vec3& arm) const { return v + w.cross(arm); }
        Vec3 end_point_velocity(const Vec3& arm) const { return v + dv + (w + dw).cross(arm); }
    };
    /// Set by a two-way coupling layer before the step (empty: none): the bodies, and per particle the one
    /// it is tied to (an index into coupled_rigids, or kNoRigid) and how: contact_stick 1 in all three
    /// directions (an attached particle, or a contact where friction holds), 0 along contact_normal only
    /// (no friction, a tie new this step, or one sliding: its impulse left the friction cone). An attached particle (inverse mass 0)
    /// tied to its target joins the solve instead of being held (two-way attachments).
    /// contact_tie_impulse then reports the impulse the body gave each tied particle in the solve, for
    /// the layer to take from the body.
    static constexpr std::uint32_t kNoRigid = ~std::uint32_t(0);
    std::vector<CoupledRigid> coupled_rigids;
    std::vector<std::uint32_t> contact_rigid;
    std::vector<std::uint8_t> contact_stick;
    /// Per tied particle: the arm of the point it moves with, from the body's centre of mass (the
    /// particle's position; for an attached particle its attachment point on the body at the start of the
    /// step, where the particle itself already stands at the body's predicted pose).
    std::vector<Vec3> contact_arm;
    /// Per tied particle: its distance to the body's surface beyond its thickness at the start of the step
    /// (m, < 0: inside); the solve closes it along the normal within the step.
    std::vector<Real> contact_gap;
    /// Per particle tied along the normal only: the kinetic friction impulse the body gives it this step
    /// (N s, across the normal; zero: none), the body taking the opposite.
    std::vector<Vec3> contact_friction;
    std::vector<Vec3> contact_tie_impulse;
    /// One per attachment when a coupling layer asks for them (sized to `attachments`; empty: not asked):
    /// the impulse (N s) holding the attached particle on its target took in the last solve (implicit
    /// Euler fills it), whose opposite a hybrid or interleaved layer sends back to the rigid body.
    std::vector<Vec3> attachment_impulse;
    /// Set by a coupling layer before the step (one-solver coupling): the body's links are rows of the rigid
    /// solver this step, and its method only predicts (soft/soft_methods.hpp, soft_stages_of).
    bool solved_by_rows = false;
    /// Set by a coupling layer (embedding, coupling/rigid_embedding.hpp): the body meets the colliders
    /// through its rigid proxy only, so its own contact pass has no colliders.
    bool meets_colliders_through_proxy = false;
    /// Set by a coupling layer (coupling/fem_embedding.hpp) on the FEM proxy of a rigid body: it meets no
    /// collider (its rigid body meets those), only soft bodies, and of those only `soft_partners` (slots)
    /// if that is not empty.
    bool meets_soft_bodies_only = false;
    std::vector<std::uint32_t> soft_partners;
    /// Set by the same layer: in the soft-soft contact pass this body moves as one rigid body (the limit of
    /// Parker's very stiff proxy), of this inverse mass and world inverse inertia about `com`, starting at
    /// (v, w); the pass adds what it gave the body to `impulse` and `angular_impulse` (about com).
    struct RigidMotion {
        bool active = false;
        Real inv_mass = 0;
        Mat3 inv_inertia = Mat3::Zero();
        Vec3 com = Vec3::Zero(), v = Vec3::Zero(), w = Vec3::Zero();
        Vec3 impulse = Vec3::Zero(), angular_impulse = Vec3::Zero();
    } as_rigid;
    /// Set by the same layer on a soft body: rigid bodies (slots) whose colliders it ignores, since their
    /// FEM proxies meet it instead.
    std::vector<std::uint32_t> ignored_owners;
    /// Set by the same layer for a body whose proxy is dynamic: the proxy's rigid island decides when the
    /// body sleeps (SoftSystem::put_to_sleep), not the soft system's own thresholds.
    bool sleeps_with_proxy = false;
    /// Set by a coupling layer during a step: the body may not start to sleep at its end (a rigid body it
    /// carries is still awake); cleared by the sleep update.
    bool kept_awake = false;
    Vec3 gravity = Vec3::Zero();  ///< acceleration applied this step (world gravity × gravity_scale)
    bool awake = true;
    bool stepping = false;      ///< advanced by the step in progress (awake at its IntegrateVelocities)
    Aabb sleep_box;             ///< while asleep: its particles' box fattened by the thickness
    Real sleep_timer = 0;
    std::unique_ptr<ImplicitEulerCache> implicit_cache;
    /// The soft system's parallel region while it steps the body: a method's large loops (FEM's element
    /// loop and stiffness product, fast mass-spring's loops and solves, implicit Euler's CG) may split
    /// across its workers; outside the region's run they run on one thread.
    ParallelRegion* region = nullptr;
    std::unique_ptr<FastMassSpringCache> fms_cache;
    /// Contacts with other soft bodies held inside this step's solve as planes n · x_particle >= offset
    /// (the particle's own thickness not yet added), from SoftContactPass::gather_planes.
    struct SoftPlane {
        std::uint32_t particle = 0;
        Vec3 normal = Vec3::UnitY();
        Real offset = 0;
    };
    std::vector<SoftPlane> soft_planes;
    /// Per particle: did the last soft-soft pass (SoftContactPass::run) give it an impulse or a push? Such
    /// particles keep the contact pass's projection against colliders in the next step (implicit Euler's
    /// filter drops them, SoftSystem::solve_velocities). Empty when the pass touched none of the body's.
    std::vector<std::uint8_t> soft_touched;
    /// Does the method hold soft-soft contacts inside its solve (fast mass-spring without tets)?
    bool holds_soft_planes() const { return def.method == SoftMethod::FastMassSpring && !fem; }
    /// The tets' rest data, rotations, plastic strain and warped stiffness (null without tets).
    std::unique_ptr<FemState> fem;

    /// Signed volume enclosed by the triangles (divergence theorem), m^3.
    Real volume() const;
    /// Largest current/rest length ratio over structural and shear links (1 = unstretched).
    Real max_stretch() const;
    Real kinetic_energy() const;
};

}  // namespace sinew
