// The Bullet side of the rigid benchmark. Bullet is linked into this tool only, never into the library.
#include <btBulletDynamicsCommon.h>

#include <cmath>
#include <memory>
#include <stdexcept>

#include "tools/bench/bench_rigid.hpp"
#include "tools/bench/peers.hpp"

namespace sinew::bench {

bool bullet_peer_available() { return true; }

namespace {

btVector3 bt(const Vec3& v) { return btVector3(btScalar(v.x()), btScalar(v.y()), btScalar(v.z())); }
btQuaternion bt(const Quat& q) { return btQuaternion(btScalar(q.x()), btScalar(q.y()), btScalar(q.z()), btScalar(q.w())); }

struct BulletWorld {
    btDefaultCollisionConfiguration config;
    btCollisionDispatcher dispatcher{&config};
    btDbvtBroadphase broadphase;
    btSequentialImpulseConstraintSolver solver;
    btDiscreteDynamicsWorld world{&dispatcher, &broadphase, &solver, &config};
    std::vector<std::unique_ptr<btCollisionShape>> shapes;
    std::vector<std::unique_ptr<btTriangleIndexVertexArray>> mesh_data;
    std::vector<std::vector<int>> mesh_indices;
    std::vector<std::vector<btScalar>> mesh_vertices;
    std::vector<std::unique_ptr<btDefaultMotionState>> motion;
    std::vector<std::unique_ptr<btRigidBody>> bodies;
    std::vector<std::unique_ptr<btTypedConstraint>> joints;

    ~BulletWorld() {
        for (auto& j : joints) world.removeConstraint(j.get());
        for (auto& b : bodies) world.removeRigidBody(b.get());
    }

    btCollisionShape* make_shape(const Shape& s) {
        std::unique_ptr<btCollisionShape> out;
        switch (s.type) {
            case ShapeType::Sphere: out = std::make_unique<btSphereShape>(btScalar(s.radius)); break;
            case ShapeType::Box: out = std::make_unique<btBoxShape>(bt(s.half_extents)); break;
            case ShapeType::Capsule:
                out = std::make_unique<btCapsuleShape>(btScalar(s.radius), btScalar(2 * s.half_height));
                break;
            case ShapeType::ConvexHull: {
                auto hull = std::make_unique<btConvexHullShape>();
                for (const Vec3& v : s.hull->vertices) hull->addPoint(bt(v), false);
                hull->recalcLocalAabb();
                out = std::move(hull);
                break;
            }
            case ShapeType::Plane:
                out = std::make_unique<btStaticPlaneShape>(bt(s.normal), btScalar(s.offset));
                break;
            case ShapeType::TriangleMesh: {
                mesh_indices.emplace_back(s.mesh->indices.begin(), s.mesh->indices.end());
                mesh_vertices.emplace_back();
                for (const Vec3& v : s.mesh->vertices)
                    for (int k = 0; k < 3; ++k) mesh_vertices.back().push_back(btScalar(v[k]));
                mesh_data.push_back(std::make_unique<btTriangleIndexVertexArray>(
                    int(mesh_indices.back().size() / 3), mesh_indices.back().data(), 3 * int(sizeof(int)),
                    int(s.mesh->vertices.size()), mesh_vertices.back().data(), 3 * int(sizeof(btScalar))));
                out = std::make_unique<btBvhTriangleMeshShape>(mesh_data.back().get(), true);
                break;
            }
            case ShapeType::Compound: {
                auto c = std::make_unique<btCompoundShape>();
                for (const CompoundChild& ch : *s.children)
                    c->addChildShape(btTransform(bt(ch.local.q), bt(ch.local.p)), make_shape(*ch.shape));
                out = std::move(c);
                break;
            }
            default: throw std::runtime_error("bullet peer: unsupported shape");
        }
        shapes.push_back(std::move(out));
        return shapes.back().get();
    }
};

}  // namespace

namespace {

class BulletContender final : public RigidContender {
public:
    BulletContender(const SceneDesc& scene, int iterations) : h_(btScalar(scene.settings.time_step)) {
        const RigidSettings& rs = scene.settings.rigid;
        if (!scene.soft_bodies.empty()) throw std::runtime_error("bullet peer: soft bodies are not run here");
        bw_.world.setGravity(bt(rs.gravity));
        bw_.world.getSolverInfo().m_numIterations = iterations;
        for (const SceneBody& sb : scene.bodies) {
            const BodyDef& d = sb.def;
            btCollisionShape* shape = bw_.make_shape(d.shape);
            btScalar mass = 0;
            btVector3 inertia(0, 0, 0);
            if (d.type == BodyType::Dynamic) {
                // Bullet places the shape at the body origin; Sinew's generators use centred shapes, so
                // origin and centre of mass coincide for every benchmark body.
                mass = btScalar(d.mass > 0 ? d.mass : 1);
                shape->calculateLocalInertia(mass, inertia);
            }
            bw_.motion.push_back(std::make_unique<btDefaultMotionState>(btTransform(bt(d.pose.q), bt(d.pose.p))));
            btRigidBody::btRigidBodyConstructionInfo info(mass, bw_.motion.back().get(), shape, inertia);
            // Bullet multiplies the two bodies' friction; the square root makes the per-contact value the
            // geometric mean, the same mixing rule as Sinew (0.6 and 0.6 give 0.6).
            info.m_friction = btScalar(std::sqrt(d.material.friction));
            info.m_restitution = btScalar(d.material.restitution);
            info.m_linearDamping = btScalar(d.linear_damping);
            info.m_angularDamping = btScalar(d.angular_damping);
            bw_.bodies.push_back(std::make_unique<btRigidBody>(info));
            btRigidBody* body = bw_.bodies.back().get();
            if (d.type == BodyType::Kinematic)
                body->setCollisionFlags(body->getCollisionFlags() | btCollisionObject::CF_KINEMATIC_OBJECT);
            if (d.type == BodyType::Dynamic) {
                body->setLinearVelocity(bt(d.linear_velocity));
                body->setAngularVelocity(bt(d.angular_velocity));
                if (!rs.sleeping) body->setActivationState(DISABLE_DEACTIVATION);
                dynamic_.push_back(body);
            }
            bw_.world.addRigidBody(body);
        }
        for (const SceneJoint& sj : scene.joints) {
            if (sj.def.type != JointType::Ball || sj.soft_a || sj.soft_b)
                throw std::runtime_error("bullet peer: only ball joints between rigid bodies");
            // Pivots in each body's frame: the body origin is Bullet's centre of mass (centred shapes).
            bw_.joints.push_back(std::make_unique<btPoint2PointConstraint>(
                *bw_.bodies[sj.body_a], *bw_.bodies[sj.body_b], bt(sj.def.local_anchor_a), bt(sj.def.local_anchor_b)));
            bw_.world.addConstraint(bw_.joints.back().get(), !sj.def.collide_connected);
        }
        run.scene = scene.name;
        run.engine = "bullet";
        run.variant = "default";
        run.bodies = int(dynamic_.size());
        run.iterations = iterations;
    }
    void step() override { bw_.world.stepSimulation(h_, 0); }
    std::vector<Transform> poses() const override {
        std::vector<Transform> p(bw_.bodies.size());
        for (std::size_t i = 0; i < p.size(); ++i) {
            const btTransform& t = bw_.bodies[i]->getWorldTransform();
            const btQuaternion q = t.getRotation();
            p[i].p = Vec3(Real(t.getOrigin().x()), Real(t.getOrigin().y()), Real(t.getOrigin().z()));
            p[i].q = Quat(Real(q.w()), Real(q.x()), Real(q.y()), Real(q.z()));
        }
        return p;
    }
    std::vector<Vec3> positions() const override {
        std::vector<Vec3> p(dynamic_.size());
        for (std::size_t i = 0; i < dynamic_.size(); ++i) {
            const btVector3& o = dynamic_[i]->getWorldTransform().getOrigin();
            p[i] = Vec3(Real(o.x()), Real(o.y()), Real(o.z()));
        }
        return p;
    }

private:
    BulletWorld bw_;
    std::vector<btRigidBody*> dynamic_;
    btScalar h_;
};

}  // namespace

std::unique_ptr<RigidContender> make_bullet_contender(const SceneDesc& scene, int iterations) {
    return std::make_unique<BulletContender>(scene, iterations);
}

}  // namespace sinew::bench
