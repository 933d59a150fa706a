// Signed distance of a point to every shape type, with the closest surface point and outward normal.
// Particles are small spheres, so this one query is their whole narrow phase.
#include <algorithm>
#include <cmath>

#include "soft/particle_collision.hpp"
#include "soft/triangle_closest.hpp"

namespace sinew {
namespace {

constexpr Real kTiny = Real(1e-9);  // below this a direction is undefined (m)

Vec3 closest_on_segment(const Vec3& p, const Vec3& a, const Vec3& b) {
    const Vec3 ab = b - a;
    const Real len2 = ab.squaredNorm();
    const Real t = len2 > 0 ? std::clamp((p - a).dot(ab) / len2, Real(0), Real(1)) : Real(0);
    return a + t * ab;
}

// A query in the shape's local frame.
struct Local {
    Vec3 surface;
    Vec3 normal;
    Real distance;
};

bool sphere_local(const Vec3& q, Real radius, Real max_d, Local& out) {
    const Real len = q.norm();
    if (len - radius > max_d) return false;
    out.normal = len > kTiny ? Vec3(q / len) : Vec3::UnitY();
    out.surface = radius * out.normal;
    out.distance = len - radius;
    return true;
}

bool box_local(const Vec3& q, const Vec3& he, Real max_d, Local& out) {
    const Vec3 clamped = q.cwiseMax(-he).cwiseMin(he);
    const Vec3 d = q - clamped;
    const Real d2 = d.squaredNorm();
    if (d2 > 0) {  // outside: the clamped point is the closest
        const Real len = std::sqrt(d2);
        if (len > max_d) return false;
        out.surface = clamped;
        out.normal = d / len;
        out.distance = len;
        return true;
    }
    // Inside: leave through the nearest face.
    int axis = 0;
    Real best = he.x() - std::abs(q.x());
    for (int k = 1; k < 3; ++k) {
        const Real gap = he[k] - std::abs(q[k]);
        if (gap < best) best = gap, axis = k;
    }
    out.normal = Vec3::Zero();
    out.normal[axis] = q[axis] >= 0 ? Real(1) : Real(-1);
    out.surface = q;
    out.surface[axis] = out.normal[axis] * he[axis];
    out.distance = -best;
    return true;
}

bool hull_local(const Vec3& q, const ConvexHullData& hull, Real max_d, Local& out) {
    Real deepest = -kRealMax;
    int deepest_face = 0;
    for (std::size_t f = 0; f < hull.faces.size(); ++f) {
        const Real s = hull.faces[f].normal.dot(q) - hull.faces[f].offset;
        if (s > deepest) deepest = s, deepest_face = static_cast<int>(f);
    }
    if (deepest > max_d) return false;  // the distance is at least the largest face separation
    if (deepest <= 0) {                  // inside: leave through the least deep face
        out.normal = hull.faces[deepest_face].normal;
        out.surface = q - deepest * out.normal;
        out.distance = deepest;
        return true;
    }
    // Outside: the closest point lies inside a face the point is in front of, or on an edge.
    Real best2 = kRealMax;
    for (std::size_t f = 0; f < hull.faces.size(); ++f) {
        const auto& face = hull.faces[f];
        const Real s = face.normal.dot(q) - face.offset;
        if (s <= 0) continue;
        const Vec3 proj = q - s * face.normal;
        bool inside = true;
        for (std::size_t k = 0; k < face.verts.size() && inside; ++k) {
            const Vec3& a = hull.vertices[face.verts[k]];
            const Vec3& b = hull.vertices[face.verts[(k + 1) % face.verts.size()]];
            inside = (b - a).cross(proj - a).dot(face.normal) >= 0;
        }
        if (inside && s * s < best2) best2 = s * s, out.surface = proj;
    }
    for (const auto& e : hull.edges) {
        const Vec3 c = closest_on_segment(q, hull.vertices[e.first], hull.vertices[e.second]);
        const Real d2 = (q - c).squaredNorm();
        if (d2 < best2) best2 = d2, out.surface = c;
    }
    out.distance = std::sqrt(best2);
    if (out.distance > max_d) return false;
    out.normal = out.distance > kTiny ? Vec3((q - out.surface) / out.distance) : hull.faces[deepest_face].normal;
    return true;
}

// Meshes are open surfaces: a point behind the nearest triangle is inside (distance < 0, pushed out
// along the triangle's normal), in front it is outside.
bool mesh_local(const Vec3& q, const TriangleMeshData& mesh, Real max_d, Local& out) {
    Aabb box;
    box.grow(q);
    box = box.fattened(max_d);
    Real best2 = kRealMax;
    std::size_t best_tri = 0;
    Vec3 best_c = Vec3::Zero();
    mesh.query(box, [&](std::uint32_t t) {
        const Triangle tri = mesh.triangle(t);
        const Vec3 c = closest_on_triangle(q, tri.a, tri.b, tri.c);
        const Real d2 = (q - c).squaredNorm();
        if (d2 < best2) best2 = d2, best_tri = t, best_c = c;
    });
    if (best2 == kRealMax) return false;
    const Triangle tri = mesh.triangle(best_tri);
    Vec3 n = (tri.b - tri.a).cross(tri.c - tri.a);
    n.normalize();
    const Real len = std::sqrt(best2);
    const Vec3 d = q - best_c;
    out.surface = best_c;
    if (d.dot(n) >= 0) {
        if (len > max_d) return false;
        out.distance = len;
        out.normal = len > kTiny ? Vec3(d / len) : n;
    } else {
        out.distance = -len;
        out.normal = n;
    }
    return true;
}

}  // namespace

bool point_shape_distance(const Vec3& point, const Shape& shape, const Transform& xf, Real max_distance,
                          Vec3& surface_point, Vec3& normal, Real& distance) {
    const Vec3 q = xf.apply_inverse(point);
    Local l{};
    bool hit = false;
    switch (shape.type) {
        case ShapeType::Sphere: hit = sphere_local(q, shape.radius, max_distance, l); break;
        case ShapeType::Box: hit = box_local(q, shape.half_extents, max_distance, l); break;
        case ShapeType::Capsule: {
            const Vec3 c = closest_on_segment(q, Vec3(0, -shape.half_height, 0), Vec3(0, shape.half_height, 0));
            hit = sphere_local(q - c, shape.radius, max_distance, l);
            l.surface += c;
            break;
        }
        case ShapeType::ConvexHull: hit = hull_local(q, *shape.hull, max_distance, l); break;
        case ShapeType::Plane: {
            l.distance = shape.normal.dot(q) - shape.offset;
            hit = l.distance <= max_distance;
            l.normal = shape.normal;
            l.surface = q - l.distance * shape.normal;
            break;
        }
        case ShapeType::TriangleMesh: hit = mesh_local(q, *shape.mesh, max_distance, l); break;
        case ShapeType::Compound: {
            // The child with the smallest signed distance decides (the deepest one the point is inside, else
            // the nearest): the compound is the union of its children.
            for (const CompoundChild& child : *shape.children) {
                Vec3 s, n;
                Real d;
                if (point_shape_distance(q, *child.shape, child.local, max_distance, s, n, d) &&
                    (!hit || d < l.distance)) {
                    hit = true;
                    l = {s, n, d};
                }
            }
            break;
        }
        default: break;
    }
    if (!hit) return false;
    surface_point = xf.apply(l.surface);
    normal = xf.rotate(l.normal);
    distance = l.distance;
    return true;
}

}  // namespace sinew
