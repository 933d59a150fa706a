// The Bullet side of the FEM benchmark: btDeformableBody (a btSoftBody with tetras) in a
// btDeformableMultiBodyDynamicsWorld. Bullet is linked into this tool only, never into the library.
//
// Configuration (issue 13): the scene's nodes, tets and lumped masses exactly (clamped nodes get mass 0,
// Bullet's way of fixing a node), the body assembled as Bullet's own tet loaders do (appendTetra, the six
// edge links, generateBoundaryFaces, initializeDmInverse, the tetra scratches);
// btDeformableLinearElasticityForce with the scene's Lamé μ and λ and its Rayleigh α and β (Bullet's force
// damps by -α m v and -β K v, as Sinew's Rayleigh damping does), and
// btDeformableGravityForce. The default btDeformableBodySolver, one step of h per frame, soft-rigid
// contacts against a static ground box by signed distance (Bullet's deformable demos' flags). Sleeping is
// off on both sides so the timings measure the solver.
#include <btBulletDynamicsCommon.h>
#include <stdexcept>
#include <BulletSoftBody/btDeformableBodySolver.h>
#include <BulletSoftBody/btDeformableGravityForce.h>
#include <BulletSoftBody/btDeformableLinearElasticityForce.h>
#include <BulletSoftBody/btDeformableMultiBodyConstraintSolver.h>
#include <BulletSoftBody/btDeformableMultiBodyDynamicsWorld.h>
#include <BulletSoftBody/btSoftBodyHelpers.h>
#include <BulletSoftBody/btSoftBodyRigidBodyCollisionConfiguration.h>

#include <cmath>
#include <memory>

#include "tools/bench/bench_fem.hpp"
#include "tools/bench/bench_rigid.hpp"  // median()

namespace sinew::bench {

namespace {

btVector3 bt(const Vec3& v) { return btVector3(btScalar(v.x()), btScalar(v.y()), btScalar(v.z())); }

struct BulletFemWorld {
    btSoftBodyRigidBodyCollisionConfiguration config;
    btCollisionDispatcher dispatcher{&config};
    btDbvtBroadphase broadphase;
    btDeformableBodySolver body_solver;
    btDeformableMultiBodyConstraintSolver solver;
    std::unique_ptr<btDeformableMultiBodyDynamicsWorld> world;
    std::unique_ptr<btCollisionShape> ground_shape;
    std::unique_ptr<btRigidBody> ground;
    std::unique_ptr<btSoftBody> body;
    std::unique_ptr<btDeformableGravityForce> gravity;
    std::unique_ptr<btDeformableLinearElasticityForce> elasticity;

    BulletFemWorld() {
        solver.setDeformableSolver(&body_solver);
        world = std::make_unique<btDeformableMultiBodyDynamicsWorld>(&dispatcher, &broadphase, &solver, &config, &body_solver);
    }
    ~BulletFemWorld() {
        if (body) world->removeSoftBody(body.get());
        if (ground) world->removeRigidBody(ground.get());
    }
};

}  // namespace

// Bullet's element types (btVector3, btSoftBody::TetraScratch) leave their members uninitialised by
// design; GCC's -Wmaybe-uninitialized fires where their arrays are resized here, inlined from its headers.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
FemRun run_bullet_fem(const FemScene& s, int steps, BenchClock clock) {
    BulletFemWorld bw;
    btDeformableMultiBodyDynamicsWorld& world = *bw.world;
    world.setGravity(bt(s.gravity));
    btSoftBodyWorldInfo& info = world.getWorldInfo();
    info.m_gravity = bt(s.gravity);
    info.m_sparsesdf.setDefaultVoxelsz(btScalar(0.25));
    info.m_sparsesdf.Reset();
    if (s.has_ground) {
        bw.ground_shape = std::make_unique<btBoxShape>(btVector3(50, 50, 50));
        btRigidBody::btRigidBodyConstructionInfo ci(0, nullptr, bw.ground_shape.get());
        ci.m_startWorldTransform.setOrigin(btVector3(0, btScalar(s.ground_y - 50), 0));
        ci.m_friction = btScalar(s.friction);
        bw.ground = std::make_unique<btRigidBody>(ci);
        world.addRigidBody(bw.ground.get());
    }

    const std::size_t n = s.mesh.nodes.size();
    btAlignedObjectArray<btVector3> x;
    btAlignedObjectArray<btScalar> m;
    x.resize(int(n));
    m.resize(int(n));
    for (std::size_t i = 0; i < n; ++i) {
        x[int(i)] = bt(s.mesh.nodes[i]);
        m[int(i)] = btScalar(s.masses[i]);
    }
    for (const std::uint32_t i : s.pinned) m[int(i)] = 0;  // inverse mass 0: fixed
    bw.body = std::make_unique<btSoftBody>(&info, int(n), &x[0], &m[0]);
    btSoftBody& b = *bw.body;
    if (s.mesh.order != 1) throw std::runtime_error("Bullet's deformable bodies take linear (4-node) tets only");
    for (std::size_t e = 0; e < s.mesh.tet_count(); ++e) {
        const std::uint32_t* t = &s.mesh.tets[4 * e];
        const int a = int(t[0]), c = int(t[1]), d = int(t[2]), f = int(t[3]);
        b.appendTetra(a, c, d, f);
        b.appendLink(a, c, nullptr, true);
        b.appendLink(c, d, nullptr, true);
        b.appendLink(d, a, nullptr, true);
        b.appendLink(a, f, nullptr, true);
        b.appendLink(c, f, nullptr, true);
        b.appendLink(d, f, nullptr, true);
    }
    btSoftBodyHelpers::generateBoundaryFaces(&b);
    b.initializeDmInverse();
    b.m_tetraScratches.resize(b.m_tetras.size());
    b.m_tetraScratchesTn.resize(b.m_tetras.size());
    b.getCollisionShape()->setMargin(btScalar(s.thickness));
    b.m_cfg.kKHR = 1;
    b.m_cfg.kCHR = 1;
    b.m_cfg.kDF = btScalar(s.friction);
    b.m_cfg.collisions = btSoftBody::fCollision::SDF_RD | btSoftBody::fCollision::SDF_RDN;
    b.m_sleepingThreshold = 0;
    b.setActivationState(DISABLE_DEACTIVATION);
    world.addSoftBody(&b);
    bw.gravity = std::make_unique<btDeformableGravityForce>(bt(s.gravity));
    world.addForce(&b, bw.gravity.get());
    bw.elasticity = std::make_unique<btDeformableLinearElasticityForce>(
        btScalar(s.material.lame_mu()), btScalar(s.material.lame_lambda()), btScalar(s.material.mass_damping),
        btScalar(s.material.stiffness_damping));
    world.addForce(&b, bw.elasticity.get());

    FemRun run;
    run.scene = s.name;
    run.engine = "bullet";
    run.variant = "corotated r" + std::to_string(s.refinement);
    run.tets = int(s.mesh.tet_count());
    run.nodes = int(n);
    FemTracker track(s);
    std::vector<double> ms;
    ms.reserve(steps);
    std::vector<Vec3> pos(n);
    const btScalar h = btScalar(s.h);
    for (int i = 0; i < steps; ++i) {
        const double t0 = bench_clock_ms(clock);
        world.stepSimulation(h, 0);
        ms.push_back(bench_clock_ms(clock) - t0);
        ++run.steps;
        bool finite = true;
        for (std::size_t k = 0; k < n; ++k) {
            const btVector3& p = b.m_nodes[int(k)].m_x;
            pos[k] = Vec3(Real(p.x()), Real(p.y()), Real(p.z()));
            finite = finite && is_finite(pos[k]) && pos[k].cwiseAbs().maxCoeff() < Real(1e6);
        }
        if (!finite) {
            run.finite = false;
            break;
        }
        track.sample(pos, i, steps);
    }
    run.ms_per_step_median = median(ms);
    if (run.finite) track.finish(run, pos);
    return run;
}
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif

}  // namespace sinew::bench
