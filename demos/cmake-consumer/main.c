/* Uses Sinew through sinew.h alone: a ball dropped for half a second. Built against the shared library
 * (sinew::shared, pkg-config) and, in a C-only project, against the static one (sinew::sinew). */
#include <stdio.h>

#include <sinew.h>

int main(void) {
    sinew_world_def wd = sinew_world_def_default();
    sinew_body_def ball = sinew_body_def_default();
    sinew_world_id world;
    sinew_body_id id;
    sinew_transform t;
    int i;
    ball.shape.type = SINEW_SHAPE_SPHERE;
    ball.transform.p.y = 10.0f;
    if (sinew_world_create(&wd, &world) != SINEW_OK || sinew_body_create(world, &ball, &id) != SINEW_OK) {
        fprintf(stderr, "sinew: %s\n", sinew_last_error());
        return 1;
    }
    for (i = 0; i < 30; ++i) sinew_world_step_fixed(world);
    sinew_body_get_transform(id, &t);
    printf("sinew %s: a ball dropped from 10 m is at %.2f m after 0.5 s\n", sinew_version(), t.p.y);
    sinew_world_destroy(world);
    return t.p.y < 9.0f && t.p.y > 8.5f ? 0 : 1; /* 10 - g t^2 / 2 = 8.77 m */
}
