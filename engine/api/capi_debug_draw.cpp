// Debug draw (sinew_world_draw): the world as it is now handed to the host's renderer as spheres,
// capsules, boxes, triangles, segments and points, in body slot order.
#include <cmath>

#include "engine/api/capi_internal.hpp"
#include "rigid/joint_set.hpp"

namespace sinew::capi {

namespace {

constexpr std::uint32_t kStatic = 0x8A8F98, kKinematic = 0xE0A040, kAwake = 0x5CB85C, kAsleep = 0x6F8090,
                        kSensor = 0x58D68D, kSoft = 0x4AA3DF, kPoint = 0xE04040, kSpeculative = 0xB07070, kNormal = 0xF0D040, kJoint = 0x40D0E0;
constexpr Real kPlaneHalf = 50;      // m: a plane is drawn as a square this far each way
constexpr Real kNormalLength = Real(0.2);
constexpr float kPointSize = 0.05f;

struct Drawer {
    const sinew_debug_draw& d;

    void triangle(const Vec3& a, const Vec3& b, const Vec3& c, std::uint32_t color) const {
        if (d.draw_triangle) d.draw_triangle(d.context, capi::to_c(a), capi::to_c(b), capi::to_c(c), color);
    }
    void segment(const Vec3& a, const Vec3& b, std::uint32_t color) const {
        if (d.draw_segment) d.draw_segment(d.context, capi::to_c(a), capi::to_c(b), color);
    }

    void shape(const Shape& s, const Transform& xf, std::uint32_t color) const {
        switch (s.type) {
            case ShapeType::Sphere:
                if (d.draw_sphere) d.draw_sphere(d.context, capi::to_c(xf.p), float(s.radius), color);
                break;
            case ShapeType::Capsule:
                if (d.draw_capsule)
                    d.draw_capsule(d.context, capi::to_c(xf.apply(Vec3(0, -s.half_height, 0))),
                                   capi::to_c(xf.apply(Vec3(0, s.half_height, 0))), float(s.radius), color);
                break;
            case ShapeType::Box:
                if (d.draw_box) d.draw_box(d.context, to_c(xf), capi::to_c(s.half_extents), color);
                break;
            case ShapeType::ConvexHull:
                for (const ConvexHullData::Face& f : s.hull->faces)
                    for (std::size_t k = 2; k < f.verts.size(); ++k)
                        triangle(xf.apply(s.hull->vertices[f.verts[0]]), xf.apply(s.hull->vertices[f.verts[k - 1]]),
                                 xf.apply(s.hull->vertices[f.verts[k]]), color);
                break;
            case ShapeType::TriangleMesh:
                for (std::size_t i = 0; i < s.mesh->triangle_count(); ++i) {
                    const Triangle t = s.mesh->triangle(i);
                    triangle(xf.apply(t.a), xf.apply(t.b), xf.apply(t.c), color);
                }
                break;
            case ShapeType::Plane: {
                // A square centred on the plane's point nearest the origin, spanned by two in-plane axes.
                const Vec3 n = xf.rotate(s.normal).normalized();
                const Vec3 c = xf.apply(s.normal * s.offset);
                const Vec3 u = (std::abs(n.x()) < Real(0.9) ? Vec3::UnitX() : Vec3::UnitY()).cross(n).normalized() * kPlaneHalf;
                const Vec3 v = n.cross(u);
                triangle(c - u - v, c + u - v, c + u + v, color);
                triangle(c - u - v, c + u + v, c - u + v, color);
                break;
            }
            case ShapeType::Compound:
                for (const CompoundChild& ch : *s.children) shape(*ch.shape, xf * ch.local, color);
                break;
            default: break;
        }
    }
};

}  // namespace

}  // namespace sinew::capi

using namespace sinew;
using namespace sinew::capi;

extern "C" {

sinew_debug_draw sinew_debug_draw_default(void) {
    sinew_debug_draw d{};
    d.draw_shapes = d.draw_joints = d.draw_contacts = d.draw_soft_bodies = 1;
    return d;
}

sinew_status sinew_world_draw(sinew_world_id world, const sinew_debug_draw* draw) {
    const char* fn = "sinew_world_draw";
    return guarded(fn, [&] {
        if (!draw) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": draw is NULL");
        World* w = find_world(world, fn);
        if (!w) return SINEW_ERROR_STALE_ID;
        if (sinew_status s = check_not_stepping(w, fn)) return s;
        const Drawer out{*draw};
        const RigidSystem& r = w->rigid();
        if (draw->draw_shapes) {
            for (std::uint32_t s = 0; s < r.slot_count(); ++s) {
                if (!r.slot_alive(s)) continue;
                const BodyId id = r.id_of_slot(s);
                std::uint32_t color = kAwake;
                if (r.slot_sensor(s)) color = kSensor;
                else if (r.slot_type(s) == BodyType::Static) color = kStatic;
                else if (r.slot_type(s) == BodyType::Kinematic) color = kKinematic;
                else if (!r.awake(id)) color = kAsleep;
                out.shape(r.slot_shape(s), r.slot_transform(s), color);
            }
        }
        if (draw->draw_joints) {
            for (const JointId j : r.joints().ids()) {
                const JointDef& d = r.joints().def(j);
                if (!r.valid(d.body_a) || !r.valid(d.body_b)) continue;
                const Transform xa = r.transform(d.body_a), xb = r.transform(d.body_b);
                const Vec3 pa = xa.apply(d.local_anchor_a), pb = xb.apply(d.local_anchor_b);
                out.segment(r.state().x[d.body_a.index], pa, kJoint);
                out.segment(pa, pb, kJoint);
                out.segment(pb, r.state().x[d.body_b.index], kJoint);
            }
        }
        if (draw->draw_contacts) {
            for (const ContactManifold& c : r.contacts())
                for (int k = 0; k < c.manifold.count; ++k) {
                    const ContactPoint& p = c.manifold.points[k];
                    // A speculative point (still apart, within the contact margin) in its own colour.
                    const std::uint32_t color = p.depth < 0 ? kSpeculative : kPoint;
                    if (draw->draw_point) draw->draw_point(draw->context, capi::to_c(p.position), kPointSize, color);
                    out.segment(p.position, p.position + kNormalLength * c.manifold.normal, kNormal);
                }
        }
        if (draw->draw_soft_bodies) {
            const SoftSystem& soft = w->soft();
            for (std::uint32_t s = 0; s < soft.slot_count(); ++s) {
                if (!soft.slot_alive(s)) continue;
                const SoftBody& b = soft.slot_body(s);
                const std::vector<Vec3>& x = b.p.x;
                if (!b.triangles.empty()) {
                    for (std::size_t t = 0; t + 2 < b.triangles.size(); t += 3)
                        out.triangle(x[b.triangles[t]], x[b.triangles[t + 1]], x[b.triangles[t + 2]], kSoft);
                } else {
                    for (const Link& l : b.links) out.segment(x[l.a], x[l.b], kSoft);
                }
            }
        }
        return SINEW_OK;
    });
}

}  // extern "C"
