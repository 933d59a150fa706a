/* A plain-C game loop on Sinew's C API: a stack of boxes on the ground, stepped with variable frame
 * times through the accumulator, rendered (printed) with interpolated transforms.
 * Exit status 0 if the stack stands (top box within 2 cm of its rest height), so the tests run it. */
#include <math.h>
#include <stdio.h>

#include <sinew.h>

#define BOXES 5

static int check(sinew_status s, const char* what) {
    if (s != SINEW_OK) fprintf(stderr, "%s failed (%d): %s\n", what, (int)s, sinew_last_error());
    return s == SINEW_OK;
}

int main(void) {
    sinew_world_def wd = sinew_world_def_default();
    sinew_world_id world;
    sinew_body_def ground = sinew_body_def_default();
    sinew_body_id boxes[BOXES];
    sinew_transform previous[BOXES], current[BOXES];
    int i, frame;
    float t = 0.0f;

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
    /* Variable frame times around 60 Hz; render at the interpolation fraction between the last two steps. */
    for (frame = 0; frame < 240; ++frame) {
        float dt = 1.0f / 60.0f + 0.004f * sinf(0.37f * (float)frame);
        int steps = 0;
        float alpha = 0.0f;
        for (i = 0; i < BOXES; ++i) previous[i] = current[i];
        if (!check(sinew_world_step(world, dt, &steps, &alpha), "sinew_world_step")) return 1;
        t += dt;
        for (i = 0; i < BOXES; ++i) check(sinew_body_get_transform(boxes[i], &current[i]), "get");
        if (frame % 60 == 59) {
            const sinew_transform* a = &previous[BOXES - 1];
            const sinew_transform* b = &current[BOXES - 1];
            float y = steps > 0 ? a->p.y + (b->p.y - a->p.y) * alpha : b->p.y;
            printf("t = %.2f s: %d step(s), alpha %.2f, top box rendered at y = %.4f m\n", t, steps, alpha, y);
        }
    }
    {
        float top = current[BOXES - 1].p.y;
        check(sinew_world_destroy(world), "sinew_world_destroy");
        return fabsf(top - ((float)BOXES - 0.5f)) < 0.02f ? 0 : 1;
    }
}
