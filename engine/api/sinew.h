/*
 * sinew.h - the C API of Sinew, rigid/deformable multi-physics middleware for games.
 *
 * C99, no C++ in this header; only sinew_-prefixed symbols are exported from libsinew.so.
 *
 * Conventions
 * - Units: metres, kilograms, seconds, radians; forces in newtons, impulses in newton-seconds.
 * - Handles are values: {index, generation} (bodies also carry their world). A zero generation is the
 *   null handle. A stale handle (its object was destroyed) or a foreign one is detected and rejected,
 *   never dereferenced.
 * - Every call that can fail returns a sinew_status; sinew_last_error() then names the argument and the
 *   value. A rejected call leaves the world exactly as it was.
 * - Definitions have defaults: start from sinew_*_def_default() and change what you need.
 * - The API is single precision (float) whatever Real the library was built with.
 *
 * Threading: a world is used by one thread at a time. Different worlds may be used from different
 * threads concurrently. sinew_last_error() is per thread. Calls that change a world are rejected with
 * SINEW_ERROR_IN_STEP while that world is stepping (e.g. from a callback).
 *
 * This header grows with the engine: rigid bodies now; joints, events, queries, soft bodies next.
 */
#ifndef SINEW_H
#define SINEW_H

#include <stdint.h>

#if defined(_WIN32)
#define SINEW_API __declspec(dllexport)
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
    SINEW_ERROR_INTERNAL = 5          /* out of memory or a bug: the message says which */
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

typedef struct sinew_world_def {
    sinew_vec3 gravity;      /* m/s^2, default (0, -9.81, 0) */
    float time_step;         /* fixed internal step h, s, default 1/60 */
    int max_steps_per_frame; /* accumulator cap, default 8 */
    sinew_solver solver;     /* default SINEW_SOLVER_SOFT_STEP */
    int velocity_iterations; /* passes over the constraints per step, default 10 */
    int enable_sleep;        /* 0 or 1, default 1 */
} sinew_world_def;

typedef enum sinew_body_type { SINEW_BODY_STATIC = 0, SINEW_BODY_KINEMATIC = 1, SINEW_BODY_DYNAMIC = 2 } sinew_body_type;
typedef enum sinew_shape_type { SINEW_SHAPE_SPHERE = 0, SINEW_SHAPE_BOX = 1, SINEW_SHAPE_CAPSULE = 2 } sinew_shape_type;

typedef struct sinew_shape_def {
    sinew_shape_type type; /* default SINEW_SHAPE_BOX */
    float radius;          /* m: sphere, capsule (default 0.5) */
    float half_height;     /* m: capsule segment half length along local y (default 0.5) */
    sinew_vec3 half_extents; /* m: box (default 0.5, 0.5, 0.5) */
} sinew_shape_def;

typedef struct sinew_body_def {
    sinew_body_type type;     /* default SINEW_BODY_DYNAMIC */
    sinew_transform transform; /* body origin in the world, default identity */
    sinew_vec3 linear_velocity;  /* m/s, default 0 */
    sinew_vec3 angular_velocity; /* rad/s, default 0 */
    sinew_shape_def shape;
    float mass;               /* kg; 0 = from density (default 0) */
    float density;            /* kg/m^3, default 1000 */
    float friction;           /* Coulomb coefficient, default 0.6 */
    float restitution;        /* [0, 1], default 0 */
    float linear_damping;     /* 1/s, default 0 */
    float angular_damping;    /* 1/s, default 0 */
    uint64_t user_data;       /* yours, returned by sinew_body_user_data() */
} sinew_body_def;

/** "MAJOR.MINOR.PATCH (float|double)"; a static string, never NULL. */
SINEW_API const char* sinew_version(void);
/** Message of the last failed call on this thread ("" if none); valid until the next call. */
SINEW_API const char* sinew_last_error(void);

SINEW_API sinew_world_def sinew_world_def_default(void);
SINEW_API sinew_status sinew_world_create(const sinew_world_def* def, sinew_world_id* out);
SINEW_API sinew_status sinew_world_destroy(sinew_world_id world);
/** Game-loop stepping: adds frame_dt (s, >= 0) to the accumulator and runs whole fixed steps.
 *  steps_taken and alpha (interpolation fraction in [0, 1)) may be NULL. */
SINEW_API sinew_status sinew_world_step(sinew_world_id world, float frame_dt, int* steps_taken, float* alpha);
/** Exactly one fixed step of the world's time_step. */
SINEW_API sinew_status sinew_world_step_fixed(sinew_world_id world);
SINEW_API sinew_status sinew_world_body_count(sinew_world_id world, int* out);
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
/** For kinematic bodies this is how the game drives them. */
SINEW_API sinew_status sinew_body_set_velocity(sinew_body_id body, sinew_vec3 linear, sinew_vec3 angular);
SINEW_API sinew_status sinew_body_apply_force(sinew_body_id body, sinew_vec3 force, sinew_vec3 world_point);
SINEW_API sinew_status sinew_body_apply_impulse(sinew_body_id body, sinew_vec3 impulse, sinew_vec3 world_point);
SINEW_API sinew_status sinew_body_user_data(sinew_body_id body, uint64_t* out);

#ifdef __cplusplus
}
#endif

#endif /* SINEW_H */
