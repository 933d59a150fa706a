// Drops a box on the ground through the installed C++ interface and prints where it came to rest.
#include <cstdio>

#include "engine/world/world.hpp"

int main() {
    sinew::World world;
    sinew::BodyDef ground;
    ground.type = sinew::BodyType::Static;
    ground.shape = sinew::make_box(sinew::Vec3(10, 0.5f, 10));
    ground.pose.p = sinew::Vec3(0, -0.5f, 0);
    world.rigid().create_body(ground);
    sinew::BodyDef box;
    box.shape = sinew::make_box(sinew::Vec3(0.5f, 0.5f, 0.5f));
    box.pose.p = sinew::Vec3(0, 2, 0);
    sinew::BodyId id = world.rigid().create_body(box);
    for (int i = 0; i < 120; ++i) world.step();
    std::printf("box at rest at y = %.3f\n", double(world.rigid().transform(id).p.y()));
    return world.rigid().transform(id).p.y() > 0.4f && world.rigid().transform(id).p.y() < 0.6f ? 0 : 1;
}
