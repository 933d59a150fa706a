/*
 * sinew.h - the C API of Sinew, rigid/deformable multi-physics middleware for games.
 *
 * C99, no C++ in this header; only sinew_-prefixed symbols are exported from libsinew.so.
 *
 * Conventions
 * - Units: metres, kilograms, seconds, radians; forces in newtons, impulses in newton-seconds.
 * - Handles are values: {world, index, generation}. A zero generation is the null handle. A stale handle
 *   (its object was destroyed) or a foreign one (another world's) is detected and rejected with
 *   SINEW_ERROR_STALE_ID, never dereferenced.
 * - Every call that can fail returns a sinew_status; sinew_last_error() then names the function, the
 *   argument and the value. A rejected call leaves the world exactly as it was.
 * - Definitions have defaults: start from sinew_*_def_default() and change what you need.
 * - Enum fields are checked: a value outside the enum (a C caller can store any int) is rejected.
 * - The API is single precision (float) whatever Real the library was built with.
 *
 * Threading contract
 * - A world, and every body, soft body and joint in it, is used by one thread at a time: calls on the
 *   same world must not overlap (serialise them yourself if several threads touch one world).
 * - Different worlds may be used from different threads at the same time, with no locking on your side:
 *   worlds share no mutable state. sinew_world_create, sinew_world_create_from_scene_file and
 *   sinew_world_destroy may be called concurrently from any threads (the registry of worlds is locked).
 * - sinew_last_error() is per thread: it reports the last failed call made by the calling thread.
 * - sinew_version() may be called from any thread at any time.
 * - sinew_set_log_callback() and sinew_set_allocator() may be called from any thread; the log callback is
 *   called on the thread whose call produced the message, so it may run on several threads at once if
 *   several worlds are used concurrently. A world keeps the allocator it was created with.
 * - While a world steps, calls that change it are rejected with SINEW_ERROR_IN_STEP (this can only happen
 *   from inside a callback: the log callback or the allocator hooks). Reading calls are allowed.
 * - A step may use several threads (sinew_world_def.worker_count): your own job system's, through
 *   enqueue_task/finish_task (then Sinew never creates a thread), or a small pool the world starts. The
 *   calls above still come from one thread at a time; the step returns when all its work is done, and
 *   the result is bit-identical for every worker count.
 */
#ifndef SINEW_H
#define SINEW_H

#include <stddef.h>
#include <stdint.h>

#if defined(_WIN32)
/* Building the library exports; a program using the DLL imports; define SINEW_STATIC when linking the
 * static library (sinew::sinew does it for you). */
#if defined(SINEW_BUILDING)
#define SINEW_API __declspec(dllexport)
#elif defined(SINEW_STATIC)
#define SINEW_API
#else
#define SINEW_API __declspec(dllimport)
#endif
#else
#define SINEW_API __attribute__((visibility("default")))
#endif

#ifdef __cplusplus
extern "C" {
#endif

typedef enum sinew_status {
    SINEW_OK = 0,
    SINEW_ERROR_NULL_ARGUMENT = 1,    /* a required pointer was NULL */
    SINEW_ERROR_INVALID_ARGUMENT = 2, /* NaN, negative mass, degenerate shape, out-of-range enum, ... */
    SINEW_ERROR_STALE_ID = 3,         /* null, destroyed or foreign handle */
    SINEW_ERROR_IN_STEP = 4,          /* the world is stepping */
    SINEW_ERROR_INTERNAL = 5,         /* out of memory or a bug: the message says which */
    SINEW_ERROR_SCENE = 6,            /* a scene file is missing, malformed or invalid: the message names the
                                         file and the JSON pointer of the offending value */
    SINEW_ERROR_NON_FINITE = 7        /* a step: a body's state turned non-finite (a method past its stability
                                         limit, a motor beyond what the solver holds); it was put back where
                                         the step found it, at rest, and the world steps on. The log has one
                                         error line per body naming it, the step and the method's limit */
} sinew_status;

typedef struct sinew_vec3 { float x, y, z; } sinew_vec3;
typedef struct sinew_quat { float x, y, z, w; } sinew_quat; /* unit quaternion, w last */
typedef struct sinew_transform { sinew_vec3 p; sinew_quat q; } sinew_transform;

typedef struct sinew_world_id { uint32_t index; uint32_t generation; } sinew_world_id;
/* `world` is opaque (the world's index and generation); a body handle is only valid for its world. */
typedef struct sinew_body_id { uint32_t world; uint32_t index; uint32_t generation; } sinew_body_id;

typedef enum sinew_solver {
    SINEW_SOLVER_SOFT_STEP = 0,     /* sequential impulses, soft contacts with sub-steps (default) */
    SINEW_SOLVER_SPLIT_IMPULSE = 1, /* sequential impulses, split-impulse position correction */
    SINEW_SOLVER_BAUMGARTE = 2,     /* sequential impulses, Baumgarte position correction */
    SINEW_SOLVER_NEWTON = 3         /* Guendelman 2003 Newtonian impulses */
} sinew_solver;

/* The host's job system (the shape of Box2D v3's task callbacks). Sinew calls enqueue_task with tasks
   of one item, up to worker_count - 1 per parallel part of a step, and runs its own share on the calling
   thread. The work never waits for a task to start: a task may run late, on any worker, or inline inside
   enqueue_task on the calling thread. But at the end of each part Sinew calls finish_task for each task,
   so finish_task must see it run: run it there if no worker has started it (a finish that only waits can
   deadlock when every worker is busy). enqueue_task must not wait for the task unless it runs it on the
   calling thread. Workers must use the calling thread's floating-point mode (rounding, flush-to-zero) for
   results to be bit-identical across worker counts. */
typedef void sinew_task_fn(int begin, int end, int worker_index, void* task_context);
/* Runs task over items [0, item_count) in ranges of at least min_range, with worker_index below the
   world's worker_count; returns a handle for finish_task, or NULL if it ran the task before returning. */
typedef void* sinew_enqueue_task_fn(sinew_task_fn* task, int item_count, int min_range, void* task_context,
                                    void* user_context);
/* Returns once the task of handle user_task (never NULL) has run; runs it here if no worker started it. */
typedef void sinew_finish_task_fn(void* user_task, void* user_context);

typedef struct sinew_world_def {
    sinew_vec3 gravity;      /* m/s^2, default (0, -9.81, 0) */
    float time_step;         /* fixed internal step h, s, default 1/60 */
    int max_steps_per_frame; /* accumulator cap, default 8, in [1, 1000] */
    sinew_solver solver;     /* default SINEW_SOLVER_SOFT_STEP */
    int velocity_iterations; /* passes over the constraints per step, default 10 */
    int enable_sleep;        /* 0 or 1, default 1 */
    int worker_count;        /* threads one step may use, the calling one included, in [1, 64]; default 1.
                                Without enqueue_task the world starts worker_count - 1 threads of its own */
    sinew_enqueue_task_fn* enqueue_task; /* your job system, default NULL; with finish_task: no thread is */
    sinew_finish_task_fn* finish_task;   /* created by Sinew, and worker_count is your workers' count */
    void* user_task_context;             /* passed to enqueue_task and finish_task */
} sinew_world_def;

typedef enum sinew_body_type { SINEW_BODY_STATIC = 0, SINEW_BODY_KINEMATIC = 1, SINEW_BODY_DYNAMIC = 2 } sinew_body_type;
typedef enum sinew_shape_type {
    SINEW_SHAPE_SPHERE = 0,
    SINEW_SHAPE_BOX = 1,
    SINEW_SHAPE_CAPSULE = 2,
    SINEW_SHAPE_HULL = 3,    /* the convex hull of `points` (at least 4, not all in a plane) */
    SINEW_SHAPE_PLANE = 4,   /* normal . x = offset, solid below; static bodies only */
    SINEW_SHAPE_MESH = 5,    /* triangles `indices` over the vertices `points`; static bodies only */
    SINEW_SHAPE_COMPOUND = 6 /* several shapes in one body: `children` (no compound inside a compound) */
} sinew_shape_type;

struct sinew_compound_child;

/* A shape in its body's frame (m). Every array is copied when the body is made: it may be freed after. */
typedef struct sinew_shape_def {
    sinew_shape_type type; /* default SINEW_SHAPE_BOX */
    float radius;          /* m: sphere, capsule (default 0.5) */
    float half_height;     /* m: capsule segment half length along local y (default 0.5) */
    sinew_vec3 half_extents; /* m: box (default 0.5, 0.5, 0.5) */
    const sinew_vec3* points; /* hull: points to wrap; mesh: vertices (m) (default NULL) */
    int point_count;          /* hull: >= 4; mesh: >= 3 (default 0) */
    const uint32_t* indices;  /* mesh: 3 vertex indices per triangle (default NULL) */
    int index_count;          /* mesh: a positive multiple of 3 (default 0) */
    sinew_vec3 normal;        /* plane: non-zero, normalised on use (default (0, 1, 0)) */
    float offset;             /* plane: m along the unit normal (default 0) */
    const struct sinew_compound_child* children; /* compound (default NULL) */
    int child_count;          /* compound: >= 1 (default 0) */
} sinew_shape_def;

/* One part of a compound: a shape placed in the body's frame. */
typedef struct sinew_compound_child {
    sinew_transform transform; /* the child's frame in the body's (m; unit quaternion) */
    sinew_shape_def shape;     /* sphere, box, capsule or hull */
} sinew_compound_child;

/** A box of half extents 0.5 m, every other field at its default (the shape of sinew_body_def_default). */
SINEW_API sinew_shape_def sinew_shape_def_default(void);

/* Which bodies may touch (Box2D's rule): two bodies of the same non-zero group_index always collide
 * (> 0) or never (< 0); otherwise each one's category_bits must meet the other's mask_bits. Soft bodies
 * carry one too, matched against the rigid bodies their particles meet. Joined bodies do not collide
 * unless their joint says so (sinew_joint_def.collide_connected). */
typedef struct sinew_filter {
    uint32_t category_bits; /* what this body is (default 1) */
    uint32_t mask_bits;     /* the categories it collides with (default 0xFFFFFFFF: all) */
    int32_t group_index;    /* 0 = none (default) */
} sinew_filter;

/** {1, 0xFFFFFFFF, 0}: category 1, collides with everything; a query filter that sees every body. */
SINEW_API sinew_filter sinew_filter_default(void);

typedef struct sinew_body_def {
    sinew_body_type type;     /* default SINEW_BODY_DYNAMIC */
    sinew_transform transform; /* body origin in the world, default identity */
    sinew_vec3 linear_velocity;  /* m/s, default 0, at most 1e4 m/s (angular: 1e4 rad/s) */
    sinew_vec3 angular_velocity; /* rad/s, default 0 */
    sinew_shape_def shape;
    float mass;               /* kg; 0 = from density (default 0) */
    float density;            /* kg/m^3, default 1000 */
    float friction;           /* Coulomb coefficient, default 0.6 */
    float restitution;        /* [0, 1], default 0 */
    float linear_damping;     /* 1/s, default 0 */
    float angular_damping;    /* 1/s, default 0 */
    sinew_filter filter;      /* default: category 1, collides with everything */
    float gravity_scale;      /* multiplies the world's gravity for this body, finite (default 1) */
    int allow_sleep;          /* 0 or 1 (default 1) */
    int is_sensor;            /* 1: a trigger volume that reports overlaps and touches nothing (no contacts,
                                 not found by queries); its shape must not be a plane or mesh. Any body
                                 type; fixed at creation (default 0). See the sensor events. */
    int is_bullet;            /* 1: continuous collision against dynamic bodies too (projectiles); dynamic
                                 bodies only (default 0). Every fast body gets it against static ones. */
    uint64_t user_data;       /* yours, returned by sinew_body_user_data() */
} sinew_body_def;

/** "MAJOR.MINOR.PATCH (float|double)"; a static string, never NULL. */
SINEW_API const char* sinew_version(void);
/** Message of the last failed call on this thread ("" if none); valid until the next call. */
SINEW_API const char* sinew_last_error(void);

SINEW_API sinew_world_def sinew_world_def_default(void);
SINEW_API sinew_status sinew_world_create(const sinew_world_def* def, sinew_world_id* out);
/** The threads the next steps use, as in sinew_world_def (for a world made from a scene file, say):
 *  worker_count in [1, 64]; enqueue_task and finish_task both NULL (the world's own threads) or both set. */
SINEW_API sinew_status sinew_world_set_workers(sinew_world_id world, int worker_count, sinew_enqueue_task_fn* enqueue_task,
                                               sinew_finish_task_fn* finish_task, void* user_task_context);
SINEW_API sinew_status sinew_world_destroy(sinew_world_id world);
/** Game-loop stepping: adds frame_dt (s, >= 0) to the accumulator and runs whole fixed steps.
 *  steps_taken and alpha (interpolation fraction in [0, 1)) may be NULL and are set on
 *  SINEW_ERROR_NON_FINITE too (the steps were taken). */
SINEW_API sinew_status sinew_world_step(sinew_world_id world, float frame_dt, int* steps_taken, float* alpha);
/** Exactly one fixed step of the world's time_step (SINEW_ERROR_NON_FINITE as sinew_world_step). */
SINEW_API sinew_status sinew_world_step_fixed(sinew_world_id world);
SINEW_API sinew_status sinew_world_body_count(sinew_world_id world, int* out);

/* What a world holds and what its last step cost (for a game's profiler overlay). */
typedef struct sinew_world_counters {
    int body_count;          /* rigid bodies */
    int awake_body_count;    /* dynamic rigid bodies awake */
    int soft_body_count;
    int joint_count;
    int contact_count;       /* touching rigid body pairs' manifolds after the last step */
    int contact_point_count; /* their points */
    uint64_t step_count;     /* fixed steps taken */
    float step_ms;           /* wall time of the last fixed step, ms */
    float stage_ms[4];       /* of it, per stage summed over the systems: integrate velocities, detect
                                collisions, solve velocities, integrate positions (docs/ARCHITECTURE.md) */
} sinew_world_counters;
SINEW_API sinew_status sinew_world_get_counters(sinew_world_id world, sinew_world_counters* out);
/** Bulk read for rendering: up to capacity bodies, in creation order, ids and transforms (either array
 *  may be NULL); *count receives how many were written. No allocation. */
SINEW_API sinew_status sinew_world_get_transforms(sinew_world_id world, sinew_body_id* ids, sinew_transform* transforms,
                                                  int capacity, int* count);

SINEW_API sinew_body_def sinew_body_def_default(void);
SINEW_API sinew_status sinew_body_create(sinew_world_id world, const sinew_body_def* def, sinew_body_id* out);
SINEW_API sinew_status sinew_body_destroy(sinew_body_id body);
SINEW_API sinew_status sinew_body_get_transform(sinew_body_id body, sinew_transform* out);
SINEW_API sinew_status sinew_body_set_transform(sinew_body_id body, const sinew_transform* transform);
SINEW_API sinew_status sinew_body_get_velocity(sinew_body_id body, sinew_vec3* linear, sinew_vec3* angular);
/** For kinematic bodies this is how the game drives them. At most 1e4 m/s and 1e4 rad/s; a static body takes
 *  only a zero velocity (SINEW_ERROR_INVALID_ARGUMENT otherwise: make it kinematic to move it). */
SINEW_API sinew_status sinew_body_set_velocity(sinew_body_id body, sinew_vec3 linear, sinew_vec3 angular);
/** Moves a kinematic (or dynamic) body to `target` (m; its origin's pose) over the next step of time_step
 *  seconds (> 0; the world's fixed step) by setting the velocities that take it there, so what it pushes
 *  or carries moves with it (a moving platform). Call it before each step. The rotation takes the
 *  shorter way. A static body is refused (SINEW_ERROR_INVALID_ARGUMENT), as are speeds past
 *  sinew_body_set_velocity's limits. */
SINEW_API sinew_status sinew_body_set_target_transform(sinew_body_id body, const sinew_transform* target, float time_step);
SINEW_API sinew_status sinew_body_apply_force(sinew_body_id body, sinew_vec3 force, sinew_vec3 world_point);
SINEW_API sinew_status sinew_body_apply_impulse(sinew_body_id body, sinew_vec3 impulse, sinew_vec3 world_point);
SINEW_API sinew_status sinew_body_user_data(sinew_body_id body, uint64_t* out);
/** Wakes the body's island (a sleeping body is not simulated until something wakes it). */
SINEW_API sinew_status sinew_body_wake(sinew_body_id body);
SINEW_API sinew_status sinew_body_get_type(sinew_body_id body, sinew_body_type* out);
/** Changes the body's type, keeping its pose: made dynamic it gets the mass it was created with (or its
 *  density's), made static it stops; the bodies it touched are woken. A plane or mesh stays static
 *  (SINEW_ERROR_INVALID_ARGUMENT). */
SINEW_API sinew_status sinew_body_set_type(sinew_body_id body, sinew_body_type type);
/** 0 takes the body out of the simulation (no contacts, not found by queries and sensors, not moved, its
 *  joints not solved, its velocity zeroed; setting a velocity, a target or a force on it is refused), 1
 *  puts it back awake. The bodies it touched are woken. */
SINEW_API sinew_status sinew_body_set_enabled(sinew_body_id body, int enabled);
SINEW_API sinew_status sinew_body_is_enabled(sinew_body_id body, int* out);
/** Puts the dynamic body's island (the bodies it touched or was jointed to in the last step) to sleep now,
 *  velocities zeroed, even with automatic sleeping off; it stays asleep until something wakes it (an
 *  awake body touching it, sinew_body_wake, a change made to it). SINEW_ERROR_INVALID_ARGUMENT for a
 *  static or kinematic body. */
SINEW_API sinew_status sinew_body_sleep(sinew_body_id body);

typedef struct sinew_mass_data {
    float mass;              /* kg (0 for static and kinematic bodies) */
    sinew_vec3 local_center; /* m: the centre of mass in the body's frame */
    float inertia[9];        /* kg m^2: about the centre of mass, in the body's axes, row-major */
} sinew_mass_data;
SINEW_API sinew_status sinew_body_get_mass_data(sinew_body_id body, sinew_mass_data* out);
/** *out = 1 if the body is awake, 0 if asleep (static bodies report 0). */
SINEW_API sinew_status sinew_body_is_awake(sinew_body_id body, int* out);
/** kg: the dynamic body's mass (0 for static and kinematic bodies). */
SINEW_API sinew_status sinew_body_get_mass(sinew_body_id body, float* out);
/** Multiplies the world's gravity for this body (finite; 0 floats, -1 rises), from the next step. Wakes it. */
SINEW_API sinew_status sinew_body_set_gravity_scale(sinew_body_id body, float scale);
/** 1/s, >= 0: velocity damping, v *= 1 / (1 + h c) each step, from the next step. Wakes the body. */
SINEW_API sinew_status sinew_body_set_damping(sinew_body_id body, float linear, float angular);
/** Takes effect at the next step: contacts of pairs it now excludes are gone after it, pairs it admits
 *  meet (the body is woken). Not during a step (SINEW_ERROR_IN_STEP). */
SINEW_API sinew_status sinew_body_set_filter(sinew_body_id body, sinew_filter filter);
SINEW_API sinew_status sinew_body_get_filter(sinew_body_id body, sinew_filter* out);

/* ==== Soft bodies ====================================================================================
 * Particles joined by links (cloth, ropes, spheres, any triangle mesh) or by tetrahedral elements (FEM
 * solids, below). Rigid bodies push soft bodies and
 * carry their attached particles (one-way coupling); soft bodies do not push rigid ones yet. */

typedef struct sinew_soft_body_id { uint32_t world; uint32_t index; uint32_t generation; } sinew_soft_body_id;

typedef enum sinew_soft_method {
    SINEW_SOFT_VERLET = 0,        /* Jakobsen 2003: Verlet integration, links relaxed as distance constraints */
    SINEW_SOFT_EXPLICIT = 1,      /* springs or FEM, explicit Euler (unstable when undamped: for comparisons) */
    SINEW_SOFT_SEMI_IMPLICIT = 2, /* springs or FEM, symplectic Euler (stable while omega h < 2) */
    SINEW_SOFT_IMPLICIT = 3,      /* springs or FEM, Baraff & Witkin 1998 implicit Euler (one Newton step, CG) */
    SINEW_SOFT_FAST_MS = 4        /* springs, Liu et al. 2013 fast mass-spring (local/global); on linear tets,
                                     Bouaziz et al. 2014 projective dynamics */
} sinew_soft_method;

/* How implicit Euler's conjugate gradient is preconditioned. */
typedef enum sinew_soft_preconditioner {
    SINEW_PRECONDITIONER_BLOCK_JACOBI = 0, /* each particle's 3x3 diagonal block (any implicit body) */
    SINEW_PRECONDITIONER_REST_FACTOR = 1   /* implicit tet bodies: the rest shape's system factored once and
                                              turned with the nodes; for stiff solids, where block Jacobi
                                              runs to the iteration cap (docs/fem.md) */
} sinew_soft_preconditioner;

/* The order of Verlet's relaxation sweeps over the links. */
typedef enum sinew_soft_relaxation {
    SINEW_RELAXATION_IN_ORDER = 0, /* Gauss-Seidel in the builder's order: a pin's pull goes down a cloth in
                                      one sweep */
    SINEW_RELAXATION_BY_COLOUR = 1 /* colour by colour (no two links of a colour share a particle): a large
                                      body's sweeps run on the workers; the results differ (docs/soft-bodies.md) */
} sinew_soft_relaxation;

/* Link material by kind. Mass-spring methods read stretch/shear/bend/damping; Verlet reads fraction. */
typedef struct sinew_soft_links {
    float stretch;  /* N/m, >= 0, structural links (default 1000) */
    float shear;    /* N/m, >= 0, diagonal links (default 1000) */
    float bend;     /* N/m, >= 0, links two apart (default 100) */
    float damping;  /* N s/m, >= 0, along every link (default 0) */
    float fraction; /* Verlet stiffness fraction per relaxation, in (0, 1] (default 1) */
} sinew_soft_links;

typedef struct sinew_soft_def {
    sinew_soft_method method;   /* default SINEW_SOFT_VERLET */
    int iterations;             /* [1, 10000]: Verlet relaxations, CG cap, fast-ms iterations (default 10) */
    float drag;                 /* 1/s, >= 0: velocity damping (default 0) */
    float friction;             /* >= 0, particle-vs-rigid Coulomb coefficient (default 0.5) */
    float restitution;          /* [0, 1] (default 0) */
    float thickness;            /* m, > 0: particle collision radius (default 0.01) */
    float pressure;             /* J (Matyka's P_c), >= 0; needs a closed surface (icosphere, closed mesh).
                                   0 = none (default) */
    int long_range_attachments; /* 0 or 1: Kim et al. 2012 LRA constraints to the pinned particles (default 0) */
    sinew_soft_links links;
    float total_mass;           /* kg, > 0, spread evenly over the particles (default 1) */
    sinew_vec3 velocity;        /* m/s, initial velocity of every free particle (default 0) */
    float gravity_scale;        /* finite (default 1) */
    int allow_sleep;            /* 0 or 1 (default 1) */
    sinew_filter filter;        /* which rigid bodies the particles meet (default: all) */
    int tet_order;              /* tet bodies: 1 = linear (4-node) tets, 2 = quadratic (10-node) tets, which
                                   bend without locking; no plasticity (default 1) */
    sinew_soft_preconditioner preconditioner; /* implicit bodies (default SINEW_PRECONDITIONER_BLOCK_JACOBI) */
    int self_collision;         /* 0 or 1: the particles meet the body's own triangles (a cloth folding on
                                   itself; default 0) */
    uint64_t user_data;         /* yours, returned by sinew_soft_user_data() */
    sinew_soft_relaxation relaxation; /* Verlet bodies (default SINEW_RELAXATION_IN_ORDER) */
} sinew_soft_def;

/* Corners of a cloth grid to pin, combined with |: node (i, j) with i in {0, nx-1}, j in {0, ny-1}. */
enum {
    SINEW_CLOTH_PIN_00 = 1, /* node (0, 0) = origin */
    SINEW_CLOTH_PIN_10 = 2, /* node (nx-1, 0) = origin + edge_u */
    SINEW_CLOTH_PIN_01 = 4, /* node (0, ny-1) = origin + edge_v */
    SINEW_CLOTH_PIN_11 = 8  /* node (nx-1, ny-1) = origin + edge_u + edge_v */
};

/* A rectangular cloth grid; node (i, j) is particle j * nx + i. */
typedef struct sinew_cloth_def {
    int nx, ny;             /* nodes along u and along v, each in [2, 4096] (default 16 x 16) */
    sinew_vec3 origin;      /* m, position of node (0, 0) (default (0, 0, 0)) */
    sinew_vec3 edge_u;      /* m, from node (0, 0) to node (nx-1, 0) (default (2, 0, 0)) */
    sinew_vec3 edge_v;      /* m, from node (0, 0) to node (0, ny-1) (default (0, -2, 0)) */
    int shear;              /* 0 or 1: both diagonals of every quad (default 1) */
    int bend;               /* 0 or 1: links between nodes two apart (default 0) */
    int pinned_corners;     /* SINEW_CLOTH_PIN_* flags (default 0) */
} sinew_cloth_def;

SINEW_API sinew_soft_def sinew_soft_def_default(void);
SINEW_API sinew_cloth_def sinew_cloth_def_default(void);
SINEW_API sinew_status sinew_soft_create_cloth(sinew_world_id world, const sinew_soft_def* def,
                                               const sinew_cloth_def* cloth, sinew_soft_body_id* out);
/** A rope of `segments` (>= 1) links from `from` to `to` (m, distinct): segments + 1 particles. */
SINEW_API sinew_status sinew_soft_create_rope(sinew_world_id world, const sinew_soft_def* def, sinew_vec3 from,
                                              sinew_vec3 to, int segments, sinew_soft_body_id* out);
/** A geodesic sphere: radius > 0 (m), subdivisions in [0, 6] (0: 12 particles, 2: 162, 3: 642). */
SINEW_API sinew_status sinew_soft_create_icosphere(sinew_world_id world, const sinew_soft_def* def, sinew_vec3 center,
                                                   float radius, int subdivisions, sinew_soft_body_id* out);
/** A body from a triangle mesh: vertex_count (> 0) positions (m, world), index_count (a multiple of 3,
 *  >= 3) vertex indices, counter-clockwise seen from outside; links join vertices at graph distance
 *  <= link_distance (1 = edges, 2 adds bend-like links; [1, 3]). The arrays are copied. */
SINEW_API sinew_status sinew_soft_create_mesh(sinew_world_id world, const sinew_soft_def* def,
                                              const sinew_vec3* vertices, int vertex_count, const uint32_t* indices,
                                              int index_count, int link_distance, sinew_soft_body_id* out);
SINEW_API sinew_status sinew_soft_destroy(sinew_soft_body_id body);
SINEW_API sinew_status sinew_soft_particle_count(sinew_soft_body_id body, int* out);
/** Bulk read for rendering: particle positions (m) 0 .. min(capacity, count) - 1 into `positions`;
 *  *count receives how many were written. No allocation. */
SINEW_API sinew_status sinew_soft_get_positions(sinew_soft_body_id body, sinew_vec3* positions, int capacity, int* count);
/** pinned = 1 fixes the particle in space, 0 frees it (an attached particle must be detached first). */
SINEW_API sinew_status sinew_soft_set_pinned(sinew_soft_body_id body, int particle, int pinned);
/** The particle follows `local_point` (m, in the rigid body's frame) of `rigid_body`, which must be in the
 *  same world; the particle is kinematic until detached. Attaching an attached particle retargets it. If
 *  the rigid body is destroyed the particle stays where it was, still kinematic. */
SINEW_API sinew_status sinew_soft_attach(sinew_soft_body_id body, int particle, sinew_body_id rigid_body,
                                         sinew_vec3 local_point);
/** Removes the particle's attachment; the particle is free (not pinned) afterwards. */
SINEW_API sinew_status sinew_soft_detach(sinew_soft_body_id body, int particle);
/** Teleports a particle (m); it gains no velocity. Wakes the body. */
SINEW_API sinew_status sinew_soft_set_particle_position(sinew_soft_body_id body, int particle, sinew_vec3 position);
/** Adds a force (N) on a particle for the next step. Wakes the body. */
SINEW_API sinew_status sinew_soft_apply_particle_force(sinew_soft_body_id body, int particle, sinew_vec3 force);
SINEW_API sinew_status sinew_soft_user_data(sinew_soft_body_id body, uint64_t* out);
/** Which rigid bodies the particles meet, from the next step (the body is woken; an embedded body's proxy
 *  follows). Not during a step. */
SINEW_API sinew_status sinew_soft_set_filter(sinew_soft_body_id body, sinew_filter filter);
SINEW_API sinew_status sinew_soft_get_filter(sinew_soft_body_id body, sinew_filter* out);
SINEW_API sinew_status sinew_world_soft_body_count(sinew_world_id world, int* out);
/** Up to capacity soft body handles, in slot order (creation order in a fresh world, scene file order for
 *  a loaded scene); *count receives how many were written. Neither this nor the counts include the FEM
 *  proxies SINEW_COUPLING_EMBED_FEM makes of rigid bodies. */
SINEW_API sinew_status sinew_world_get_soft_bodies(sinew_world_id world, sinew_soft_body_id* ids, int capacity,
                                                   int* count);

/* ---- FEM solids: tetrahedral meshes (docs/fem.md) ----------------------------------------------------
 * A tet body's particles are its mesh nodes, with lumped masses from the material's density
 * (def->total_mass and def->links are checked as for every soft body but not used); its surface triangles are the mesh boundary. def->method
 * must be SINEW_SOFT_IMPLICIT (the usual choice), SINEW_SOFT_SEMI_IMPLICIT or SINEW_SOFT_EXPLICIT, and
 * def->iterations is the CG cap of implicit Euler (100 is a good start for a solid). Read nodes with
 * sinew_soft_get_positions, pin them with sinew_soft_set_pinned. */

typedef enum sinew_fem_rotation {
    SINEW_FEM_LINEAR = 0, /* plain linear elements (they inflate when turned: for comparisons) */
    SINEW_FEM_POLAR = 1,  /* stiffness warping by the polar rotation of each element (default) */
    SINEW_FEM_QR = 2      /* stiffness warping by the Gram-Schmidt rotation of each element */
} sinew_fem_rotation;

typedef struct sinew_fem_material {
    float young;             /* Pa, > 0 (default 1e5) */
    float poisson;           /* in (-1, 0.5) (default 0.3) */
    float density;           /* kg/m^3, > 0 (default 1000) */
    float mass_damping;      /* Rayleigh alpha, 1/s, >= 0 (default 0) */
    float stiffness_damping; /* Rayleigh beta, s, >= 0 (default 0) */
    float yield;             /* plastic yield strain, >= 0 (default 0) */
    float creep;             /* plastic creep rate, 1/s, >= 0 (default 0: elastic) */
    float max_plastic;       /* cap on the plastic strain, >= 0 (default 0) */
    sinew_fem_rotation rotation;
} sinew_fem_material;

SINEW_API sinew_fem_material sinew_fem_material_default(void);
/** A solid box from min_corner (m) of extents size (m, > 0), cut into nx x ny x nz cells (each in
 *  [1, 1000]) of `split` (5 or 6) tets each: (nx+1)(ny+1)(nz+1) particles, node (i, j, k) being particle
 *  i + (nx+1) (j + (ny+1) k). With def->tet_order = 2 the tets are quadratic: a particle is added at the
 *  midpoint of every edge, after those. */
SINEW_API sinew_status sinew_soft_create_tet_box(sinew_world_id world, const sinew_soft_def* def,
                                                 const sinew_fem_material* material, sinew_vec3 min_corner,
                                                 sinew_vec3 size, int nx, int ny, int nz, int split,
                                                 sinew_soft_body_id* out);
/** A solid from a tet mesh: node_count (>= 4) positions (m, world, the rest shape) and tet_count (> 0)
 *  tets of 4 node indices each, positively oriented ((b-a).((c-a)x(d-a)) > 0); with def->tet_order = 2, of
 *  10 each: the 4 corners, then the midpoints of the edges (0 1) (1 2) (0 2) (0 3) (1 3) (2 3). The mesh is checked first
 *  (an inverted or flat tet, duplicate or unused nodes, a face on three tets, an open boundary: the
 *  message names the tet and its volume). The arrays are copied. */
SINEW_API sinew_status sinew_soft_create_tet_mesh(sinew_world_id world, const sinew_soft_def* def,
                                                  const sinew_fem_material* material, const sinew_vec3* nodes,
                                                  int node_count, const uint32_t* tets, int tet_count,
                                                  sinew_soft_body_id* out);
/** Changes a tet body's material; a new density changes its particles' masses (pins stay pinned). */
SINEW_API sinew_status sinew_soft_set_fem_material(sinew_soft_body_id body, const sinew_fem_material* material);
/** The number of tets of a soft body (0 for a body that is not a solid). */
SINEW_API sinew_status sinew_soft_tet_count(sinew_soft_body_id body, int* out);

/* ==== Joints ========================================================================================
 * Anchors are points in each body's origin frame (m); the hinge/slider axis is in A's frame. The bodies'
 * relative orientation at creation is the joint's zero (hinge angle 0, slider translation 0). */

typedef struct sinew_joint_id { uint32_t world; uint32_t index; uint32_t generation; } sinew_joint_id;

typedef enum sinew_joint_type {
    SINEW_JOINT_BALL = 0,     /* anchors coincide */
    SINEW_JOINT_HINGE = 1,    /* rotation about local_axis_a only; limit (rad) and motor (rad/s, N m) */
    SINEW_JOINT_SLIDER = 2,   /* translation along local_axis_a only; limit (m) and motor (m/s, N) */
    SINEW_JOINT_DISTANCE = 3, /* anchors keep `length`; rigid, or a spring (frequency, damping_ratio) */
    SINEW_JOINT_FIXED = 4     /* weld */
} sinew_joint_type;

typedef struct sinew_joint_def {
    sinew_joint_type type;      /* default SINEW_JOINT_BALL */
    sinew_body_id body_a;       /* distinct bodies of the world, at least one dynamic; no default */
    sinew_body_id body_b;
    sinew_vec3 local_anchor_a;  /* m, in A's frame (default 0) */
    sinew_vec3 local_anchor_b;  /* m, in B's frame (default 0) */
    sinew_vec3 local_axis_a;    /* hinge/slider axis in A's frame, non-zero (default (0, 0, 1)) */
    int collide_connected;      /* 0 or 1: contacts between the two bodies (default 0) */
    int enable_limit;           /* 0 or 1 (default 0) */
    float lower, upper;         /* limit: hinge rad within [-pi, pi], slider m; lower <= upper (default 0, 0) */
    int enable_motor;           /* 0 or 1 (default 0) */
    float motor_speed;          /* hinge rad/s, slider m/s (default 0) */
    float max_motor_force;      /* >= 0: hinge N m, slider N (default 0) */
    float length;               /* distance joint rest length, m; < 0 = the anchors' distance at creation
                                   (default -1) */
    float frequency;            /* distance joint spring, Hz, >= 0; 0 = rigid (default 0) */
    float damping_ratio;        /* distance joint spring, >= 0, 1 = critical (default 0) */
    float break_force;          /* N (torque rows: N m), >= 0; 0 = unbreakable (default 0) */
    uint64_t user_data;         /* yours, reported in joint break events */
} sinew_joint_def;

SINEW_API sinew_joint_def sinew_joint_def_default(void);
/** Creates a joint and wakes both bodies. Bodies of another world are SINEW_ERROR_STALE_ID. */
SINEW_API sinew_status sinew_joint_create(sinew_world_id world, const sinew_joint_def* def, sinew_joint_id* out);
/** Destroys a joint. Joints also disappear when they break or when one of their bodies is destroyed. */
SINEW_API sinew_status sinew_joint_destroy(sinew_joint_id joint);
/** Force (N) and torque (N m) the joint applied to body B in the last step (A received the opposite);
 *  either pointer may be NULL, not both. */
SINEW_API sinew_status sinew_joint_get_reaction(sinew_joint_id joint, sinew_vec3* force, sinew_vec3* torque);
/** Changes a hinge or slider motor (enable 0 or 1, speed finite, max_force >= 0) and wakes its bodies. */
SINEW_API sinew_status sinew_joint_set_motor(sinew_joint_id joint, int enable, float speed, float max_force);
/** Changes a hinge or slider limit (enable 0 or 1; lower <= upper, finite; a hinge's within [-pi, pi] rad)
 *  and wakes its bodies. */
SINEW_API sinew_status sinew_joint_set_limits(sinew_joint_id joint, int enable, float lower, float upper);
/** The joint's free coordinate and its rate now: hinge angle (rad, 0 at creation, in (-pi, pi]) and
 *  angular speed (rad/s) about the axis, slider translation (m) and speed (m/s) along it, distance joint
 *  length (m) and its rate (m/s); 0 for ball and fixed joints. Either pointer may be NULL, not both. */
SINEW_API sinew_status sinew_joint_get_coordinate(sinew_joint_id joint, float* value, float* speed);

/* ==== Scenes ========================================================================================
 * Scene files are documented in docs/scene-format.md (the same files `sinew run` steps). */

/** Creates a world from a scene file: its settings, rigid bodies (file order, then generators), joints and
 *  soft bodies. On a bad file returns SINEW_ERROR_SCENE with the file, the JSON pointer and the problem
 *  in sinew_last_error(), and creates nothing. */
SINEW_API sinew_status sinew_world_create_from_scene_file(const char* path, sinew_world_id* out);
/** Writes the world to a scene file that sinew_world_create_from_scene_file() (and `sinew run`) reads
 *  back into the same state: settings, bodies (named "body-INDEX"), joints, soft bodies (as their current
 *  particles and links) and velocities. Sleep states, contact warm-start impulses and solver caches are
 *  not saved: the reloaded world starts awake and cold. SINEW_ERROR_SCENE if the file cannot be written. */
SINEW_API sinew_status sinew_world_save_scene(sinew_world_id world, const char* path);

/* ==== Events ========================================================================================
 * Gathered during every fixed step and read after sinew_world_step / sinew_world_step_fixed returns. Each
 * stepping call first clears the previous call's events; the arrays then hold the events of all the
 * fixed steps that call took, in step order, and within a step in a fixed order (below), so two identical
 * runs report identical events. The arrays stay valid until the next call that steps or destroys the
 * world. */

/* Two bodies began to touch: their first manifold with at least one point appeared (speculative points
 * within the contact margin count, as in Box2D). body_a's slot is below body_b's. */
typedef struct sinew_contact_begin_event {
    sinew_body_id body_a, body_b;
    sinew_vec3 point;       /* m, world: the first contact point */
    sinew_vec3 normal;      /* unit, from A to B */
    float normal_impulse;   /* N s, summed over the pair's points: the normal impulse the solver applied
                               over that whole step (summed over the soft step's sub-steps), i.e.
                               m |v_before| + m g h - m |v_after| for a box landing. A speculative contact
                               begins while a gap is still open, so the first step may only close it and
                               the next stops the box. With SINEW_SOLVER_NEWTON it counts the contact and
                               shock-propagation passes, not the elastic collision passes before them. */
    float approach_speed;   /* m/s, >= 0: how fast the bodies were closing along the normal at the first
                               point when the step began (before its solve): a hit's strength, for
                               impact sounds and damage (Box2D's hit events); 0 if they were not closing */
    uint64_t step;          /* the world's step count after the step it happened in */
} sinew_contact_begin_event;

/* Two bodies stopped touching (or one of them was destroyed: its handle is then stale). */
typedef struct sinew_contact_end_event {
    sinew_body_id body_a, body_b;
    uint64_t step;
} sinew_contact_end_event;

/* A dynamic rigid body fell asleep (awake = 0) or woke up (awake = 1) during a step. */
typedef struct sinew_sleep_event {
    sinew_body_id body;
    int awake;
    uint64_t step;
} sinew_sleep_event;

/* A joint broke (its force exceeded break_force) and was removed: `joint` is stale now. body_a, body_b
 * and user_data are those of its definition. */
typedef struct sinew_joint_break_event {
    sinew_joint_id joint;
    sinew_body_id body_a, body_b;
    uint64_t user_data;
    uint64_t step;
} sinew_joint_break_event;

/* A soft body pushed a rigid body during a step (two-way or hybrid coupling): one event per (soft body,
 * rigid body) pair per step, the impulses of all its particles summed. */
typedef struct sinew_soft_contact_event {
    sinew_body_id body;         /* the rigid body */
    sinew_soft_body_id soft;    /* the soft body */
    sinew_vec3 impulse;         /* N s, received by the rigid body over the step: at rest, its weight times h
                                   (minus what other contacts carry) */
    sinew_vec3 point;           /* m, world: the contact points averaged, weighted by their impulses */
    int particles;              /* how many particles pushed */
    uint64_t step;
} sinew_soft_contact_event;

/* A body began or stopped overlapping a sensor (sinew_body_def.is_sensor). Found after each step, with
 * every position final: dynamic and kinematic rigid bodies whose shapes touch the sensor's, and soft
 * bodies with a particle (a sphere of the body's thickness) touching it, both passing the sensor's filter.
 * Static bodies and other sensors are not reported. Every begin is followed by exactly one end, also
 * when the visitor or the sensor is destroyed (the end then names a stale id). */
typedef struct sinew_sensor_event {
    sinew_body_id sensor;
    int is_soft;              /* 1: the visitor is `soft`, 0: it is `body` (the other is zeroed) */
    sinew_body_id body;
    sinew_soft_body_id soft;
    uint64_t step;
} sinew_sensor_event;

typedef struct sinew_events {
    const sinew_contact_begin_event* contact_begin; /* in (body_a slot, body_b slot) order per step */
    int contact_begin_count;
    const sinew_contact_end_event* contact_end;     /* same order */
    int contact_end_count;
    const sinew_sleep_event* sleep;                 /* in body slot order per step */
    int sleep_count;
    const sinew_joint_break_event* joint_break;     /* in the order the solver broke them */
    int joint_break_count;
    const sinew_soft_contact_event* soft_contact;   /* in (soft body slot, rigid body slot) order per step */
    int soft_contact_count;
    const sinew_sensor_event* sensor_begin;         /* in (sensor slot, rigid before soft, visitor slot) order per step */
    int sensor_begin_count;
    const sinew_sensor_event* sensor_end;           /* same order */
    int sensor_end_count;
    int dropped;  /* events lost because the allocator returned NULL (0 normally) */
} sinew_events;

SINEW_API sinew_status sinew_world_get_events(sinew_world_id world, sinew_events* out);

/* ---- queries and settings ---------------------------------------------------------------------------- */

typedef struct sinew_ray_hit {
    sinew_body_id body;  /* the body hit */
    sinew_vec3 point;    /* m, world: where the segment enters the body */
    sinew_vec3 normal;   /* unit, world, facing against the ray */
    float fraction;      /* [0, 1]: point = from + fraction (to - from) */
} sinew_ray_hit;

/** The closest body the segment from -> to enters (static, kinematic, dynamic; asleep or not). A ray that
 *  starts inside a solid shape does not hit that shape. *found = 1 and *hit filled, or *found = 0. */
SINEW_API sinew_status sinew_world_ray_cast(sinew_world_id world, sinew_vec3 from, sinew_vec3 to, sinew_ray_hit* hit,
                                            int* found);
/** As sinew_world_ray_cast, for the bodies `filter` would collide with (Box2D's rule, as between two
 *  bodies: each one's category must meet the other's mask, a shared negative group skips your own
 *  ragdoll). sinew_filter's defaults see everything. */
SINEW_API sinew_status sinew_world_ray_cast_filtered(sinew_world_id world, sinew_vec3 from, sinew_vec3 to,
                                                     sinew_filter filter, sinew_ray_hit* hit, int* found);
/** Every body the segment enters (one hit each, where it enters), by fraction: up to capacity hits written
 *  to `hits` (may be NULL when capacity is 0), *count receives how many there are. */
SINEW_API sinew_status sinew_world_ray_cast_all(sinew_world_id world, sinew_vec3 from, sinew_vec3 to, sinew_filter filter,
                                                sinew_ray_hit* hits, int capacity, int* count);

typedef struct sinew_shape_cast_hit {
    sinew_body_id body;  /* the first body the swept shape touches */
    sinew_vec3 point;    /* m, world: where they touch */
    sinew_vec3 normal;   /* unit, world: the body's surface normal there, toward the swept shape */
    float fraction;      /* [0, 1]: the shape touches after moving fraction * translation (0: it overlaps at the start) */
} sinew_shape_cast_hit;

/** Sweeps a sphere, box or capsule from `transform` along `translation` (m), keeping its rotation, and
 *  finds the first body it touches among those `filter` collides with (a character's move, a thrown
 *  object's path): the fraction is within 1e-5 m over the translation's length of the exact time of
 *  impact. *found = 1 and *hit filled, or *found = 0. Sensors are not hit. */
SINEW_API sinew_status sinew_world_cast_shape(sinew_world_id world, const sinew_shape_def* shape,
                                              const sinew_transform* transform, sinew_vec3 translation,
                                              sinew_filter filter, sinew_shape_cast_hit* hit, int* found);

typedef struct sinew_closest_points {
    float distance;             /* m; negative: they overlap by that depth */
    sinew_vec3 point_on_shape;  /* m, world: on the query shape's surface */
    sinew_vec3 point_on_body;   /* m, world: on the body's surface */
    sinew_vec3 normal;          /* unit, world, from the shape toward the body */
} sinew_closest_points;

/** The closest points of a sphere, box or capsule at `transform` and `body`, if they are at most
 *  max_distance (m, >= 0) apart: *found = 1 and *out filled, else *found = 0. */
SINEW_API sinew_status sinew_world_closest_points(sinew_world_id world, const sinew_shape_def* shape,
                                                  const sinew_transform* transform, sinew_body_id body,
                                                  float max_distance, sinew_closest_points* out, int* found);
/** Bodies whose world bounds overlap the box [lo, hi] (lo <= hi on every axis), in slot order. Up to
 *  capacity ids are written to ids (may be NULL when capacity is 0); *count receives how many overlap,
 *  which may exceed capacity (call again with a larger buffer). No allocation per call once warm. */
SINEW_API sinew_status sinew_world_overlap_aabb(sinew_world_id world, sinew_vec3 lo, sinew_vec3 hi, sinew_body_id* ids,
                                                int capacity, int* count);
/** Bodies whose shapes overlap or touch `shape` placed at `transform`, as sinew_world_overlap_aabb. */
SINEW_API sinew_status sinew_world_overlap_shape(sinew_world_id world, const sinew_shape_def* shape,
                                                 const sinew_transform* transform, sinew_body_id* ids, int capacity,
                                                 int* count);
/** What overlaps the sensor after the last step, in (rigid before soft, visitor slot) order: up to
 *  capacity overlaps written to `overlaps` (may be NULL when capacity is 0), *count receives how many
 *  there are. The events (sensor_begin, is_soft, body, soft; step 0) describe each. A body that is no
 *  sensor has none (SINEW_ERROR_INVALID_ARGUMENT). */
SINEW_API sinew_status sinew_sensor_get_overlaps(sinew_body_id sensor, sinew_sensor_event* overlaps, int capacity,
                                                 int* count);
/** Changes the rigid solver and its velocity iterations (1..1000) from the next step. */
SINEW_API sinew_status sinew_world_set_solver(sinew_world_id world, sinew_solver solver, int velocity_iterations);
SINEW_API sinew_status sinew_world_set_gravity(sinew_world_id world, sinew_vec3 gravity);

/* A touching pair of rigid bodies as the pre-solve callback sees it, and may change for this step. */
typedef struct sinew_presolve_contact {
    sinew_body_id body_a, body_b;
    sinew_vec3 normal;     /* unit, from body_a to body_b */
    int point_count;       /* 1..4 */
    sinew_vec3 points[4];  /* m, world */
    float depths[4];       /* m, > 0 penetrating, < 0 apart (a speculative point) */
    float friction;        /* the combined value; set it (finite, >= 0) to change it for this step */
    float restitution;     /* the combined value; set it to change it for this step (clamped to [0, 1]) */
} sinew_presolve_contact;
/** Return 0 to leave the contact out of this step (it starts the next one cold), non-zero to keep it. */
typedef int sinew_presolve_fn(void* context, sinew_presolve_contact* contact);
/** The pre-solve callback (NULL removes it): called once per touching pair every step, after collision
 *  detection and before the solve, on the thread that called sinew_world_step, in the same order every
 *  run (sorted by body pair), so results stay deterministic. It may read bodies (transforms,
 *  velocities, user data) but must not change the world. One-way platforms, conveyor belts (friction),
 *  surfaces that bounce only some bodies. */
SINEW_API sinew_status sinew_world_set_presolve(sinew_world_id world, sinew_presolve_fn* fn, void* context);

/* How rigid and soft bodies act on each other (docs/coupling.md). */
typedef enum sinew_coupling {
    SINEW_COUPLING_ONE_WAY = 0, /* rigid bodies push soft ones, nothing comes back (default) */
    SINEW_COUPLING_TWO_WAY = 1, /* both ways: particles in the rigid solve, rigid inertia in implicit soft solves */
    SINEW_COUPLING_HYBRID = 2,  /* one-way contacts, `gain` times their impulses sent back to the rigid body */
    SINEW_COUPLING_INTERLEAVED = 3, /* Baraff & Witkin 1997: alternate steps, forces a step late, repair */
    SINEW_COUPLING_ONE_SOLVER = 4,  /* two-way in one solver: the soft body's springs solved in the rigid solver's loop */
    SINEW_COUPLING_EMBED_RIGID = 5, /* embedding: the soft body is one rigid proxy in the rigid solver (per soft body:
                                       name no rigid body in sinew_world_set_pair_coupling) */
    SINEW_COUPLING_EMBED_FEM = 6,   /* embedding the other way: a dynamic rigid body (box, sphere, capsule, convex hull)
                                       is a stiff FEM proxy in the soft system, meeting the soft bodies paired with it */
    SINEW_COUPLING_AUTO = 7         /* the world's only: each soft body gets the cheapest strategy expected to stay
                                       within the tolerance (sinew_world_set_coupling_tolerance; docs/compare.md) */
} sinew_coupling;
/** The world's coupling strategy from the next step, for every pair no override names; `gain` in [0, 1]
 *  is the hybrid strategy's share of the reaction (ignored by the others). Overrides are kept. */
SINEW_API sinew_status sinew_world_set_coupling(sinew_world_id world, sinew_coupling strategy, float gain);
SINEW_API sinew_status sinew_world_get_coupling(sinew_world_id world, sinew_coupling* strategy);
/** How often the coupling layers act per step, from the next step: `substeps` soft steps per rigid step,
 *  in [1, 64] (one-way and hybrid, against the rigid poses interpolated over the step: a stiff cloth at
 *  300 Hz under a 60 Hz world takes 5; above 1 every strategy in use, overrides too, must be one of those
 *  two); `exchange_iterations` in [1, 100], two-way's passes of the particle rows per step (default 2).
 *  A value out of range, or sub-steps the strategies cannot take, is refused and nothing changes. */
SINEW_API sinew_status sinew_world_set_coupling_steps(sinew_world_id world, int substeps, int exchange_iterations);
SINEW_API sinew_status sinew_world_get_coupling_steps(sinew_world_id world, int* substeps, int* exchange_iterations);
/** SINEW_COUPLING_AUTO's position tolerance in metres, in (0, 1000] (default 0.01); picks again at once. */
SINEW_API sinew_status sinew_world_set_coupling_tolerance(sinew_world_id world, float meters);
/** The strategy acting between a soft body and a rigid body (`rigid` null: its strategy against every
 *  rigid body no override names): under SINEW_COUPLING_AUTO, the last pick (bodies created or destroyed
 *  since are taken into account at the next step's start). */
SINEW_API sinew_status sinew_world_get_pair_coupling(sinew_world_id world, sinew_soft_body_id soft, sinew_body_id rigid,
                                                     sinew_coupling* strategy);
/** The rigid proxy of an embedded soft body (SINEW_COUPLING_EMBED_RIGID), a rigid body that joints accept
 *  as either body (its frame: the world's turned to no angle and moved to the nodes' centre of mass as they
 *  were when the proxy was made). Pinning or attaching a first node, or freeing the last, makes the proxy
 *  anew (a kinematic one while any node is held): its old handle and joints are gone then;
 *  SINEW_ERROR_INVALID_ARGUMENT if the soft body is not embedded. Under SINEW_COUPLING_AUTO,
 *  asking for the proxy embeds the body (a joint is to hold it) unless a pair override says otherwise;
 *  SINEW_ERROR_INVALID_ARGUMENT during a step (a proxy may be made). */
SINEW_API sinew_status sinew_world_get_soft_proxy(sinew_world_id world, sinew_soft_body_id soft, sinew_body_id* out);
/* SINEW_COUPLING_EMBED_RIGID's proxies (docs/coupling.md, "Element proxies"): one rigid proxy per soft
 * body, or one per element (per tet; per surface triangle without tets; per structural link without
 * either), neighbours exchanging velocity changes through their shared nodes in every solver pass. */
typedef enum sinew_embed_proxies {
    SINEW_EMBED_BODY = 0,     /* one proxy per soft body (default): joints accept it */
    SINEW_EMBED_ELEMENTS = 1  /* one proxy per element */
} sinew_embed_proxies;
typedef enum sinew_embed_mass {
    SINEW_EMBED_MASS_PHYSICAL = 0,   /* an element weighs its nodes by their masses: momentum exchanged exactly */
    SINEW_EMBED_MASS_WHOLE_BODY = 1  /* each element weighs the whole body (seed 001): faster to stop, the nodes
                                        take only their share of an impulse */
} sinew_embed_mass;
/** The proxies of every soft body the world embeds (SINEW_COUPLING_EMBED_RIGID), remade at once; under
 *  SINEW_COUPLING_AUTO bodies are embedded with one proxy each whatever this says. Changing the kind, or
 *  the weights of element proxies, drops the old proxies and their joints. SINEW_ERROR_INVALID_ARGUMENT
 *  for a value out of range, or during a step. */
SINEW_API sinew_status sinew_world_set_embed_proxies(sinew_world_id world, sinew_embed_proxies proxies,
                                                     sinew_embed_mass mass);
/** Up to capacity handles of a soft body's element proxies (SINEW_EMBED_ELEMENTS), one per element in
 *  the order of its tets (or triangles, or structural links); *count receives how many it has (0 if it
 *  is not embedded that way; capacity 0 asks only that). A joint accepts one as either body; the proxies
 *  are made anew, their joints gone, when a node of the body is pinned or freed.
 *  SINEW_ERROR_INVALID_ARGUMENT during a step (proxies may be made). */
SINEW_API sinew_status sinew_world_get_soft_element_proxies(sinew_world_id world, sinew_soft_body_id soft,
                                                            sinew_body_id* out, int capacity, int* count);
/** Overrides the strategy between one soft body and one rigid body (`rigid` the null handle {0, 0, 0}:
 *  every rigid body), from the next step; a later call for the same pair replaces it. */
SINEW_API sinew_status sinew_world_set_pair_coupling(sinew_world_id world, sinew_soft_body_id soft, sinew_body_id rigid,
                                                     sinew_coupling strategy);
/** Friction (>= 0) and restitution ([0, 1]) of a body, from the next step. */
SINEW_API sinew_status sinew_body_set_material(sinew_body_id body, float friction, float restitution);

/* ==== Host hooks ==================================================================================== */

typedef enum sinew_log_level { SINEW_LOG_ERROR = 0, SINEW_LOG_WARNING = 1, SINEW_LOG_INFO = 2 } sinew_log_level;
/** `message` is valid during the call only. */
typedef void (*sinew_log_fn)(sinew_log_level level, const char* message, void* user);

/** Sets the callback that receives the library's messages (NULL: none; the default, the library prints
 *  nothing): every failed call's message at SINEW_LOG_ERROR (the text of sinew_last_error()), frame time
 *  dropped by the max_steps_per_frame cap at SINEW_LOG_WARNING, loaded scenes and broken joints at
 *  SINEW_LOG_INFO. Broken joints are logged during the step: a callback that tries to change that world
 *  then gets SINEW_ERROR_IN_STEP. */
SINEW_API sinew_status sinew_set_log_callback(sinew_log_fn fn, void* user);

/** Allocation hooks. alloc returns memory aligned to `alignment` (a power of two, at most 16) or NULL;
 *  free receives the size that was allocated. */
typedef struct sinew_allocator {
    void* (*alloc)(size_t size, size_t alignment, void* user);
    void (*free)(void* ptr, size_t size, void* user);
    void* user;
} sinew_allocator;

/** Sets the allocator for the C API's own per-world memory: each world's handle record and its event
 *  buffers (contact, sleep and joint-break events, the previous step's contact pairs and awake flags).
 *  NOT covered yet: the C++ engine inside (World, the rigid and soft systems, their arrays, scene parsing)
 *  still uses operator new. A world keeps the hooks it was created with until it is destroyed, so the
 *  hooks must stay callable that long; changing them affects worlds created afterwards. NULL restores
 *  malloc/free. alloc and free must both be set. */
SINEW_API sinew_status sinew_set_allocator(const sinew_allocator* allocator);

/* ==== Debug draw ====================================================================================
 * The host's renderer draws the world through these callbacks (any may be NULL: that primitive is not
 * drawn). Colours are 0xRRGGBB: static bodies grey, kinematic amber, dynamic awake green, asleep
 * blue-grey, sensors light green, soft bodies blue, contacts red (points; pink for a speculative point,
 * still apart within the contact margin) and yellow (normals, 0.2 m), joints cyan (each body's centre to its anchor, and the anchors joined). */
typedef struct sinew_debug_draw {
    void (*draw_sphere)(void* context, sinew_vec3 center, float radius, uint32_t color);
    /* A capsule: the segment a-b swept by radius. */
    void (*draw_capsule)(void* context, sinew_vec3 a, sinew_vec3 b, float radius, uint32_t color);
    /* A box: its centre and rotation, and its half extents along its own axes. */
    void (*draw_box)(void* context, sinew_transform transform, sinew_vec3 half_extents, uint32_t color);
    /* Hull faces (fanned), mesh triangles, soft surfaces, planes (a 100 m square around the point
     * nearest the origin), counter-clockwise seen from outside. */
    void (*draw_triangle)(void* context, sinew_vec3 a, sinew_vec3 b, sinew_vec3 c, uint32_t color);
    /* Joints, contact normals, soft links of bodies without a surface (ropes). */
    void (*draw_segment)(void* context, sinew_vec3 a, sinew_vec3 b, uint32_t color);
    /* Contact points (size 0.05 m). */
    void (*draw_point)(void* context, sinew_vec3 p, float size, uint32_t color);
    int draw_shapes;      /* 0 or 1: rigid bodies' shapes */
    int draw_joints;      /* 0 or 1 */
    int draw_contacts;    /* 0 or 1: the points of the last step's manifolds and their normals */
    int draw_soft_bodies; /* 0 or 1 */
    void* context;        /* passed to every callback */
} sinew_debug_draw;

/** All of it on (callbacks NULL: set the ones your renderer has). */
SINEW_API sinew_debug_draw sinew_debug_draw_default(void);
/** Calls the callbacks for the world as it is now, on the calling thread, in body slot order. Not during
 *  a step (SINEW_ERROR_IN_STEP); the callbacks must not change the world. */
SINEW_API sinew_status sinew_world_draw(sinew_world_id world, const sinew_debug_draw* draw);

/* ---- helpers (no world needed) ---------------------------------------------------------------------
 * Quaternions are {x, y, z, w} here; scene files write [w, x, y, z]. */

/** The rotation by `angle` (rad) about `axis` (any length > 0); the identity for a zero or non-finite axis. */
SINEW_API sinew_quat sinew_quat_from_axis_angle(sinew_vec3 axis, float angle);
/** The rotation by radians.x about the fixed x axis, then radians.y about y, then radians.z about z (as a
 *  scene file's "rotation_deg", in radians); the identity for non-finite angles. */
SINEW_API sinew_quat sinew_quat_from_euler(sinew_vec3 radians);
/** a * b: b's rotation first, then a's. */
SINEW_API sinew_quat sinew_quat_multiply(sinew_quat a, sinew_quat b);
/** v rotated by the unit quaternion q. */
SINEW_API sinew_vec3 sinew_quat_rotate(sinew_quat q, sinew_vec3 v);
/** For rendering between fixed steps: the position lerped and the rotation nlerped along the shorter arc
 *  from a (alpha 0) to b (alpha 1). Keep each body's transform from before the last step yourself (as
 *  demos/c/game_loop.c does) and pass the alpha sinew_world_step returned. */
SINEW_API sinew_transform sinew_transform_interpolate(sinew_transform a, sinew_transform b, float alpha);
/** 1 if the handles are the same (all fields equal), else 0. */
SINEW_API int sinew_world_id_equal(sinew_world_id a, sinew_world_id b);
SINEW_API int sinew_body_id_equal(sinew_body_id a, sinew_body_id b);
SINEW_API int sinew_soft_body_id_equal(sinew_soft_body_id a, sinew_soft_body_id b);
SINEW_API int sinew_joint_id_equal(sinew_joint_id a, sinew_joint_id b);

#ifdef __cplusplus
}
#endif

#endif /* SINEW_H */
