/* A plain-C game loop over a scene file: load it through the C API, step it with variable frame times
 * through the accumulator, render (print) interpolated rigid transforms, and read the cloth's particles
 * in bulk into a buffer allocated once.
 *
 *   scene_loop SCENE.json [FRAMES]     (default: demos/scenes/showcase-c-loop.json, 150 frames)
 *
 * At the end it prints the number of fixed steps taken and every body's transform and particle position
 * (%.9g: the exact float), which the tests compare with `sinew run SCENE --steps N --record`. */
#include <stdio.h>
#include <stdlib.h>

#include <sinew.h>

static int check(sinew_status s, const char* what) {
    if (s != SINEW_OK) fprintf(stderr, "scene_loop: %s failed (%d): %s\n", what, (int)s, sinew_last_error());
    return s == SINEW_OK;
}

/* Rendering: the state between the last two steps at fraction alpha (positions lerped, rotations nlerped). */
static sinew_transform interpolate(const sinew_transform* a, const sinew_transform* b, float alpha) {
    sinew_transform r;
    float dot = a->q.x * b->q.x + a->q.y * b->q.y + a->q.z * b->q.z + a->q.w * b->q.w;
    float s = dot < 0.0f ? -1.0f : 1.0f; /* the shorter way round */
    float n;
    r.p.x = a->p.x + (b->p.x - a->p.x) * alpha;
    r.p.y = a->p.y + (b->p.y - a->p.y) * alpha;
    r.p.z = a->p.z + (b->p.z - a->p.z) * alpha;
    r.q.x = a->q.x + (s * b->q.x - a->q.x) * alpha;
    r.q.y = a->q.y + (s * b->q.y - a->q.y) * alpha;
    r.q.z = a->q.z + (s * b->q.z - a->q.z) * alpha;
    r.q.w = a->q.w + (s * b->q.w - a->q.w) * alpha;
    n = r.q.x * r.q.x + r.q.y * r.q.y + r.q.z * r.q.z + r.q.w * r.q.w;
    if (n > 0.0f) {
        /* one Newton step of 1/sqrt(n) around 1 is enough for an nlerp of nearby unit quaternions */
        float inv = 1.5f - 0.5f * n;
        r.q.x *= inv;
        r.q.y *= inv;
        r.q.z *= inv;
        r.q.w *= inv;
    }
    return r;
}

int main(int argc, char** argv) {
    const char* path = argc > 1 ? argv[1] : "demos/scenes/showcase-c-loop.json";
    int frames = argc > 2 ? atoi(argv[2]) : 150;
    sinew_world_id world;
    int body_count = 0, soft_count = 0, particle_count = 0, total_steps = 0;
    int i, k, frame, n;
    sinew_transform *previous, *current;
    sinew_soft_body_id cloth;
    sinew_vec3* particles;

    if (!check(sinew_world_create_from_scene_file(path, &world), "sinew_world_create_from_scene_file")) return 1;
    check(sinew_world_body_count(world, &body_count), "sinew_world_body_count");
    check(sinew_world_soft_body_count(world, &soft_count), "sinew_world_soft_body_count");
    if (body_count < 1 || soft_count < 1) {
        fprintf(stderr, "scene_loop: %s needs at least one rigid body and one soft body\n", path);
        return 1;
    }
    if (!check(sinew_world_get_soft_bodies(world, &cloth, 1, &n), "sinew_world_get_soft_bodies")) return 1;
    check(sinew_soft_particle_count(cloth, &particle_count), "sinew_soft_particle_count");

    /* Every buffer is allocated once, before the loop: the loop itself allocates nothing. */
    previous = malloc(sizeof *previous * (size_t)body_count);
    current = malloc(sizeof *current * (size_t)body_count);
    particles = malloc(sizeof *particles * (size_t)particle_count);
    if (!previous || !current || !particles) return 1;
    if (!check(sinew_world_get_transforms(world, NULL, current, body_count, &n), "sinew_world_get_transforms")) return 1;
    printf("loaded %s: %d bodies, %d soft bodies (first: %d particles)\n", path, body_count, soft_count, particle_count);

    for (frame = 0; frame < frames; ++frame) {
        /* A game's frame times jitter: 1/60 s +- 4 ms, deterministic so runs can be compared. */
        float dt = 1.0f / 60.0f + 0.004f * (float)((frame * 7) % 5 - 2) / 2.0f;
        int steps = 0;
        float alpha = 0.0f;
        if (!check(sinew_world_step(world, dt, &steps, &alpha), "sinew_world_step")) return 1;
        total_steps += steps;
        if (steps > 0) { /* a new state: the old one becomes the start of the interpolation */
            for (i = 0; i < body_count; ++i) previous[i] = current[i];
            if (!check(sinew_world_get_transforms(world, NULL, current, body_count, &n), "get_transforms")) return 1;
        }
        if (!check(sinew_soft_get_positions(cloth, particles, particle_count, &n), "sinew_soft_get_positions")) return 1;
        if (frame % 30 == 29) {
            sinew_transform top = interpolate(&previous[body_count - 1], &current[body_count - 1], alpha);
            float lowest = particles[0].y;
            for (k = 1; k < n; ++k)
                if (particles[k].y < lowest) lowest = particles[k].y;
            printf("frame %3d: %d step(s), alpha %.2f; top body rendered at (%.4f, %.4f, %.4f); "
                   "cloth lowest y = %.4f m\n",
                   frame + 1, steps, alpha, top.p.x, top.p.y, top.p.z, lowest);
        }
    }

    /* The final state, exactly (the test compares it with the tool's run of the same scene). */
    printf("final steps %d\n", total_steps);
    for (i = 0; i < body_count; ++i) {
        const sinew_transform* t = &current[i];
        printf("body %d %.9g %.9g %.9g %.9g %.9g %.9g %.9g\n", i, t->p.x, t->p.y, t->p.z, t->q.w, t->q.x, t->q.y, t->q.z);
    }
    for (k = 0; k < particle_count; ++k)
        printf("particle 0 %d %.9g %.9g %.9g\n", k, particles[k].x, particles[k].y, particles[k].z);

    free(particles);
    free(current);
    free(previous);
    return check(sinew_world_destroy(world), "sinew_world_destroy") ? 0 : 1;
}
