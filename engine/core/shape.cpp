#include "engine/core/shape.hpp"

#include "engine/core/format.hpp"

namespace sinew {

namespace {
void require_positive(Real x, const char* what) {
    if (!is_finite(x) || x <= 0) throw ShapeError(std::string(what) + " must be finite and > 0, got " + to_text(x));
}
}  // namespace

const char* shape_type_name(ShapeType t) {
    switch (t) {
        case ShapeType::Sphere: return "sphere";
        case ShapeType::Box: return "box";
        case ShapeType::Capsule: return "capsule";
        case ShapeType::ConvexHull: return "convex_hull";
        case ShapeType::Plane: return "plane";
        case ShapeType::TriangleMesh: return "triangle_mesh";
        case ShapeType::Compound: return "compound";
        default: return "unknown";
    }
}

int ConvexHullData::support_index(const Vec3& d) const {
    int best = 0;
    Real best_dot = vertices[0].dot(d);
    for (int i = 1; i < static_cast<int>(vertices.size()); ++i) {
        Real v = vertices[i].dot(d);
        if (v > best_dot) {
            best_dot = v;
            best = i;
        }
    }
    return best;
}

bool Shape::can_be_dynamic() const {
    if (type == ShapeType::Plane || type == ShapeType::TriangleMesh) return false;
    if (type == ShapeType::Compound)
        for (const CompoundChild& c : *children)
            if (!c.shape->can_be_dynamic()) return false;
    return true;
}

Vec3 Shape::support(const Vec3& d) const {
    switch (type) {
        case ShapeType::Sphere: {
            Real n = d.norm();
            return n > 0 ? Vec3(d * (radius / n)) : Vec3(radius, 0, 0);
        }
        case ShapeType::Box:
            return Vec3(d.x() >= 0 ? half_extents.x() : -half_extents.x(),
                        d.y() >= 0 ? half_extents.y() : -half_extents.y(),
                        d.z() >= 0 ? half_extents.z() : -half_extents.z());
        case ShapeType::Capsule: {
            Real n = d.norm();
            Vec3 s = n > 0 ? Vec3(d * (radius / n)) : Vec3(radius, 0, 0);
            s.y() += d.y() >= 0 ? half_height : -half_height;
            return s;
        }
        case ShapeType::ConvexHull: return hull->vertices[hull->support_index(d)];
        default: throw ShapeError(std::string("support() is not defined for a ") + shape_type_name(type));
    }
}

Aabb Shape::bounds(const Transform& xf) const {
    Aabb box;
    switch (type) {
        case ShapeType::Sphere:
            box.lo = xf.p.array() - radius;
            box.hi = xf.p.array() + radius;
            return box;
        case ShapeType::Box: {
            // |R| * half extents: the tight box of a rotated box.
            Vec3 e = xf.q.toRotationMatrix().cwiseAbs() * half_extents;
            return {xf.p - e, xf.p + e};
        }
        case ShapeType::Capsule: {
            Vec3 axis = xf.q * Vec3(0, half_height, 0);
            Vec3 e = axis.cwiseAbs().array() + radius;
            return {xf.p - e, xf.p + e};
        }
        case ShapeType::ConvexHull:
            for (const Vec3& v : hull->vertices) box.grow(xf.apply(v));
            return box;
        case ShapeType::Plane: {
            // Planes are infinite; a large finite box keeps the broad phase arithmetic finite.
            const Real big = Real(1e6);
            box.lo = Vec3::Constant(-big);
            box.hi = Vec3::Constant(big);
            return box;
        }
        case ShapeType::TriangleMesh:
            for (const Vec3& v : mesh->vertices) box.grow(xf.apply(v));
            return box;
        case ShapeType::Compound:
            for (const CompoundChild& c : *children) box = box.merged(c.shape->bounds(xf * c.local));
            return box;
        default: return box;
    }
}

Shape make_sphere(Real radius) {
    require_positive(radius, "sphere radius");
    Shape s;
    s.type = ShapeType::Sphere;
    s.radius = radius;
    return s;
}

Shape make_box(const Vec3& half_extents) {
    require_positive(half_extents.x(), "box half extent x");
    require_positive(half_extents.y(), "box half extent y");
    require_positive(half_extents.z(), "box half extent z");
    Shape s;
    s.type = ShapeType::Box;
    s.half_extents = half_extents;
    return s;
}

Shape make_capsule(Real half_height, Real radius) {
    require_positive(radius, "capsule radius");
    if (!is_finite(half_height) || half_height < 0)
        throw ShapeError("capsule half height must be finite and >= 0, got " + to_text(half_height));
    Shape s;
    s.type = ShapeType::Capsule;
    s.half_height = half_height;
    s.radius = radius;
    return s;
}

Shape make_plane(const Vec3& normal, Real offset) {
    if (!is_finite(normal) || !is_finite(offset)) throw ShapeError("plane normal and offset must be finite");
    Real n = normal.norm();
    if (n < Real(1e-6)) throw ShapeError("plane normal must not be zero");
    Shape s;
    s.type = ShapeType::Plane;
    s.normal = normal / n;
    s.offset = offset / n;
    return s;
}

Shape make_compound(const std::vector<std::pair<Transform, Shape>>& children) {
    if (children.empty()) throw ShapeError("compound must have at least one child");
    auto list = std::make_shared<std::vector<CompoundChild>>();
    for (std::size_t i = 0; i < children.size(); ++i) {
        const auto& [xf, child] = children[i];
        if (!is_finite(xf.p) || !is_finite(xf.q))
            throw ShapeError("compound child " + std::to_string(i) + " has a non-finite transform");
        if (child.type == ShapeType::Compound)
            throw ShapeError("compound child " + std::to_string(i) + " is itself a compound (flatten it)");
        Transform local = xf;
        local.q.normalize();
        list->push_back({local, std::make_shared<const Shape>(child)});
    }
    Shape s;
    s.type = ShapeType::Compound;
    s.children = std::move(list);
    return s;
}

}  // namespace sinew
