// Collision shapes. A Shape is a small tagged value; the heavy data of hulls, meshes and compounds is
// shared and immutable, so copying a Shape (one per body) is cheap and shapes can be instanced.
//
// Conventions: every shape is expressed in its body's local frame. Capsules lie along the local y axis
// (segment from -half_height to +half_height). Planes and triangle meshes are static-only.
#pragma once

#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "engine/core/aabb.hpp"
#include "engine/core/math.hpp"

namespace sinew {

enum class ShapeType : std::uint8_t { Sphere, Box, Capsule, ConvexHull, Plane, TriangleMesh, Compound, Count };

const char* shape_type_name(ShapeType t);

/// Thrown for bad user data (a non-positive radius, a degenerate hull, ...). The message names the
/// offending value; callers (scene loader, C API) add where it came from.
struct ShapeError : std::invalid_argument {
    using std::invalid_argument::invalid_argument;
};

/// A convex polyhedron with explicit faces (needed for reference-face clipping) and unique edges
/// (needed for the SAT edge-edge tests). Built by make_convex_hull() from a point cloud.
struct ConvexHullData {
    struct Face {
        Vec3 normal;                      ///< outward unit normal
        Real offset;                      ///< plane: normal . x = offset
        std::vector<std::uint16_t> verts;  ///< vertex indices, counter-clockwise seen from outside
    };
    std::vector<Vec3> vertices;
    std::vector<Face> faces;
    std::vector<std::pair<std::uint16_t, std::uint16_t>> edges;  ///< unique undirected edges
    Vec3 centroid = Vec3::Zero();  ///< volume centroid (centre of mass at uniform density)

    /// Index of the vertex furthest along d.
    int support_index(const Vec3& d) const;
};

struct Triangle {
    Vec3 a, b, c;
};

/// A static triangle mesh with a bounding-volume hierarchy over its triangles.
struct TriangleMeshData {
    std::vector<Vec3> vertices;
    std::vector<std::uint32_t> indices;  ///< 3 per triangle
    struct Node {
        Aabb box;
        std::int32_t left = -1;   ///< child index, or -1 for a leaf
        std::int32_t right = -1;
        std::int32_t first = 0;   ///< leaf: first entry in tri_order
        std::int32_t count = 0;   ///< leaf: number of triangles
    };
    std::vector<Node> nodes;  ///< nodes[0] is the root
    std::vector<std::uint32_t> tri_order;

    std::size_t triangle_count() const { return indices.size() / 3; }
    Triangle triangle(std::size_t i) const {
        return {vertices[indices[3 * i]], vertices[indices[3 * i + 1]], vertices[indices[3 * i + 2]]};
    }
    /// Calls f(triangle_index) for each triangle whose box overlaps `box` (mesh-local coordinates).
    template <class F>
    void query(const Aabb& box, F&& f) const;
};

struct Shape;

struct CompoundChild {
    Transform local;  ///< child frame in the compound's frame
    std::shared_ptr<const Shape> shape;
};

struct Shape {
    ShapeType type = ShapeType::Sphere;
    Real radius = 0;             ///< sphere, capsule
    Real half_height = 0;        ///< capsule: half the segment length along local y
    Vec3 half_extents = Vec3::Zero();  ///< box
    Vec3 normal = Vec3::UnitY();  ///< plane: normal . x = offset, solid below
    Real offset = 0;             ///< plane
    std::shared_ptr<const ConvexHullData> hull;
    std::shared_ptr<const TriangleMeshData> mesh;
    std::shared_ptr<const std::vector<CompoundChild>> children;

    /// May a dynamic body carry this shape? (planes and triangle meshes are static-only)
    bool can_be_dynamic() const;
    /// Bounds of the shape placed at xf. Planes give a huge but finite box.
    Aabb bounds(const Transform& xf) const;
    /// Furthest point of a convex shape along d (local frame). Not for planes, meshes, compounds.
    Vec3 support(const Vec3& d) const;
};

// Factories validate their arguments and throw ShapeError naming the bad value.
Shape make_sphere(Real radius);
Shape make_box(const Vec3& half_extents);
Shape make_capsule(Real half_height, Real radius);
/// `flatness` > 0 (relative to the cloud's diagonal) merges faces whose points lie within it of one plane
/// and skips points that far inside or above a face: a sagging soft cube's hull (coupling/rigid_proxy.hpp)
/// keeps six faces instead of hundreds of slivers, each point within flatness x diagonal of the hull.
Shape make_convex_hull(const std::vector<Vec3>& points, Real flatness = 0);
Shape make_plane(const Vec3& normal, Real offset);
Shape make_triangle_mesh(const std::vector<Vec3>& vertices, const std::vector<std::uint32_t>& indices);
Shape make_compound(const std::vector<std::pair<Transform, Shape>>& children);

template <class F>
void TriangleMeshData::query(const Aabb& box, F&& f) const {
    if (nodes.empty()) return;
    std::int32_t stack[64];
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
        const Node& n = nodes[stack[--top]];
        if (!n.box.overlaps(box)) continue;
        if (n.left < 0) {
            // A leaf holds up to 4 triangles: test each one's own box before the caller's (costly)
            // narrow phase.
            for (int i = 0; i < n.count; ++i) {
                const std::uint32_t t = tri_order[n.first + i];
                const Vec3 &a = vertices[indices[3 * t]], &b = vertices[indices[3 * t + 1]], &c = vertices[indices[3 * t + 2]];
                const Aabb tb{a.cwiseMin(b).cwiseMin(c), a.cwiseMax(b).cwiseMax(c)};
                if (tb.overlaps(box)) f(t);
            }
        } else {
            stack[top++] = n.left;
            stack[top++] = n.right;
        }
    }
}

}  // namespace sinew
