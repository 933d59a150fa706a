// The soft step solver's contact kernels (portable, SSE2, AVX: rigid/wide_float.hpp) do the same
// arithmetic in lanes of different widths without fused multiply-adds, so a scene must come out bit for
// bit the same under each. The scene mixes what the kernels treat differently: restitution (its own
// pass), a kinematic body (immovable but moving, shared by many lanes), boxes and spheres with manifolds
// of 1 to 4 points, and more manifolds than one batch holds.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include "engine/world/world.hpp"
#include "rigid/rigid_solver.hpp"

using namespace sinew;

namespace {

void add_ground(RigidSystem& rs) {
    BodyDef ground;
    ground.type = BodyType::Static;
    ground.shape = make_box(Vec3(20, 0.5, 20));
    ground.pose.p = Vec3(0, -0.5, 0);
    rs.create_body(ground);
}

/// Forces a kernel for its lifetime, so a failing assertion does not leave it forced for later tests.
struct ForceKernel {
    explicit ForceKernel(SimdKernel k) : ok(set_simd_kernel(k)) {}
    ~ForceKernel() { set_simd_kernel(SimdKernel::Auto); }
    bool ok;
};

std::vector<Real> run_scene(SimdKernel kernel) {
    ForceKernel force(kernel);
    REQUIRE(force.ok);
    WorldSettings ws;
    ws.time_step = Real(1) / 60;
    World world(ws);
    RigidSystem& rs = world.rigid();
    add_ground(rs);
    BodyDef paddle;
    paddle.type = BodyType::Kinematic;
    paddle.shape = make_box(Vec3(3, 0.1, 0.5));
    paddle.pose.p = Vec3(0, 0.1, 3);
    paddle.angular_velocity = Vec3(0, 1, 0);
    rs.create_body(paddle);
    for (int i = 0; i < 6; ++i)
        for (int j = 0; j < 5; ++j) {
            BodyDef b;
            b.shape = (i + j) % 3 == 0 ? make_sphere(Real(0.4)) : make_box(Vec3(0.5, 0.5, 0.5));
            b.pose.p = Vec3(Real(i) * Real(1.1) - 3, Real(0.5) + Real(j) * Real(1.05), Real(0.2) * Real(i % 2));
            b.pose.q = Quat(Eigen::AngleAxis<Real>(Real(0.05) * Real(i - j), Vec3::UnitY()));
            b.material.restitution = (i % 2) ? Real(0.5) : Real(0);
            rs.create_body(b);
        }
    for (int s = 0; s < 90; ++s) world.step();
    std::vector<Real> out;
    for (BodyId id : rs.bodies()) {
        const Transform xf = rs.transform(id);
        const Vec3 v = rs.linear_velocity(id), w = rs.angular_velocity(id);
        for (int k = 0; k < 3; ++k) out.insert(out.end(), {xf.p[k], v[k], w[k]});
        out.insert(out.end(), {xf.q.w(), xf.q.x(), xf.q.y(), xf.q.z()});
    }
    return out;
}

}  // namespace

TEST_CASE("every available contact kernel gives bit-identical results", "[rigid][simd]") {
    const std::vector<Real> reference = run_scene(SimdKernel::Portable);
    REQUIRE(!reference.empty());
    for (SimdKernel k : {SimdKernel::Sse2, SimdKernel::Avx}) {
        if (!simd_kernel_available(k)) continue;
        INFO("kernel " << simd_kernel_name(k));
        const std::vector<Real> got = run_scene(k);
        REQUIRE(got.size() == reference.size());
        CHECK(std::memcmp(got.data(), reference.data(), got.size() * sizeof(Real)) == 0);
    }
}

TEST_CASE("a body with more contacts than colours: the overflow manifolds hold the load too", "[rigid][simd]") {
    // A dynamic slab carries 48 small boxes: every box-slab manifold shares the slab, so at most 24 fit
    // the 24 colours and the rest run one per batch (overflow). All must carry their box: after 2 s every
    // box rests on the slab at its rest height (slab top 0.2 m + half extent 0.1 m = 0.3 m) within 5 mm
    // (the soft contacts' elastic sag under 0.2 kg is far below that; a box left unsupported would
    // have fallen 20 m in 2 s), under each kernel.
    for (SimdKernel k : {SimdKernel::Portable, SimdKernel::Sse2, SimdKernel::Avx}) {
        if (!simd_kernel_available(k)) continue;
        INFO("kernel " << simd_kernel_name(k));
        ForceKernel force(k);
        REQUIRE(force.ok);
        World world;
        RigidSystem& rs = world.rigid();
        add_ground(rs);
        BodyDef slab;
        slab.shape = make_box(Vec3(4, 0.1, 3));
        slab.pose.p = Vec3(0, 0.1, 0);
        slab.mass = 50;
        rs.create_body(slab);
        std::vector<BodyId> boxes;
        for (int i = 0; i < 8; ++i)
            for (int j = 0; j < 6; ++j) {
                BodyDef b;
                b.shape = make_box(Vec3(0.1, 0.1, 0.1));
                b.pose.p = Vec3(Real(i) - Real(3.5), Real(0.3), Real(j) - Real(2.5));
                b.mass = Real(0.2);
                boxes.push_back(rs.create_body(b));
            }
        for (int s = 0; s < 120; ++s) world.step();
        double worst = 0;
        for (BodyId id : boxes) worst = std::max(worst, std::abs(double(rs.transform(id).p.y()) - 0.3));
        CHECK(worst < 5e-3);
    }
}

TEST_CASE("an unavailable kernel is refused and the choice is unchanged", "[rigid][simd]") {
    const SimdKernel before = active_simd_kernel();
    for (SimdKernel k : {SimdKernel::Sse2, SimdKernel::Avx})
        if (!simd_kernel_available(k)) CHECK_FALSE(set_simd_kernel(k));
    CHECK(active_simd_kernel() == before);
    CHECK(set_simd_kernel(SimdKernel::Auto));
}
