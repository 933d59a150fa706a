// make_triangle_mesh(): validates a static triangle soup and builds the bounding-volume hierarchy that
// TriangleMeshData::query() walks.
//
// The BVH is a binary tree of AABBs built top-down by a median split of the triangle centroids along the
// longest axis of their bounds (the "object median" split of Kay & Kajiya 1986 / Ericson, Real-Time
// Collision Detection, 6.2). Splitting at the median index halves the count every level, so the depth is
// ceil(log2(n / 4)) + 1 whatever the geometry: far below the 64-slot traversal stack of query().
#include <algorithm>

#include "engine/core/shape.hpp"
#include "engine/core/format.hpp"

namespace sinew {

namespace {

constexpr int kLeafSize = 4;

/// Twice the triangle's area is below rounding noise relative to its longest edge: the triangle has no
/// normal and no interior, so it can only produce garbage contacts.
bool is_degenerate(const Vec3& a, const Vec3& b, const Vec3& c) {
    Vec3 ab = b - a, ac = c - a, bc = c - b;
    Real longest2 = std::max({ab.squaredNorm(), ac.squaredNorm(), bc.squaredNorm()});
    Real area2 = ab.cross(ac).norm();
    return !(area2 > Real(16) * kEpsilon * longest2);
}

struct BvhBuilder {
    TriangleMeshData& m;
    std::vector<Vec3> centroid;  // per triangle

    Aabb triangle_box(std::uint32_t t) const {
        Aabb b;
        for (int k = 0; k < 3; ++k) b.grow(m.vertices[m.indices[3 * t + k]]);
        return b;
    }

    /// Builds the subtree over tri_order[first, first + count) into nodes[index].
    void build(int index, int first, int count) {
        Aabb box, cbox;
        for (int i = first; i < first + count; ++i) {
            box = box.merged(triangle_box(m.tri_order[i]));
            cbox.grow(centroid[m.tri_order[i]]);
        }
        m.nodes[index].box = box;
        if (count <= kLeafSize) {
            m.nodes[index].first = first;
            m.nodes[index].count = count;
            return;
        }
        Vec3 ext = cbox.extent();
        int axis = 0;
        if (ext.y() > ext[axis]) axis = 1;
        if (ext.z() > ext[axis]) axis = 2;
        const int half = count / 2;
        auto begin = m.tri_order.begin() + first;
        std::nth_element(begin, begin + half, begin + count, [&](std::uint32_t a, std::uint32_t b) {
            return centroid[a][axis] < centroid[b][axis];
        });
        const int left = static_cast<int>(m.nodes.size());
        m.nodes.emplace_back();
        m.nodes.emplace_back();
        m.nodes[index].left = left;
        m.nodes[index].right = left + 1;
        build(left, first, half);
        build(left + 1, first + half, count - half);
    }
};

}  // namespace

Shape make_triangle_mesh(const std::vector<Vec3>& vertices, const std::vector<std::uint32_t>& indices) {
    if (indices.empty()) throw ShapeError("triangle mesh has no triangles (empty index list)");
    if (indices.size() % 3 != 0)
        throw ShapeError("triangle mesh index count must be a multiple of 3, got " + std::to_string(indices.size()));
    for (std::size_t i = 0; i < vertices.size(); ++i)
        if (!is_finite(vertices[i]))
            throw ShapeError("triangle mesh vertex " + std::to_string(i) + " is not finite (" + to_text(vertices[i].x()) +
                             ", " + to_text(vertices[i].y()) + ", " + to_text(vertices[i].z()) + ")");
    for (std::size_t i = 0; i < indices.size(); ++i)
        if (indices[i] >= vertices.size())
            throw ShapeError("triangle mesh index " + std::to_string(i) + " is " + std::to_string(indices[i]) +
                             ", out of range for " + std::to_string(vertices.size()) + " vertices");

    auto mesh = std::make_shared<TriangleMeshData>();
    mesh->vertices = vertices;
    mesh->indices.reserve(indices.size());
    for (std::size_t t = 0; t < indices.size() / 3; ++t) {
        const std::uint32_t i0 = indices[3 * t], i1 = indices[3 * t + 1], i2 = indices[3 * t + 2];
        if (is_degenerate(vertices[i0], vertices[i1], vertices[i2])) continue;  // zero area: dropped
        mesh->indices.insert(mesh->indices.end(), {i0, i1, i2});
    }
    const std::size_t n = mesh->triangle_count();
    if (n == 0)
        throw ShapeError("triangle mesh has no usable triangles: all " + std::to_string(indices.size() / 3) +
                         " are degenerate (zero area)");
    if (n > std::size_t(0x7fffffff)) throw ShapeError("triangle mesh has too many triangles");

    BvhBuilder b{*mesh, {}};
    b.centroid.resize(n);
    mesh->tri_order.resize(n);
    for (std::size_t t = 0; t < n; ++t) {
        const Triangle tri = mesh->triangle(t);
        b.centroid[t] = (tri.a + tri.b + tri.c) / Real(3);
        mesh->tri_order[t] = static_cast<std::uint32_t>(t);
    }
    mesh->nodes.reserve(2 * (n / kLeafSize + 1));
    mesh->nodes.emplace_back();
    b.build(0, 0, static_cast<int>(n));

    Shape s;
    s.type = ShapeType::TriangleMesh;
    s.mesh = std::move(mesh);
    return s;
}

}  // namespace sinew
