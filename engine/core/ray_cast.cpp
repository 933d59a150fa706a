// Ray against each shape type, in the shape's local frame.
#include "engine/core/ray_cast.hpp"

#include <algorithm>
#include <cmath>

namespace sinew {
namespace {

struct LocalHit {
    Real t;
    Vec3 normal;
};

// |o + t d - c|^2 = r^2, smallest t in [0, t_max]; from outside only.
bool ray_sphere(const Vec3& o, const Vec3& d, const Vec3& c, Real r, Real t_max, LocalHit& out) {
    const Vec3 m = o - c;
    const Real cc = m.squaredNorm() - r * r;
    if (cc <= 0) return false;  // starts inside
    const Real a = d.squaredNorm();
    if (a == 0) return false;
    const Real b = m.dot(d);
    if (b >= 0) return false;  // moving away
    const Real disc = b * b - a * cc;
    if (disc < 0) return false;
    const Real t = (-b - std::sqrt(disc)) / a;
    if (t < 0 || t > t_max) return false;
    out.t = t;
    out.normal = (m + t * d).normalized();
    return true;
}

// Slab method (Kay & Kajiya); the entering slab gives the normal.
bool ray_box(const Vec3& o, const Vec3& d, const Vec3& he, Real t_max, LocalHit& out) {
    Real t0 = 0, t1 = t_max;
    int axis = -1;
    Real sign = 0;
    for (int k = 0; k < 3; ++k) {
        if (std::abs(d[k]) < Real(1e-12)) {
            if (o[k] < -he[k] || o[k] > he[k]) return false;
            continue;
        }
        const Real inv = Real(1) / d[k];
        Real a = (-he[k] - o[k]) * inv, b = (he[k] - o[k]) * inv;
        Real s = -1;
        if (a > b) std::swap(a, b), s = 1;
        if (a > t0) t0 = a, axis = k, sign = s;
        t1 = std::min(t1, b);
        if (t0 > t1) return false;
    }
    if (axis < 0) return false;  // starts inside
    out.t = t0;
    out.normal = Vec3::Zero();
    out.normal[axis] = sign;
    return true;
}

// The capsule is the union of the cylinder between the caps and the two cap spheres.
bool ray_capsule(const Vec3& o, const Vec3& d, Real hh, Real r, Real t_max, LocalHit& out) {
    // Inside test first: distance to the segment.
    const Vec3 c0(0, std::clamp(o.y(), -hh, hh), 0);
    if ((o - c0).squaredNorm() <= r * r) return false;
    bool hit = false;
    // Infinite cylinder around y: (ox + t dx)^2 + (oz + t dz)^2 = r^2.
    const Real a = d.x() * d.x() + d.z() * d.z();
    if (a > 0) {
        const Real b = o.x() * d.x() + o.z() * d.z();
        const Real c = o.x() * o.x() + o.z() * o.z() - r * r;
        const Real disc = b * b - a * c;
        if (disc >= 0) {
            const Real t = (-b - std::sqrt(disc)) / a;
            const Real y = o.y() + t * d.y();
            if (t >= 0 && t <= t_max && y >= -hh && y <= hh) {
                out.t = t;
                out.normal = Vec3(o.x() + t * d.x(), 0, o.z() + t * d.z()).normalized();
                hit = true;
            }
        }
    }
    for (Real cy : {-hh, hh}) {
        LocalHit s;
        if (ray_sphere(o, d, Vec3(0, cy, 0), r, hit ? out.t : t_max, s)) {
            out = s;
            hit = true;
        }
    }
    return hit;
}

// Cyrus-Beck clipping against the face planes.
bool ray_hull(const Vec3& o, const Vec3& d, const ConvexHullData& hull, Real t_max, LocalHit& out) {
    Real t0 = 0, t1 = t_max;
    int entering = -1;
    for (std::size_t f = 0; f < hull.faces.size(); ++f) {
        const Vec3& n = hull.faces[f].normal;
        const Real num = hull.faces[f].offset - n.dot(o);  // > 0: origin inside this face's half-space
        const Real den = n.dot(d);
        if (den == 0) {
            if (num < 0) return false;
            continue;
        }
        const Real t = num / den;
        if (den < 0) {  // entering
            if (t > t0) t0 = t, entering = static_cast<int>(f);
        } else {
            t1 = std::min(t1, t);
        }
        if (t0 > t1) return false;
    }
    if (entering < 0) return false;  // starts inside
    out.t = t0;
    out.normal = hull.faces[entering].normal;
    return true;
}

// Möller-Trumbore; both sides.
bool ray_triangle(const Vec3& o, const Vec3& d, const Triangle& tri, Real t_max, LocalHit& out) {
    const Vec3 e1 = tri.b - tri.a, e2 = tri.c - tri.a;
    const Vec3 p = d.cross(e2);
    const Real det = e1.dot(p);
    if (std::abs(det) < Real(1e-12)) return false;
    const Real inv = Real(1) / det;
    const Vec3 s = o - tri.a;
    const Real u = s.dot(p) * inv;
    if (u < 0 || u > 1) return false;
    const Vec3 q = s.cross(e1);
    const Real v = d.dot(q) * inv;
    if (v < 0 || u + v > 1) return false;
    const Real t = e2.dot(q) * inv;
    if (t < 0 || t > t_max) return false;
    out.t = t;
    Vec3 n = e1.cross(e2).normalized();
    out.normal = n.dot(d) > 0 ? Vec3(-n) : n;
    return true;
}

bool ray_mesh(const Vec3& o, const Vec3& d, const TriangleMeshData& mesh, Real t_max, LocalHit& out) {
    Aabb box;
    box.grow(o);
    box.grow(o + t_max * d);
    bool hit = false;
    Real best = t_max;
    mesh.query(box, [&](std::uint32_t t) {
        LocalHit h;
        if (ray_triangle(o, d, mesh.triangle(t), best, h)) {
            best = h.t;
            out = h;
            hit = true;
        }
    });
    return hit;
}

bool ray_local(const Shape& s, const Vec3& o, const Vec3& d, Real t_max, LocalHit& out) {
    switch (s.type) {
        case ShapeType::Sphere: return ray_sphere(o, d, Vec3::Zero(), s.radius, t_max, out);
        case ShapeType::Box: return ray_box(o, d, s.half_extents, t_max, out);
        case ShapeType::Capsule: return ray_capsule(o, d, s.half_height, s.radius, t_max, out);
        case ShapeType::ConvexHull: return ray_hull(o, d, *s.hull, t_max, out);
        case ShapeType::Plane: {
            const Real above = s.normal.dot(o) - s.offset;
            const Real den = s.normal.dot(d);
            if (above <= 0 || den >= 0) return false;  // starts below, or runs parallel or away
            const Real t = -above / den;
            if (t > t_max) return false;
            out.t = t;
            out.normal = s.normal;
            return true;
        }
        case ShapeType::TriangleMesh: return ray_mesh(o, d, *s.mesh, t_max, out);
        case ShapeType::Compound: {
            bool hit = false;
            for (const CompoundChild& c : *s.children) {
                const Vec3 co = c.local.apply_inverse(o), cd = c.local.rotate_inverse(d);
                LocalHit h;
                if (ray_local(*c.shape, co, cd, hit ? out.t : t_max, h)) {
                    out = {h.t, c.local.rotate(h.normal)};
                    hit = true;
                }
            }
            return hit;
        }
        default: return false;
    }
}

}  // namespace

bool ray_cast(const Shape& shape, const Transform& xf, const Vec3& from, const Vec3& to, Real max_fraction,
              RayHit& hit) {
    const Vec3 o = xf.apply_inverse(from);
    const Vec3 d = xf.rotate_inverse(to - from);
    LocalHit h;
    if (!ray_local(shape, o, d, max_fraction, h)) return false;
    hit.fraction = h.t;
    hit.point = from + h.t * (to - from);
    hit.normal = xf.rotate(h.normal);
    return true;
}

}  // namespace sinew
