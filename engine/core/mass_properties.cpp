// Mass properties at uniform density. Everything is accumulated in double and rounded to Real once at
// the end: the hull sum cancels large signed tetrahedron terms and the compound sum subtracts
// m c cᵀ from second moments, both of which lose most of float's 24 bits on off-centre shapes.
#include "engine/core/mass_properties.hpp"
#include "engine/core/format.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace sinew {

namespace {

using Vec3d = Eigen::Vector3d;
using Mat3d = Eigen::Matrix3d;

constexpr double kPiD = 3.14159265358979323846;

/// Mass properties at unit density (so mass == volume), in double.
struct UnitMass {
    double volume = 0;
    Vec3d center = Vec3d::Zero();
    Mat3d inertia = Mat3d::Zero();  ///< about `center`, per unit density
};

void require_dimension(Real x, const char* what) {
    if (!is_finite(x) || x <= 0) throw ShapeError(std::string(what) + " must be finite and > 0, got " + to_text(x));
}

UnitMass sphere_mass(Real radius_r) {
    require_dimension(radius_r, "sphere radius");
    const double r = radius_r;
    UnitMass u;
    u.volume = 4.0 / 3.0 * kPiD * r * r * r;
    u.inertia = Mat3d::Identity() * (0.4 * u.volume * r * r);  // 2/5 m r²
    return u;
}

UnitMass box_mass(const Vec3& he) {
    require_dimension(he.x(), "box half extent x");
    require_dimension(he.y(), "box half extent y");
    require_dimension(he.z(), "box half extent z");
    const double a = he.x(), b = he.y(), c = he.z();
    UnitMass u;
    u.volume = 8.0 * a * b * c;
    // m/12 (w² + h²) with full widths 2a, 2b, 2c, i.e. m/3 (b² + c²) with half extents.
    const double k = u.volume / 3.0;
    u.inertia = Vec3d(k * (b * b + c * c), k * (a * a + c * c), k * (a * a + b * b)).asDiagonal();
    return u;
}

// Capsule along y: a cylinder of radius r and length 2h plus two hemispheres of radius r whose flat
// faces sit at y = ±h.
//  cylinder (mass mc):   Iyy = mc r²/2,  Ixx = Izz = mc (r²/4 + (2h)²/12) = mc (r²/4 + h²/3)
//  hemisphere (mass ms/2 each, ms = mass of the whole sphere): about the centre of its flat face, the
//    same 2/5 (ms/2) r² as the sphere on every axis. Its centroid lies 3r/8 from that face, so about its
//    own centroid the transverse moment is (ms/2)(2/5 r² - (3r/8)²) = (ms/2)(83/320) r². Shifting it
//    to the capsule centre, at distance h + 3r/8 from the centroid, gives
//    (ms/2)(83/320 r² + (h + 3r/8)²) = (ms/2)(2/5 r² + h² + 3/4 h r).
//  Both hemispheres: Ixx += ms (2/5 r² + h² + 3/4 h r), Iyy += 2/5 ms r².
// (Forgetting the 3r/8 offset and shifting by h alone underestimates Ixx by ms (3/4 h r).)
UnitMass capsule_mass(Real half_height, Real radius_r) {
    require_dimension(radius_r, "capsule radius");
    if (!is_finite(half_height) || half_height < 0)
        throw ShapeError("capsule half height must be finite and >= 0, got " + to_text(half_height));
    const double r = radius_r, h = half_height;
    const double r2 = r * r;
    const double mc = kPiD * r2 * 2.0 * h;
    const double ms = 4.0 / 3.0 * kPiD * r2 * r;
    UnitMass u;
    u.volume = mc + ms;
    const double ixx = mc * (r2 / 4.0 + h * h / 3.0) + ms * (0.4 * r2 + h * h + 0.75 * h * r);
    const double iyy = mc * r2 / 2.0 + ms * 0.4 * r2;
    u.inertia = Vec3d(ixx, iyy, ixx).asDiagonal();
    return u;
}

// Convex hull by the divergence theorem (Mirtich 1996; Eberly, "Polyhedral Mass Properties"): the solid
// is the union of tetrahedra (p0, a, b, c) fanned from a reference point p0 to each boundary triangle,
// every polygonal face itself fanned from its first vertex. With x_i = vertex - p0 and D = det[x1 x2 x3]
// (6x the signed volume; positive for counter-clockwise faces seen from outside):
//   volume   = D / 6
//   ∫ x dV   = D / 24 (x1 + x2 + x3)
//   ∫ x xᵀ dV = D / 120 (Σ x_i x_iᵀ + (Σ x_i)(Σ x_i)ᵀ)      (covariance of the canonical tetrahedron)
// p0 is the vertex mean so the x_i are small and the sums do not cancel catastrophically.
UnitMass hull_mass(const ConvexHullData* hull) {
    if (!hull) throw ShapeError("convex hull shape has no hull data");
    const std::size_t nv = hull->vertices.size();
    if (nv < 4 || hull->faces.size() < 4)
        throw ShapeError("convex hull needs >= 4 vertices and >= 4 faces, got " + std::to_string(nv) + " vertices and " +
                         std::to_string(hull->faces.size()) + " faces");
    Vec3d p0 = Vec3d::Zero();
    for (const Vec3& v : hull->vertices) {
        if (!is_finite(v)) throw ShapeError("convex hull vertex is not finite");
        p0 += v.cast<double>();
    }
    p0 /= static_cast<double>(nv);

    double six_volume = 0;
    Vec3d first = Vec3d::Zero();   // 24 ∫ x dV
    Mat3d second = Mat3d::Zero();  // 120 ∫ x xᵀ dV
    for (std::size_t f = 0; f < hull->faces.size(); ++f) {
        const auto& idx = hull->faces[f].verts;
        if (idx.size() < 3) throw ShapeError("convex hull face " + std::to_string(f) + " has fewer than 3 vertices");
        for (std::uint16_t i : idx)
            if (i >= nv) throw ShapeError("convex hull face " + std::to_string(f) + " uses vertex " + std::to_string(i) +
                                          " of " + std::to_string(nv));
        const Vec3d x1 = hull->vertices[idx[0]].cast<double>() - p0;
        for (std::size_t k = 1; k + 1 < idx.size(); ++k) {
            const Vec3d x2 = hull->vertices[idx[k]].cast<double>() - p0;
            const Vec3d x3 = hull->vertices[idx[k + 1]].cast<double>() - p0;
            const double d = x1.dot(x2.cross(x3));
            const Vec3d s = x1 + x2 + x3;
            six_volume += d;
            first += d * s;
            second += d * (x1 * x1.transpose() + x2 * x2.transpose() + x3 * x3.transpose() + s * s.transpose());
        }
    }
    // Consistently clockwise faces flip every term's sign; accept them rather than return a negative
    // mass. A hull with (near) zero volume is degenerate.
    if (six_volume < 0) {
        six_volume = -six_volume;
        first = -first;
        second = -second;
    }
    double extent = 0;
    for (const Vec3& v : hull->vertices) extent = std::max(extent, (v.cast<double>() - p0).norm());
    if (!(six_volume > 1e-12 * std::pow(extent, 3)))
        throw ShapeError("convex hull is degenerate (volume " + to_text(six_volume / 6.0) + ")");

    UnitMass u;
    u.volume = six_volume / 6.0;
    const Vec3d c = first / (24.0 * u.volume);  // centroid relative to p0
    Mat3d cov = second / 120.0 - u.volume * c * c.transpose();  // about the centroid
    u.center = p0 + c;
    u.inertia = Mat3d::Identity() * cov.trace() - cov;  // I = tr(C) E - C
    return u;
}

UnitMass shape_mass(const Shape& shape);

// Compound: rotate each child's tensor into the compound frame (R I Rᵀ) and move it to the compound's
// centre of mass with the parallel-axis theorem, I += m (|d|² E - d dᵀ). Overlapping children count
// their shared volume twice, as a sum of separate solids does.
UnitMass compound_mass(const Shape& shape) {
    if (!shape.children || shape.children->empty()) throw ShapeError("compound has no children");
    struct Part {
        double m;
        Vec3d c;
        Mat3d i;
    };
    std::vector<Part> parts;
    parts.reserve(shape.children->size());
    UnitMass u;
    Vec3d moment = Vec3d::Zero();
    for (const CompoundChild& child : *shape.children) {
        if (!child.shape) throw ShapeError("compound child has no shape");
        if (child.shape->type == ShapeType::Compound) throw ShapeError("compound child is itself a compound");
        const UnitMass cm = shape_mass(*child.shape);
        const Mat3d r = child.local.q.cast<double>().normalized().toRotationMatrix();
        const Vec3d c = r * cm.center + child.local.p.cast<double>();
        parts.push_back({cm.volume, c, r * cm.inertia * r.transpose()});
        u.volume += cm.volume;
        moment += cm.volume * c;
    }
    u.center = moment / u.volume;
    for (const Part& p : parts) {
        const Vec3d d = p.c - u.center;
        u.inertia += p.i + p.m * (Mat3d::Identity() * d.squaredNorm() - d * d.transpose());
    }
    return u;
}

UnitMass shape_mass(const Shape& shape) {
    switch (shape.type) {
        case ShapeType::Sphere: return sphere_mass(shape.radius);
        case ShapeType::Box: return box_mass(shape.half_extents);
        case ShapeType::Capsule: return capsule_mass(shape.half_height, shape.radius);
        case ShapeType::ConvexHull: return hull_mass(shape.hull.get());
        case ShapeType::Compound: return compound_mass(shape);
        case ShapeType::Plane:
        case ShapeType::TriangleMesh:
            throw ShapeError(std::string("a ") + shape_type_name(shape.type) +
                             " is static-only and has no mass properties");
        default: break;
    }
    throw ShapeError("mass properties of an unknown shape type " + std::to_string(static_cast<int>(shape.type)));
}

MassProperties scaled(const UnitMass& u, double density) {
    MassProperties mp;
    mp.mass = static_cast<Real>(u.volume * density);
    if (!is_finite(mp.mass) || mp.mass <= 0)
        throw ShapeError("mass " + to_text(u.volume * density) + " (volume " + to_text(u.volume) + " x density " +
                         to_text(density) + ") is not representable");
    mp.center = u.center.cast<Real>();
    // Exactly symmetric after rotations. (Into a new matrix: `i = i + i.transpose()` would alias.)
    const Mat3d sym = (0.5 * density) * (u.inertia + u.inertia.transpose());
    mp.inertia = sym.cast<Real>();
    mp.volume = static_cast<Real>(u.volume);
    return mp;
}

}  // namespace

MassProperties compute_mass_properties(const Shape& shape, Real density) {
    if (!is_finite(density) || density <= 0)
        throw ShapeError("density must be finite and > 0, got " + to_text(density));
    return scaled(shape_mass(shape), density);
}

MassProperties mass_properties_for_mass(const Shape& shape, Real mass) {
    if (!is_finite(mass) || mass <= 0) throw ShapeError("mass must be finite and > 0, got " + to_text(mass));
    const UnitMass u = shape_mass(shape);
    return scaled(u, static_cast<double>(mass) / u.volume);
}

}  // namespace sinew
