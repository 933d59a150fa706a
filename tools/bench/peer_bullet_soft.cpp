// The Bullet side of the cloth benchmark: btSoftBody in a btSoftRigidDynamicsWorld. Bullet is linked into
// this tool only, never into the library.
//
// Configuration (issue 5): the cloth is btSoftBodyHelpers::CreatePatch with diagonals (structural and
// shear links, as Sinew's grid), the ball btSoftBodyHelpers::CreateFromTriMesh on Sinew's own icosphere;
// material kLST = 1, m_cfg.piterations = 10, everything else Bullet's defaults except what the scene
// fixes for both engines: gravity, node masses, the collision margin (= Sinew's particle thickness, where
// Bullet's default is 0.25 m), friction and the pressure constant. Sleeping is off on both sides so the
// timings measure the solver.
#include <btBulletDynamicsCommon.h>
#include <BulletSoftBody/btSoftBodyHelpers.h>
#include <BulletSoftBody/btSoftBodyRigidBodyCollisionConfiguration.h>
#include <BulletSoftBody/btSoftRigidDynamicsWorld.h>

#include <algorithm>
#include <cmath>
#include <memory>

#include "tools/bench/bench_cloth.hpp"
#include "tools/bench/bench_rigid.hpp"  // median()

namespace sinew::bench {

namespace {

btVector3 bt(const Vec3& v) { return btVector3(btScalar(v.x()), btScalar(v.y()), btScalar(v.z())); }

struct BulletSoftWorld {
    btSoftBodyRigidBodyCollisionConfiguration config;
    btCollisionDispatcher dispatcher{&config};
    btDbvtBroadphase broadphase;
    btSequentialImpulseConstraintSolver solver;
    btSoftRigidDynamicsWorld world{&dispatcher, &broadphase, &solver, &config};
    std::vector<std::unique_ptr<btCollisionShape>> shapes;
    std::vector<std::unique_ptr<btRigidBody>> statics;
    std::unique_ptr<btSoftBody> body;

    ~BulletSoftWorld() {
        if (body) world.removeSoftBody(body.get());
        for (auto& b : statics) world.removeRigidBody(b.get());
    }

    // A static collider. Bullet combines the node's kDF with the body's friction by product, so the body
    // gets friction 1 and the soft body kDF = the scene's friction.
    void add_static(std::unique_ptr<btCollisionShape> shape, const Vec3& at) {
        btRigidBody::btRigidBodyConstructionInfo info(0, nullptr, shape.get());
        info.m_startWorldTransform.setOrigin(bt(at));
        info.m_friction = 1;
        statics.push_back(std::make_unique<btRigidBody>(info));
        shapes.push_back(std::move(shape));
        world.addRigidBody(statics.back().get());
    }
};

double bullet_max_stretch(const btSoftBody& b) {
    double worst = 1;
    for (int i = 0; i < b.m_links.size(); ++i) {
        const btSoftBody::Link& l = b.m_links[i];
        worst = std::max(worst, double((l.m_n[0]->m_x - l.m_n[1]->m_x).length() / l.m_rl));
    }
    return worst;
}

}  // namespace

ClothRun run_bullet_soft(const ClothScene& s, int steps, BenchClock clock) {
    BulletSoftWorld bw;
    btSoftBodyWorldInfo& info = bw.world.getWorldInfo();
    info.m_gravity = bt(s.gravity);  // the world info's default is (0, -10, 0)
    bw.world.setGravity(bt(s.gravity));
    info.m_sparsesdf.Initialize();

    if (s.has_sphere) bw.add_static(std::make_unique<btSphereShape>(btScalar(s.sphere_radius)), s.sphere_centre);
    // The ground is a large box whose top face is y = ground_y: Bullet's soft-rigid contacts evaluate a
    // signed distance field of convex shapes only, so a btStaticPlaneShape would not collide.
    if (s.has_ground)
        bw.add_static(std::make_unique<btBoxShape>(btVector3(50, 50, 50)), Vec3(0, s.ground_y - 50, 0));

    btScalar free_mass = btScalar(s.total_mass);
    if (s.kind == ClothSceneKind::PressureBall) {
        std::vector<Vec3> verts;
        std::vector<std::uint32_t> tris;
        scene_ball_mesh(s, verts, tris);
        std::vector<btScalar> xyz;
        for (const Vec3& v : verts)
            for (int k = 0; k < 3; ++k) xyz.push_back(btScalar(v[k]));
        std::vector<int> idx(tris.begin(), tris.end());
        bw.body.reset(btSoftBodyHelpers::CreateFromTriMesh(info, xyz.data(), idx.data(), int(idx.size() / 3)));
        bw.body->m_cfg.kPR = btScalar(s.pressure);
    } else {
        const Vec3 c11 = s.corner10 + s.corner01 - s.corner00;
        const int fixeds = s.pin_corners ? 1 + 2 : 0;  // nodes (0, 0) and (n-1, 0), as Sinew pins
        bw.body.reset(btSoftBodyHelpers::CreatePatch(info, bt(s.corner00), bt(s.corner10), bt(s.corner01), bt(c11),
                                                     s.n, s.n, fixeds, true));
        // Sinew spreads the mass over all n^2 nodes and pins keep theirs; setTotalMass spreads over the
        // free nodes only, so give it the free nodes' share to make every node weigh the same on both sides.
        if (s.pin_corners) free_mass = btScalar(s.total_mass * double(s.n * s.n - 2) / double(s.n * s.n));
    }
    btSoftBody& b = *bw.body;
    b.m_materials[0]->m_kLST = 1;
    b.m_cfg.piterations = 10;
    b.m_cfg.kDF = btScalar(s.friction);
    b.setTotalMass(free_mass);
    b.getCollisionShape()->setMargin(btScalar(s.thickness));
    b.setActivationState(DISABLE_DEACTIVATION);
    bw.world.addSoftBody(&b);

    ClothRun run;
    run.scene = s.name;
    run.engine = "bullet";
    run.variant = "pi10";
    run.nodes = b.m_nodes.size();
    run.links = b.m_links.size();
    run.iterations = b.m_cfg.piterations;
    const double rest_volume = s.kind == ClothSceneKind::PressureBall ? double(b.getVolume()) : 0;
    std::vector<double> ms;
    ms.reserve(steps);
    const btScalar h = btScalar(s.h);
    std::vector<Vec3> x(b.m_nodes.size());
    for (int i = 0; i < steps; ++i) {
        const double t0 = bench_clock_ms(clock);
        bw.world.stepSimulation(h, 0);
        ms.push_back(bench_clock_ms(clock) - t0);
        ++run.steps;
        bool finite = true;
        for (int k = 0; k < b.m_nodes.size() && finite; ++k) {
            const btVector3& p = b.m_nodes[k].m_x;
            finite = std::isfinite(p.x()) && std::isfinite(p.y()) && std::isfinite(p.z());
        }
        const double stretch = bullet_max_stretch(b);
        if (!finite || !std::isfinite(stretch)) {
            run.finite = false;
            break;
        }
        run.peak_stretch = std::max(run.peak_stretch, stretch);
    }
    for (int k = 0; k < b.m_nodes.size(); ++k) {
        const btVector3& p = b.m_nodes[k].m_x;
        x[k] = Vec3(Real(p.x()), Real(p.y()), Real(p.z()));
    }
    run.ms_per_step_median = median(ms);
    run.max_stretch = bullet_max_stretch(b);
    if (rest_volume > 0) run.volume_ratio = double(b.getVolume()) / rest_volume;
    run.max_penetration = scene_penetration(s, x);
    return run;
}

}  // namespace sinew::bench
