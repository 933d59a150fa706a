// Builders for closed and general triangle-mesh bodies: the geodesic sphere of Matyka's pressure ball
// (Matyka 2004) and links for any triangle mesh by graph distance along its edges.
//
// As the cloth builders: every link gets its rest length from the built positions (the body starts
// unstressed), k_s from the LinkMaterial of its kind, k_d and the Verlet fraction from the material, and
// min_length = max_length = rest (an equality constraint under Verlet, Jakobsen 2003).
#include <algorithm>
#include <cmath>
#include <string>
#include <unordered_map>
#include <utility>

#include "engine/core/format.hpp"
#include "soft/builder_common.hpp"

namespace sinew {

using namespace builder;

namespace {

void check_total_mass(const char* where, Real total_mass) {
    if (!(is_finite(total_mass) && total_mass > 0))
        fail(where, "total_mass must be finite and > 0, got " + to_text(total_mass));
}


std::uint64_t edge_key(std::uint32_t a, std::uint32_t b) {
    if (a > b) std::swap(a, b);
    return (std::uint64_t(a) << 32) | b;
}

// The unique undirected edges of a triangle list, sorted by (smaller index, larger index).
std::vector<std::uint64_t> unique_edges(const std::vector<std::uint32_t>& tris) {
    std::vector<std::uint64_t> keys;
    keys.reserve(tris.size());
    for (std::size_t t = 0; t + 2 < tris.size(); t += 3) {
        keys.push_back(edge_key(tris[t], tris[t + 1]));
        keys.push_back(edge_key(tris[t + 1], tris[t + 2]));
        keys.push_back(edge_key(tris[t + 2], tris[t]));
    }
    std::sort(keys.begin(), keys.end());
    keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
    return keys;
}

void spread_mass(SoftBodyDef& d, Real total_mass) {
    d.masses.assign(d.positions.size(), total_mass / Real(d.positions.size()));
}

using DVec3 = Eigen::Vector3d;

// The regular icosahedron on the unit sphere: vertices (0, ±1, ±φ) and its cyclic permutations.
void icosahedron(std::vector<DVec3>& v, std::vector<std::uint32_t>& tris) {
    const double phi = (1 + std::sqrt(5.0)) / 2;
    v = {{-1, phi, 0}, {1, phi, 0},  {-1, -phi, 0}, {1, -phi, 0}, {0, -1, phi}, {0, 1, phi},
         {0, -1, -phi}, {0, 1, -phi}, {phi, 0, -1},  {phi, 0, 1},  {-phi, 0, -1}, {-phi, 0, 1}};
    for (DVec3& p : v) p.normalize();
    // Every face of the icosahedron is a triple of mutually adjacent vertices (edge length 2 before
    // normalisation); listing them from adjacency rather than from a table keeps the 20 faces correct by
    // construction. Each is then turned counter-clockwise seen from outside: the polyhedron is convex
    // and centred at the origin, so a face is outward iff its normal points away from the origin.
    const double edge2 = (v[0] - v[1]).squaredNorm();
    auto adjacent = [&](std::uint32_t a, std::uint32_t b) { return std::abs((v[a] - v[b]).squaredNorm() - edge2) < 1e-9; };
    tris.clear();
    for (std::uint32_t a = 0; a < 12; ++a)
        for (std::uint32_t b = a + 1; b < 12; ++b) {
            if (!adjacent(a, b)) continue;
            for (std::uint32_t c = b + 1; c < 12; ++c) {
                if (!adjacent(a, c) || !adjacent(b, c)) continue;
                const bool outward = (v[b] - v[a]).cross(v[c] - v[a]).dot(v[a] + v[b] + v[c]) > 0;
                tris.insert(tris.end(), {a, outward ? b : c, outward ? c : b});
            }
        }
}

// Loop-style 1-to-4 split: one new vertex per edge (shared by the two faces on it), pushed out to the
// unit sphere. The four children keep the parent's winding, so outward stays outward.
void subdivide(std::vector<DVec3>& v, std::vector<std::uint32_t>& tris) {
    std::unordered_map<std::uint64_t, std::uint32_t> midpoint;
    midpoint.reserve(tris.size());
    auto mid = [&](std::uint32_t a, std::uint32_t b) {
        const auto found = midpoint.find(edge_key(a, b));
        if (found != midpoint.end()) return found->second;
        const std::uint32_t m = static_cast<std::uint32_t>(v.size());
        v.push_back((v[a] + v[b]).normalized());
        midpoint.emplace(edge_key(a, b), m);
        return m;
    };
    std::vector<std::uint32_t> out;
    out.reserve(tris.size() * 4);
    for (std::size_t t = 0; t < tris.size(); t += 3) {
        const std::uint32_t a = tris[t], b = tris[t + 1], c = tris[t + 2];
        const std::uint32_t ab = mid(a, b), bc = mid(b, c), ca = mid(c, a);
        out.insert(out.end(), {a, ab, ca, b, bc, ab, c, ca, bc, ab, bc, ca});
    }
    tris.swap(out);
}

}  // namespace

SoftBodyDef make_icosphere(const Vec3& centre, Real radius, int subdivisions, Real total_mass,
                           const LinkMaterial& m, SoftBodyDef base) {
    const char* where = "make_icosphere";
    if (!is_finite(centre)) fail(where, "centre must be finite, got " + to_text(centre));
    if (!(is_finite(radius) && radius > 0)) fail(where, "radius must be finite and > 0, got " + to_text(radius));
    // 6 subdivisions already give 40962 vertices; a 7th (163842) is beyond any real-time soft body.
    if (subdivisions < 0 || subdivisions > 6)
        fail(where, "subdivisions must be in [0, 6], got " + std::to_string(subdivisions));
    check_total_mass(where, total_mass);
    check_material(where, m);

    // Built on the unit sphere in double, so the vertices of the finest level still lie on the sphere
    // to float precision after the projections.
    std::vector<DVec3> unit;
    std::vector<std::uint32_t> tris;
    icosahedron(unit, tris);
    for (int s = 0; s < subdivisions; ++s) subdivide(unit, tris);

    reset_geometry(base);
    base.positions.reserve(unit.size());
    for (const DVec3& u : unit) base.positions.push_back(centre + radius * u.cast<Real>());
    spread_mass(base, total_mass);
    const std::vector<std::uint64_t> edges = unique_edges(tris);
    base.links.reserve(edges.size());
    for (std::uint64_t e : edges)
        base.links.push_back(make_link(base.positions, std::uint32_t(e >> 32), std::uint32_t(e & 0xffffffffu),
                                       LinkKind::Structural, m));
    base.triangles = std::move(tris);
    return base;
}

SoftBodyDef make_mesh_body(const std::vector<Vec3>& vertices, const std::vector<std::uint32_t>& indices,
                           int link_distance, Real total_mass, const LinkMaterial& m, SoftBodyDef base) {
    const char* where = "make_mesh_body";
    const std::size_t n = vertices.size();
    if (n == 0) fail(where, "vertices is empty");
    if (indices.empty()) fail(where, "indices is empty (no triangles)");
    if (indices.size() % 3 != 0)
        fail(where, "indices has " + std::to_string(indices.size()) + " entries, not a multiple of 3");
    // Links two apart make bend-like springs; further ones stiffen a surface into a near-rigid shell and
    // their count grows with the square of the distance, so the range stops at 3.
    if (link_distance < 1 || link_distance > 3)
        fail(where, "link_distance must be in [1, 3], got " + std::to_string(link_distance));
    check_total_mass(where, total_mass);
    check_material(where, m);
    for (std::size_t i = 0; i < n; ++i)
        if (!is_finite(vertices[i]))
            fail(where, "vertices[" + std::to_string(i) + "] must be finite, got " + to_text(vertices[i]));

    const std::size_t tri_count = indices.size() / 3;
    for (std::size_t t = 0; t < tri_count; ++t) {
        const std::uint32_t* k = &indices[3 * t];
        for (int c = 0; c < 3; ++c)
            if (k[c] >= n)
                fail(where, "triangle " + std::to_string(t) + ": index " + std::to_string(k[c]) +
                                " is out of range (" + std::to_string(n) + " vertices)");
        // Zero area, relative to the triangle's size: |e1 × e2| <= eps |e1| |e2| means the corner angle is
        // below float's resolution (repeated indices, coincident or collinear vertices). Such a face has
        // no normal for the pressure and a zero-length edge link.
        const Vec3 e1 = vertices[k[1]] - vertices[k[0]], e2 = vertices[k[2]] - vertices[k[0]];
        const Real scale = e1.norm() * e2.norm();
        if (!(e1.cross(e2).norm() > Real(4) * kEpsilon * scale))
            fail(where, "triangle " + std::to_string(t) + " (" + std::to_string(k[0]) + ", " + std::to_string(k[1]) +
                            ", " + std::to_string(k[2]) + ") is degenerate (zero area)");
    }

    reset_geometry(base);
    base.positions = vertices;
    spread_mass(base, total_mass);

    // Adjacency in CSR form from the unique edges; distances by a breadth-first search from every vertex
    // cut at link_distance. A stamp per vertex marks "seen from the current source" without clearing.
    const std::vector<std::uint64_t> edges = unique_edges(indices);
    std::vector<std::uint32_t> start(n + 1, 0), adj(2 * edges.size());
    for (std::uint64_t e : edges) {
        ++start[(e >> 32) + 1];
        ++start[(e & 0xffffffffu) + 1];
    }
    for (std::size_t i = 0; i < n; ++i) start[i + 1] += start[i];
    {
        std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
        for (std::uint64_t e : edges) {
            const std::uint32_t a = std::uint32_t(e >> 32), b = std::uint32_t(e & 0xffffffffu);
            adj[fill[a]++] = b;
            adj[fill[b]++] = a;
        }
    }

    base.links.reserve(edges.size() * std::size_t(link_distance));
    for (std::uint64_t e : edges)
        base.links.push_back(make_link(base.positions, std::uint32_t(e >> 32), std::uint32_t(e & 0xffffffffu),
                                       LinkKind::Structural, m));
    if (link_distance >= 2) {
        std::vector<std::uint32_t> stamp(n, 0xffffffffu), frontier, next;
        std::vector<std::uint32_t> far;  // this source's vertices at distance >= 2, sorted for a stable order
        for (std::uint32_t s = 0; s < n; ++s) {
            stamp[s] = s;
            frontier.assign(1, s);
            far.clear();
            for (int d = 1; d <= link_distance && !frontier.empty(); ++d) {
                next.clear();
                for (std::uint32_t u : frontier)
                    for (std::uint32_t k = start[u]; k < start[u + 1]; ++k) {
                        const std::uint32_t w = adj[k];
                        if (stamp[w] == s) continue;
                        stamp[w] = s;
                        next.push_back(w);
                        if (d >= 2 && w > s) far.push_back(w);  // each pair once, from its smaller end
                    }
                frontier.swap(next);
            }
            std::sort(far.begin(), far.end());
            for (std::uint32_t w : far) {
                if (!((base.positions[w] - base.positions[s]).norm() > 0))
                    fail(where, "vertices " + std::to_string(s) + " and " + std::to_string(w) +
                                    " coincide, so the link between them would have zero rest length");
                base.links.push_back(make_link(base.positions, s, w, LinkKind::Bend, m));
            }
        }
    }
    base.triangles = indices;
    return base;
}

}  // namespace sinew
