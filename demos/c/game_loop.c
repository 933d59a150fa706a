/* A plain-C game loop on Sinew's C API: a stack of boxes on the ground and a cloth held at two corners
 * beside it, stepped with variable frame times through the accumulator, rendered (printed) with
 * interpolated transforms; the cloth's particles are read in bulk into a buffer filled every frame.
 * Events after each step report the stack falling asleep.
 * Exit status 0 if the stack stands (top box within 2 cm of its rest height) and the cloth hangs from its
 * pinned corners, so the tests run it. */
#include <math.h>
#include <stdio.h>

#include <sinew.h>

#define BOXES 5
#define CLOTH_N 16

static int check(sinew_status s, const char* what) {
    if (s != SINEW_OK) fprintf(stderr, "%s failed (%d): %s\n", what, (int)s, sinew_last_error());
    return s == SINEW_OK;
}

static float lerp(float a, float b, float t) { return a + (b - a) * t; }

int main(void) {
    sinew_world_def wd = sinew_world_def_default();
    sinew_world_id world;
    sinew_body_def ground = sinew_body_def_default();
    sinew_soft_def cloth_def = sinew_soft_def_default();
    sinew_cloth_def grid = sinew_cloth_def_default();
    sinew_body_id boxes[BOXES];
    sinew_soft_body_id cloth;
    sinew_transform previous[BOXES], current[BOXES];
    static sinew_vec3 particles[CLOTH_N * CLOTH_N]; /* filled in bulk every frame, never reallocated */
    int i, frame, n = 0, slept = 0;
    float t = 0.0f, lowest = 0.0f;

    if (!check(sinew_world_create(&wd, &world), "sinew_world_create")) return 1;
    ground.type = SINEW_BODY_STATIC;
    ground.shape.half_extents.x = 10.0f;
    ground.shape.half_extents.y = 0.5f;
    ground.shape.half_extents.z = 10.0f;
    ground.transform.p.y = -0.5f;
    {
        sinew_body_id ground_id;
        if (!check(sinew_body_create(world, &ground, &ground_id), "ground")) return 1;
    }
    for (i = 0; i < BOXES; ++i) {
        sinew_body_def box = sinew_body_def_default();
        box.mass = 1.0f;
        box.transform.p.y = 0.5f + (float)i;
        if (!check(sinew_body_create(world, &box, &boxes[i]), "box")) return 1;
        check(sinew_body_get_transform(boxes[i], &current[i]), "get");
    }
    /* A 2 m x 2 m Verlet cloth, horizontal at 4 m, held by the two corners of its first row. */
    cloth_def.method = SINEW_SOFT_VERLET;
    cloth_def.total_mass = 0.5f;
    cloth_def.drag = 0.1f;
    grid.nx = grid.ny = CLOTH_N;
    grid.origin.x = 2.0f;
    grid.origin.y = 4.0f;
    grid.origin.z = -1.0f;
    grid.edge_u.x = 2.0f;
    grid.edge_u.y = 0.0f;
    grid.edge_v.y = 0.0f;
    grid.edge_v.z = 2.0f;
    grid.pinned_corners = SINEW_CLOTH_PIN_00 | SINEW_CLOTH_PIN_10;
    if (!check(sinew_soft_create_cloth(world, &cloth_def, &grid, &cloth), "sinew_soft_create_cloth")) return 1;

    /* Variable frame times around 60 Hz; render at the interpolation fraction between the last two steps. */
    for (frame = 0; frame < 240; ++frame) {
        float dt = 1.0f / 60.0f + 0.004f * sinf(0.37f * (float)frame);
        int steps = 0;
        float alpha = 0.0f;
        sinew_events events;
        if (!check(sinew_world_step(world, dt, &steps, &alpha), "sinew_world_step")) return 1;
        t += dt;
        if (steps > 0) { /* a new state: the old one becomes the start of the interpolation */
            for (i = 0; i < BOXES; ++i) {
                previous[i] = current[i];
                check(sinew_body_get_transform(boxes[i], &current[i]), "get");
            }
        }
        check(sinew_soft_get_positions(cloth, particles, CLOTH_N * CLOTH_N, &n), "sinew_soft_get_positions");
        check(sinew_world_get_events(world, &events), "sinew_world_get_events");
        for (i = 0; i < events.sleep_count; ++i) slept += events.sleep[i].awake ? -1 : 1;
        if (frame % 60 == 59) {
            lowest = particles[0].y;
            for (i = 1; i < n; ++i)
                if (particles[i].y < lowest) lowest = particles[i].y;
            printf("t = %.2f s: %d step(s), alpha %.2f, boxes rendered at y =", t, steps, alpha);
            for (i = 0; i < BOXES; ++i) printf(" %.3f", lerp(previous[i].p.y, current[i].p.y, alpha));
            printf("; %d asleep; cloth lowest y = %.3f m\n", slept, lowest);
        }
    }
    {
        float top = current[BOXES - 1].p.y;
        int stands = fabsf(top - ((float)BOXES - 0.5f)) < 0.02f;
        /* The pinned corners have not moved; the rest of the 2 m cloth hangs below them. */
        int pinned = particles[0].y == 4.0f && particles[CLOTH_N - 1].y == 4.0f;
        int hangs = lowest < 3.0f && isfinite(lowest);
        check(sinew_world_destroy(world), "sinew_world_destroy");
        return stands && pinned && hangs ? 0 : 1;
    }
}
