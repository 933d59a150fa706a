/* What a platform game asks of a physics engine, in plain C on Sinew's C API:
 *  - a one-way platform (the pre-solve callback): the player, thrown up from below, passes through a slab
 *    and lands on its top;
 *  - collision filtering: debris dropped onto the player passes through it (the debris' mask leaves out
 *    the player's category) and lands on the slab;
 *  - a moving kinematic platform (sinew_body_set_target_transform every step) carrying a stack of crates;
 *  - a sensor (a trigger box) at the end of the platform's path that reports the crates arriving, and
 *    sees nothing else (its mask: crates only);
 *  - a shape cast: before the platform moves, a box swept along its path finds the wall at the far end.
 * Exit status 0 if each of these does what a player would expect, so the tests run it. */
#include <math.h>
#include <stdio.h>

#include <sinew.h>

#define CRATES 3
#define DEBRIS 2
#define STEPS 300

/* Collision categories. */
#define CAT_WORLD 1u
#define CAT_PLAYER 2u
#define CAT_DEBRIS 4u
#define CAT_CRATE 8u
#define CAT_SENSOR 16u

static const float kH = 1.0f / 60.0f;
static const float kSlabTop = 2.1f;     /* the one-way slab's top face (m) */
static const float kPlayerRadius = 0.3f;
static const float kPlatformSpeed = 1.0f; /* m/s along z */

typedef struct game {
    sinew_body_id player, slab;
} game;

static int check(sinew_status s, const char* what) {
    if (s != SINEW_OK) fprintf(stderr, "%s failed (%d): %s\n", what, (int)s, sinew_last_error());
    return s == SINEW_OK;
}

/* A failed check: said on stdout, in order with the rest of the report. */
static int failed(const char* what, int index) {
    if (index >= 0) printf("FAILED: %s (%d)\n", what, index);
    else printf("FAILED: %s\n", what);
    return 0;
}

static int same(sinew_body_id a, sinew_body_id b) {
    return a.world == b.world && a.index == b.index && a.generation == b.generation;
}

/* One-way platform: the player meets the slab only while its lowest point is above the slab's top
 * (within 5 cm, so a landing player is caught however fast it falls in one step). Every other pair keeps
 * its contact. */
static int one_way(void* context, sinew_presolve_contact* contact) {
    const game* g = (const game*)context;
    sinew_body_id other;
    sinew_transform t;
    if (same(contact->body_a, g->slab)) other = contact->body_b;
    else if (same(contact->body_b, g->slab)) other = contact->body_a;
    else return 1;
    if (!same(other, g->player)) return 1;
    if (sinew_body_get_transform(g->player, &t) != SINEW_OK) return 1;
    return t.p.y - kPlayerRadius >= kSlabTop - 0.05f;
}

static sinew_body_id add_box(sinew_world_id world, sinew_body_type type, sinew_vec3 at, sinew_vec3 half,
                             uint32_t category, uint32_t mask) {
    sinew_body_def d = sinew_body_def_default();
    sinew_body_id id = {0, 0, 0};
    d.type = type;
    d.transform.p = at;
    d.shape.half_extents = half;
    d.filter.category_bits = category;
    d.filter.mask_bits = mask;
    if (type == SINEW_BODY_DYNAMIC) d.mass = 1.0f;
    check(sinew_body_create(world, &d, &id), "sinew_body_create");
    return id;
}

static sinew_vec3 v3(float x, float y, float z) {
    sinew_vec3 v;
    v.x = x;
    v.y = y;
    v.z = z;
    return v;
}

int main(void) {
    sinew_world_def wd = sinew_world_def_default();
    sinew_world_id world;
    game g;
    sinew_body_id platform, wall, sensor, crates[CRATES], debris[DEBRIS];
    sinew_transform platform_at, t;
    sinew_vec3 v, w;
    int step, i, ok = 1;
    int crate_arrivals = 0, other_arrivals = 0, player_debris_contacts = 0;
    float peak = 0.0f, wall_distance = -1.0f;

    wd.enable_sleep = 0; /* the checks read velocities every step */
    if (!check(sinew_world_create(&wd, &world), "sinew_world_create")) return 1;

    /* The level: ground, the one-way slab above the player, a wall at the end of the platform's path. */
    add_box(world, SINEW_BODY_STATIC, v3(0, -0.5f, 0), v3(20, 0.5f, 20), CAT_WORLD, 0xFFFFFFFFu);
    g.slab = add_box(world, SINEW_BODY_STATIC, v3(0, kSlabTop - 0.1f, 0), v3(1.5f, 0.1f, 1.5f), CAT_WORLD, 0xFFFFFFFFu);
    wall = add_box(world, SINEW_BODY_STATIC, v3(5, 1.5f, 6.5f), v3(2, 1.5f, 0.2f), CAT_WORLD, 0xFFFFFFFFu);

    /* The player: a ball on the ground under the slab, thrown straight up at 8 m/s. */
    {
        sinew_body_def d = sinew_body_def_default();
        d.shape.type = SINEW_SHAPE_SPHERE;
        d.shape.radius = kPlayerRadius;
        d.transform.p = v3(0, kPlayerRadius, 0);
        d.linear_velocity = v3(0, 8, 0);
        d.mass = 70.0f;
        d.filter.category_bits = CAT_PLAYER;
        if (!check(sinew_body_create(world, &d, &g.player), "player")) return 1;
    }
    if (!check(sinew_world_set_presolve(world, one_way, &g), "sinew_world_set_presolve")) return 1;

    /* The moving platform (kinematic) with a stack of crates, and the goal sensor ahead of it. */
    platform = add_box(world, SINEW_BODY_KINEMATIC, v3(5, 1, 0), v3(1, 0.1f, 1), CAT_WORLD, 0xFFFFFFFFu);
    for (i = 0; i < CRATES; ++i)
        crates[i] = add_box(world, SINEW_BODY_DYNAMIC, v3(5, 1.3f + 0.4f * (float)i, 0), v3(0.2f, 0.2f, 0.2f), CAT_CRATE,
                            0xFFFFFFFFu);
    {
        sinew_body_def d = sinew_body_def_default();
        d.type = SINEW_BODY_STATIC;
        d.is_sensor = 1;
        d.transform.p = v3(5, 1.8f, 3);
        d.shape.half_extents = v3(1, 0.7f, 0.5f);
        d.filter.category_bits = CAT_SENSOR;
        d.filter.mask_bits = CAT_CRATE;
        if (!check(sinew_body_create(world, &d, &sensor), "sensor")) return 1;
    }

    /* Before moving: sweep the platform's box along its path to see how far it can go. */
    {
        sinew_shape_def box = sinew_body_def_default().shape;
        sinew_transform from;
        sinew_shape_cast_hit hit;
        int found = 0;
        box.half_extents = v3(1, 0.1f, 1);
        if (!check(sinew_body_get_transform(platform, &from), "get platform")) return 1;
        from.p.y += 0.5f; /* the platform's height is clear of the ground; lift the probe to the wall's */
        sinew_filter level_only = sinew_filter_default(); /* the level's bodies, not the crates on board */
        level_only.category_bits = CAT_WORLD;
        level_only.mask_bits = CAT_WORLD;
        if (!check(sinew_world_cast_shape(world, &box, &from, v3(0, 0, 10), level_only, &hit, &found),
                   "sinew_world_cast_shape"))
            return 1;
        if (found && same(hit.body, wall)) wall_distance = hit.fraction * 10.0f;
        printf("shape cast: the platform's path is clear for %.3f m, up to the wall\n", wall_distance);
    }

    if (!check(sinew_body_get_transform(platform, &platform_at), "get platform")) return 1;
    for (step = 1; step <= STEPS; ++step) {
        sinew_events e;
        /* The platform starts after half a second and speeds up over one second (1 m/s^2, which friction
         * 0.6 passes on to the crates without slip) to constant speed along z. */
        if (step > 30) platform_at.p.z += kPlatformSpeed * kH * fminf(1.0f, (float)(step - 30) / 60.0f);
        if (!check(sinew_body_set_target_transform(platform, &platform_at, kH), "target")) return 1;
        /* Debris falls on the player once it has landed on the slab. */
        if (step == 120)
            for (i = 0; i < DEBRIS; ++i)
                debris[i] = add_box(world, SINEW_BODY_DYNAMIC, v3(0, 4.0f + 0.6f * (float)i, 0.35f * ((float)i - 0.5f)),
                                    v3(0.15f, 0.15f, 0.15f), CAT_DEBRIS, ~CAT_PLAYER);
        if (!check(sinew_world_step_fixed(world), "sinew_world_step_fixed")) return 1;
        if (!check(sinew_world_get_events(world, &e), "sinew_world_get_events")) return 1;
        for (i = 0; i < e.sensor_begin_count; ++i) {
            const sinew_sensor_event* s = &e.sensor_begin[i];
            int k, crate = 0;
            for (k = 0; k < CRATES; ++k) crate |= !s->is_soft && same(s->body, crates[k]);
            if (crate) ++crate_arrivals;
            else ++other_arrivals;
            printf("step %3d: %s entered the goal\n", step, crate ? "a crate" : "something else");
        }
        for (i = 0; i < e.contact_begin_count; ++i) {
            const sinew_contact_begin_event* c = &e.contact_begin[i];
            if (same(c->body_a, g.player) || same(c->body_b, g.player)) {
                int k;
                for (k = 0; step >= 120 && k < DEBRIS; ++k)
                    player_debris_contacts += same(c->body_a, debris[k]) || same(c->body_b, debris[k]);
            }
        }
        check(sinew_body_get_transform(g.player, &t), "get player");
        if (t.p.y > peak) peak = t.p.y;
        if (step % 60 == 0) printf("t = %.1f s: player at y = %.3f m, platform at z = %.3f m\n", step * kH, t.p.y, platform_at.p.z);
    }

    /* The checks. */
    check(sinew_body_get_transform(g.player, &t), "get player");
    printf("player: peak %.3f m (free flight 3.562 m), rests at %.3f m (slab top + radius = %.3f m)\n", peak, t.p.y,
           kSlabTop + kPlayerRadius);
    if (fabsf(peak - (kPlayerRadius + 64.0f / (2 * 9.81f))) > 0.05f) ok = failed("the slab stopped the rising player", -1);
    if (fabsf(t.p.y - (kSlabTop + kPlayerRadius)) > 0.02f) ok = failed("the player does not rest on the slab", -1);
    if (player_debris_contacts) ok = failed("debris touched the player", -1);
    for (i = 0; i < DEBRIS; ++i) {
        check(sinew_body_get_transform(debris[i], &t), "get debris");
        printf("debris %d rests at y = %.3f m (on the slab: %.3f m)\n", i, t.p.y, kSlabTop + 0.15f);
        if (fabsf(t.p.y - (kSlabTop + 0.15f)) > 0.02f) ok = failed("debris did not pass through to the slab", i);
    }
    for (i = 0; i < CRATES; ++i) {
        check(sinew_body_get_velocity(crates[i], &v, &w), "get crate velocity");
        check(sinew_body_get_transform(crates[i], &t), "get crate");
        printf("crate %d: v = (%.4f, %.4f, %.4f) m/s, at z - platform z = %.4f m\n", i, v.x, v.y, v.z, t.p.z - platform_at.p.z);
        if (fabsf(v.z - kPlatformSpeed) > 0.01f * kPlatformSpeed || fabsf(v.x) > 0.01f || fabsf(v.y) > 0.01f)
            ok = failed("a crate slips on the platform", i);
        if (fabsf(t.p.z - platform_at.p.z) > 0.01f) ok = failed("a crate left its place on the platform", i);
    }
    printf("the goal saw %d crates and %d other bodies\n", crate_arrivals, other_arrivals);
    if (crate_arrivals != CRATES || other_arrivals != 0) ok = failed("the goal saw the wrong bodies", -1);
    if (fabsf(wall_distance - (6.3f - 1.0f)) > 0.01f) ok = failed("the shape cast missed the wall", -1);
    check(sinew_world_destroy(world), "sinew_world_destroy");
    if (ok) printf("all checks passed\n");
    return ok ? 0 : 1;
}
