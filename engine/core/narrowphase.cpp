// Narrow-phase dispatch: a 2-D table of pair routines indexed by the two shape types (the scheme of Jolt's
// CollisionDispatch), so a pair costs one indexed load and one indirect call, never a virtual call.
//
// The table holds each routine under its canonical order (the order named in narrow::) and again under
// the swapped order, marked "swap": the routine is then called with (B, A) and its normal flipped. The
// points need no change because every routine puts them midway between the two surfaces.
//
// Compounds are expanded here, child by child, and triangle meshes through their BVH, so the pair
// routines only ever see convex shapes, planes and triangles.
#include <string>

#include "engine/core/narrowphase.hpp"

namespace sinew {

namespace {

using PairFn = bool (*)(const Shape&, const Transform&, const Shape&, const Transform&, Real, Manifold&);

enum class Route : std::uint8_t {
    None,  ///< no contact between these types (static against static)
    Pair,  ///< one routine, at most one manifold
    Mesh,  ///< convex against the triangles of a mesh, one manifold per touching triangle
};

struct Entry {
    Route route = Route::None;
    PairFn fn = nullptr;
    bool swap = false;  ///< call fn(B, A) and flip the normal
};

constexpr int kTypeCount = static_cast<int>(ShapeType::Count);

struct Table {
    Entry at[kTypeCount][kTypeCount];
};

constexpr int idx(ShapeType t) { return static_cast<int>(t); }

/// Registers fn for (x, y) and, swapped, for (y, x).
constexpr void set_pair(Table& t, ShapeType x, ShapeType y, PairFn fn) {
    t.at[idx(x)][idx(y)] = Entry{Route::Pair, fn, false};
    if (x != y) t.at[idx(y)][idx(x)] = Entry{Route::Pair, fn, true};
}

constexpr Table make_table() {
    Table t{};
    using S = ShapeType;
    set_pair(t, S::Sphere, S::Sphere, narrow::sphere_sphere);
    set_pair(t, S::Sphere, S::Capsule, narrow::sphere_capsule);
    set_pair(t, S::Sphere, S::Box, narrow::sphere_box);
    set_pair(t, S::Capsule, S::Capsule, narrow::capsule_capsule);
    set_pair(t, S::Capsule, S::Box, narrow::capsule_box);
    set_pair(t, S::Box, S::Box, narrow::box_box);
    const S convex[] = {S::Sphere, S::Box, S::Capsule, S::ConvexHull};
    for (S c : convex) {
        // convex_convex takes any convex pair in either order: no swap needed.
        t.at[idx(S::ConvexHull)][idx(c)] = Entry{Route::Pair, narrow::convex_convex, false};
        t.at[idx(c)][idx(S::ConvexHull)] = Entry{Route::Pair, narrow::convex_convex, false};
        set_pair(t, c, S::Plane, narrow::convex_plane);
        t.at[idx(c)][idx(S::TriangleMesh)] = Entry{Route::Mesh, nullptr, false};
        t.at[idx(S::TriangleMesh)][idx(c)] = Entry{Route::Mesh, nullptr, true};
    }
    // Plane and mesh pairs among themselves stay None: both are static.
    return t;
}

constexpr Table kTable = make_table();

/// How the indices of one body pair's manifolds are packed into sub_key: A's child index in the low
/// bits, then B's child index, then the triangle index. The widths are fixed per body pair (they depend
/// only on the two shapes), so the key is unique within the pair and the same every step.
struct KeyLayout {
    int b_shift;    ///< where B's child index starts
    int tri_shift;  ///< where the triangle index starts
};

int bits_for(std::size_t count) {
    int bits = 0;
    while (bits < 32 && (std::size_t(1) << bits) < count) ++bits;
    return bits;
}

std::uint32_t shifted(std::uint32_t index, int shift) { return shift < 32 ? index << shift : 0u; }

bool is_convex(ShapeType t) {
    return t == ShapeType::Sphere || t == ShapeType::Box || t == ShapeType::Capsule || t == ShapeType::ConvexHull;
}

/// Convex shape c against the triangles of `mesh` near it; `flip` when the mesh was A.
void convex_mesh(const Shape& c, const Transform& xc, const Shape& mesh, const Transform& xm, Real margin,
                 std::uint32_t key, int tri_shift, bool flip, ManifoldList& out) {
    const TriangleMeshData& data = *mesh.mesh;
    // The BVH is in mesh-local coordinates: query with the convex shape's bounds placed there.
    const Aabb box = c.bounds(xm.inverse() * xc).fattened(margin);
    data.query(box, [&](std::uint32_t tri) {
        const Triangle local = data.triangle(tri);
        const Triangle world{xm.apply(local.a), xm.apply(local.b), xm.apply(local.c)};
        Manifold m;
        if (!narrow::convex_triangle(c, xc, world, margin, m) || m.count == 0) return;
        if (flip) m.normal = -m.normal;
        m.sub_key = key | shifted(tri, tri_shift);
        out.push_back(m);
    });
}

void collide_leaf(const Shape& a, const Transform& xa, const Shape& b, const Transform& xb, Real margin,
                  std::uint32_t key, const KeyLayout& layout, ManifoldList& out) {
    const Entry& e = kTable.at[idx(a.type)][idx(b.type)];
    switch (e.route) {
        case Route::None: return;
        case Route::Pair: {
            Manifold m;
            const bool hit = e.swap ? e.fn(b, xb, a, xa, margin, m) : e.fn(a, xa, b, xb, margin, m);
            if (!hit || m.count == 0) return;
            if (e.swap) m.normal = -m.normal;
            m.sub_key = key;
            out.push_back(m);
            return;
        }
        case Route::Mesh:
            if (e.swap)
                convex_mesh(b, xb, a, xa, margin, key, layout.tri_shift, true, out);
            else
                convex_mesh(a, xa, b, xb, margin, key, layout.tri_shift, false, out);
            return;
    }
}

/// Expands A's compound, then B's, then dispatches each leaf pair. A child whose bounds miss a convex
/// partner's is skipped before any pair routine runs.
void collide_node(const Shape& a, const Transform& xa, const Shape& b, const Transform& xb, Real margin,
                  std::uint32_t key, const KeyLayout& layout, ManifoldList& out) {
    if (a.type == ShapeType::Compound) {
        const bool cull = is_convex(b.type);
        const Aabb other = cull ? b.bounds(xb).fattened(margin) : Aabb{};
        const auto& children = *a.children;
        for (std::size_t i = 0; i < children.size(); ++i) {
            const Transform xc = xa * children[i].local;
            if (cull && !children[i].shape->bounds(xc).overlaps(other)) continue;
            collide_node(*children[i].shape, xc, b, xb, margin, key | static_cast<std::uint32_t>(i), layout, out);
        }
        return;
    }
    if (b.type == ShapeType::Compound) {
        const bool cull = is_convex(a.type);
        const Aabb other = cull ? a.bounds(xa).fattened(margin) : Aabb{};
        const auto& children = *b.children;
        for (std::size_t j = 0; j < children.size(); ++j) {
            const Transform xc = xb * children[j].local;
            if (cull && !children[j].shape->bounds(xc).overlaps(other)) continue;
            collide_node(a, xa, *children[j].shape, xc, margin,
                         key | shifted(static_cast<std::uint32_t>(j), layout.b_shift), layout, out);
        }
        return;
    }
    collide_leaf(a, xa, b, xb, margin, key, layout, out);
}

void require_finite(const Transform& xf, const char* which, const Shape& s) {
    if (!is_finite(xf.p) || !is_finite(xf.q))
        throw ShapeError(std::string("collide: shape ") + which + " (" + shape_type_name(s.type) +
                         ") has a non-finite transform");
}

}  // namespace

int collide(const Shape& a, const Transform& xa, const Shape& b, const Transform& xb, Real margin, ManifoldList& out) {
    require_finite(xa, "A", a);
    require_finite(xb, "B", b);
    if (!is_finite(margin) || margin < 0)
        throw ShapeError("collide: margin must be finite and >= 0, got " + std::to_string(margin));
    if (!can_collide(a.type, b.type)) return 0;
    const std::size_t before = out.size();
    const int bits_a = a.type == ShapeType::Compound ? bits_for(a.children->size()) : 0;
    const int bits_b = b.type == ShapeType::Compound ? bits_for(b.children->size()) : 0;
    collide_node(a, xa, b, xb, margin, 0, KeyLayout{bits_a, bits_a + bits_b}, out);
    return static_cast<int>(out.size() - before);
}

bool shapes_touch(const Shape& a, const Transform& xa, const Shape& b, const Transform& xb, ManifoldList& scratch) {
    scratch.clear();
    collide(a, xa, b, xb, 0, scratch);
    for (const Manifold& m : scratch)
        for (int k = 0; k < m.count; ++k)
            if (m.points[k].depth >= 0) return true;
    return false;
}

bool can_collide(ShapeType a, ShapeType b) {
    if (idx(a) >= kTypeCount || idx(b) >= kTypeCount) return false;
    // A compound may hold dynamic children, so it can meet anything; whether a particular compound of
    // only static children meets a plane is a property of the shape, not of the types.
    if (a == ShapeType::Compound || b == ShapeType::Compound) return true;
    return kTable.at[idx(a)][idx(b)].route != Route::None;
}

}  // namespace sinew
