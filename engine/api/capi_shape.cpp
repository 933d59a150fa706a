// Shapes from C (sinew_shape_def): every shape the scene format has, checked field by field with the
// field's name in the error, the arrays copied.
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "engine/api/capi_internal.hpp"

namespace sinew::capi {

namespace {

// Far beyond any game shape, small enough that a garbage count cannot exhaust memory.
constexpr int kMaxPoints = 1 << 20;
constexpr int kMaxChildren = 1 << 12;

[[noreturn]] void bad(const std::string& where, const std::string& why) { throw ShapeError(where + " " + why); }

/// "def->shape" + "type" -> "def->shape.type"; "shape->" + "type" -> "shape->type".
std::string field(const std::string& where, const char* name) {
    return where + (!where.empty() && where.back() == '>' ? "" : ".") + name;
}

void check_array(const std::string& where, const void* data, int count, const char* data_name, const char* count_name,
                 int min_count) {
    if (count < min_count || count > kMaxPoints)
        bad(field(where, count_name), "= " + std::to_string(count) + " must be in [" + std::to_string(min_count) + ", " +
                                          std::to_string(kMaxPoints) + "]");
    if (!data) bad(field(where, data_name), "is NULL");
}

std::vector<Vec3> points_of(const sinew_shape_def& d, const std::string& where, int min_count) {
    check_array(where, d.points, d.point_count, "points", "point_count", min_count);
    std::vector<Vec3> out(static_cast<std::size_t>(d.point_count));
    for (int i = 0; i < d.point_count; ++i) {
        if (!finite(d.points[i])) bad(field(where, "points") + "[" + std::to_string(i) + "]", "must be finite");
        out[std::size_t(i)] = to_vec(d.points[i]);
    }
    return out;
}

Shape shape_at(const sinew_shape_def& d, const std::string& where, bool in_compound) {
    const int type = enum_value(d.type);
    switch (type) {
        case SINEW_SHAPE_SPHERE: return make_sphere(Real(d.radius));  // ShapeError names the value
        case SINEW_SHAPE_BOX: return make_box(to_vec(d.half_extents));
        case SINEW_SHAPE_CAPSULE: return make_capsule(Real(d.half_height), Real(d.radius));
        case SINEW_SHAPE_HULL: return make_convex_hull(points_of(d, where, 4));
        case SINEW_SHAPE_PLANE:
            if (in_compound) break;
            if (!finite(d.normal) || !std::isfinite(d.offset)) bad(field(where, "normal"), "and offset must be finite");
            return make_plane(to_vec(d.normal), Real(d.offset));
        case SINEW_SHAPE_MESH: {
            if (in_compound) break;
            std::vector<Vec3> vertices = points_of(d, where, 3);
            check_array(where, d.indices, d.index_count, "indices", "index_count", 3);
            if (d.index_count % 3 != 0) bad(field(where, "index_count"), "= " + std::to_string(d.index_count) + " must be a multiple of 3");
            std::vector<std::uint32_t> indices(d.indices, d.indices + d.index_count);
            return make_triangle_mesh(vertices, indices);  // ShapeError names an index out of range
        }
        case SINEW_SHAPE_COMPOUND: {
            if (in_compound) break;
            if (d.child_count < 1 || d.child_count > kMaxChildren)
                bad(field(where, "child_count"), "= " + std::to_string(d.child_count) + " must be in [1, " + std::to_string(kMaxChildren) + "]");
            if (!d.children) bad(field(where, "children"), "is NULL");
            std::vector<std::pair<Transform, Shape>> children;
            children.reserve(std::size_t(d.child_count));
            for (int i = 0; i < d.child_count; ++i) {
                const std::string at = field(where, "children") + "[" + std::to_string(i) + "]";
                const sinew_compound_child& c = d.children[i];
                if (!finite(c.transform.p) || !unit_quat_ok(c.transform.q))
                    bad(at + ".transform", "must be finite with a non-zero quaternion");
                children.emplace_back(Transform{to_vec(c.transform.p), to_quat(c.transform.q).normalized()},
                                      shape_at(c.shape, at + ".shape", true));
            }
            return make_compound(children);
        }
        default:
            bad(field(where, "type"), "= " + std::to_string(type) + " is not a sinew_shape_type");
    }
    bad(field(where, "type"), "= " + std::to_string(type) + ": a compound's child must be a sphere, box, capsule or hull");
}

}  // namespace

Shape make_shape(const sinew_shape_def& d, const char* where) { return shape_at(d, where, false); }

}  // namespace sinew::capi

extern "C" sinew_shape_def sinew_shape_def_default(void) {
    sinew_shape_def d;
    d.type = SINEW_SHAPE_BOX;
    d.radius = 0.5f;
    d.half_height = 0.5f;
    d.half_extents = {0.5f, 0.5f, 0.5f};
    d.points = nullptr;
    d.point_count = 0;
    d.indices = nullptr;
    d.index_count = 0;
    d.normal = {0, 1, 0};
    d.offset = 0;
    d.children = nullptr;
    d.child_count = 0;
    return d;
}
