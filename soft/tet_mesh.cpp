// Tet mesh builders, checks, boundary and masses (soft/tet_mesh.hpp).
#include "soft/tet_mesh.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <unordered_map>

#include "engine/core/format.hpp"
#include "soft/soft_body.hpp"

namespace sinew {

namespace {

[[noreturn]] void fail(const std::string& where, const std::string& what) { throw SoftError(where + ": " + what); }

// Makes tet t positively oriented by swapping its last two nodes if needed.
void orient(const std::vector<Vec3>& x, std::uint32_t* t) {
    if (tet_volume(x[t[0]], x[t[1]], x[t[2]], x[t[3]]) < 0) std::swap(t[2], t[3]);
}

// A face as its sorted node triple, with the tet and the face's outward order.
struct Face {
    std::array<std::uint32_t, 3> key;
    std::array<std::uint32_t, 3> outward;
    std::uint32_t tet;
};

// The four faces of every tet, outward for a positively oriented tet (a, b, c, d): the face opposite a
// is (b, c, d), opposite b (a, d, c), opposite c (a, b, d), opposite d (a, c, b); sorted by key.
std::vector<Face> sorted_faces(const std::vector<std::uint32_t>& tets) {
    std::vector<Face> faces;
    faces.reserve(tets.size());
    for (std::size_t e = 0; e < tets.size() / 4; ++e) {
        const std::uint32_t* t = &tets[4 * e];
        const std::array<std::array<std::uint32_t, 3>, 4> f = {
            {{t[1], t[2], t[3]}, {t[0], t[3], t[2]}, {t[0], t[1], t[3]}, {t[0], t[2], t[1]}}};
        for (const auto& tri : f) {
            Face face{tri, tri, std::uint32_t(e)};
            std::sort(face.key.begin(), face.key.end());
            faces.push_back(face);
        }
    }
    std::sort(faces.begin(), faces.end(), [](const Face& a, const Face& b) { return a.key < b.key; });
    return faces;
}

std::string tet_text(const std::vector<std::uint32_t>& tets, std::size_t e) {
    return "tet " + std::to_string(e) + " (nodes " + std::to_string(tets[4 * e]) + " " + std::to_string(tets[4 * e + 1]) +
           " " + std::to_string(tets[4 * e + 2]) + " " + std::to_string(tets[4 * e + 3]) + ")";
}

std::uint64_t edge_key(std::uint32_t a, std::uint32_t b) {
    return (std::uint64_t(std::min(a, b)) << 32) | std::uint64_t(std::max(a, b));
}

}  // namespace

std::vector<std::uint32_t> corner_tets(const std::vector<std::uint32_t>& tets, int order) {
    if (order != 2) return tets;
    std::vector<std::uint32_t> out;
    out.reserve(tets.size() / 10 * 4);
    for (std::size_t e = 0; e < tets.size() / 10; ++e) out.insert(out.end(), &tets[10 * e], &tets[10 * e + 4]);
    return out;
}

TetMesh make_quadratic(const TetMesh& linear) {
    if (linear.order != 1) throw SoftError("make_quadratic: the mesh is already of order " + std::to_string(linear.order));
    TetMesh q;
    q.order = 2;
    q.nodes = linear.nodes;
    const std::size_t m = linear.tet_count();
    q.tets.reserve(10 * m);
    std::unordered_map<std::uint64_t, std::uint32_t> mid;
    mid.reserve(7 * m / 4 + 16);
    for (std::size_t e = 0; e < m; ++e) {
        const std::uint32_t* t = &linear.tets[4 * e];
        q.tets.insert(q.tets.end(), t, t + 4);
        for (const auto& edge : kTetEdges) {
            const std::uint32_t a = t[edge[0]], b = t[edge[1]];
            const auto found = mid.emplace(edge_key(a, b), std::uint32_t(q.nodes.size()));
            if (found.second) q.nodes.push_back(Real(0.5) * (linear.nodes[a] + linear.nodes[b]));
            q.tets.push_back(found.first->second);
        }
    }
    return q;
}

TetMesh make_tet_box(const Vec3& min_corner, const Vec3& size, int nx, int ny, int nz, HexSplit split) {
    const char* where = "make_tet_box";
    if (!is_finite(min_corner)) fail(where, "min_corner must be finite, got " + to_text(min_corner));
    if (!(is_finite(size) && size.minCoeff() > 0)) fail(where, "size must be finite and > 0, got " + to_text(size));
    if (nx < 1 || ny < 1 || nz < 1 || nx > 1000 || ny > 1000 || nz > 1000)
        fail(where, "cell counts must be in [1, 1000], got " + std::to_string(nx) + " x " + std::to_string(ny) + " x " +
                        std::to_string(nz));
    if (double(nx) * ny * nz > 2e6)
        fail(where, std::to_string(nx) + " x " + std::to_string(ny) + " x " + std::to_string(nz) +
                        " cells is more than 2e6 (10-12 million tets)");
    TetMesh m;
    const int sx = nx + 1, sy = ny + 1, sz = nz + 1;
    m.nodes.reserve(std::size_t(sx) * sy * sz);
    for (int k = 0; k < sz; ++k)
        for (int j = 0; j < sy; ++j)
            for (int i = 0; i < sx; ++i)
                m.nodes.push_back(min_corner + Vec3(size.x() * Real(i) / Real(nx), size.y() * Real(j) / Real(ny),
                                                    size.z() * Real(k) / Real(nz)));
    const auto node = [&](int i, int j, int k) { return std::uint32_t(i + sx * (j + sy * k)); };
    m.tets.reserve(std::size_t(nx) * ny * nz * (split == HexSplit::Five ? 20 : 24));
    for (int k = 0; k < nz; ++k)
        for (int j = 0; j < ny; ++j)
            for (int i = 0; i < nx; ++i) {
                // Corner c of the cell (bit 0: +x, bit 1: +y, bit 2: +z), in the cell's mirrored frame.
                const bool mx = i & 1, my = j & 1, mz = k & 1;
                const auto corner = [&](int c) {
                    const int a = (c & 1) ^ int(mx), b = ((c >> 1) & 1) ^ int(my), d = ((c >> 2) & 1) ^ int(mz);
                    return node(i + a, j + b, k + d);
                };
                const auto add = [&](int a, int b, int c, int d) {
                    const std::size_t at = m.tets.size();
                    m.tets.insert(m.tets.end(), {corner(a), corner(b), corner(c), corner(d)});
                    orient(m.nodes, &m.tets[at]);
                };
                if (split == HexSplit::Five) {
                    // The central tet on the even corners {0, 3, 5, 6}, a corner tet at each odd corner with its
                    // three neighbours. Mirroring every other cell alternates the cut, so faces match.
                    add(0, 3, 5, 6);
                    add(1, 0, 3, 5);
                    add(2, 0, 3, 6);
                    add(4, 0, 5, 6);
                    add(7, 3, 5, 6);
                } else {
                    // Kuhn: one tet per path 0 -> 7 along the cell's edges (each permutation of the axes).
                    const int axes[6][3] = {{1, 2, 4}, {1, 4, 2}, {2, 1, 4}, {2, 4, 1}, {4, 1, 2}, {4, 2, 1}};
                    for (const auto& p : axes) add(0, p[0], p[0] | p[1], 7);
                }
            }
    return m;
}

std::vector<std::uint32_t> boundary_triangles(const std::vector<std::uint32_t>& tets, int order) {
    const std::vector<Face> faces = sorted_faces(order == 2 ? corner_tets(tets, 2) : tets);
    std::unordered_map<std::uint64_t, std::uint32_t> mid;  // quadratic tets: the node on each edge
    if (order == 2)
        for (std::size_t e = 0; e < tets.size() / 10; ++e)
            for (int k = 0; k < 6; ++k) mid[edge_key(tets[10 * e + kTetEdges[k][0]], tets[10 * e + kTetEdges[k][1]])] = tets[10 * e + 4 + k];
    std::vector<std::uint32_t> out;
    for (std::size_t i = 0; i < faces.size();) {
        std::size_t j = i + 1;
        while (j < faces.size() && faces[j].key == faces[i].key) ++j;
        if (j - i == 1) {
            const auto& f = faces[i].outward;
            if (order == 2) {
                // The face cut at its edge nodes: three corner triangles and the middle one, all outward.
                const std::uint32_t ab = mid.at(edge_key(f[0], f[1])), bc = mid.at(edge_key(f[1], f[2])),
                                    ca = mid.at(edge_key(f[2], f[0]));
                out.insert(out.end(), {f[0], ab, ca, ab, f[1], bc, ca, bc, f[2], ab, bc, ca});
            } else {
                out.insert(out.end(), f.begin(), f.end());
            }
        }
        i = j;
    }
    return out;
}

void check_tet_mesh(const std::vector<Vec3>& nodes, const std::vector<std::uint32_t>& all_tets, const std::string& where,
                    int order) {
    const std::size_t n = nodes.size();
    if (order != 1 && order != 2) fail(where, "order = " + std::to_string(order) + " must be 1 (linear tets) or 2 (quadratic)");
    const std::size_t per = std::size_t(tet_nodes(order));
    if (all_tets.empty()) fail(where, "the mesh has no tetrahedra");
    if (all_tets.size() % per != 0)
        fail(where, "tets has " + std::to_string(all_tets.size()) + " indices, not a multiple of " + std::to_string(per) +
                        (order == 2 ? " (quadratic tets have 10 nodes)" : ""));
    for (std::size_t i = 0; i < n; ++i)
        if (!is_finite(nodes[i])) fail(where, "node " + std::to_string(i) + " must be finite, got " + to_text(nodes[i]));
    const std::size_t m = all_tets.size() / per;
    for (std::size_t e = 0; e < m; ++e)
        for (std::size_t c = 0; c < per; ++c)
            if (all_tets[per * e + c] >= n)
                fail(where, "tet " + std::to_string(e) + " refers to node " + std::to_string(all_tets[per * e + c]) +
                                " (the mesh has " + std::to_string(n) + " nodes)");
    // The corners carry the geometry: volumes, faces and the boundary are theirs.
    const std::vector<std::uint32_t> tets = corner_tets(all_tets, order);
    if (order == 2) {
        std::unordered_map<std::uint64_t, std::uint32_t> mid;
        for (std::size_t e = 0; e < m; ++e)
            for (int k = 0; k < 6; ++k) {
                const std::uint32_t a = all_tets[10 * e + kTetEdges[k][0]], b = all_tets[10 * e + kTetEdges[k][1]];
                const std::uint32_t c = all_tets[10 * e + 4 + k];
                const Vec3 centre = Real(0.5) * (nodes[a] + nodes[b]);
                if (!((nodes[c] - centre).norm() <= Real(1e-4) * (nodes[b] - nodes[a]).norm()))
                    fail(where, "node " + std::to_string(c) + " of tet " + std::to_string(e) + " is not at the midpoint of its edge (" +
                                    std::to_string(a) + ", " + std::to_string(b) + "): quadratic tets must have straight edges, "
                                    "their edge nodes in the order (0 1) (1 2) (0 2) (0 3) (1 3) (2 3)");
                const auto found = mid.emplace(edge_key(a, b), c);
                if (found.first->second != c)
                    fail(where, "the edge (" + std::to_string(a) + ", " + std::to_string(b) + ") has node " +
                                    std::to_string(found.first->second) + " in one tet and node " + std::to_string(c) + " in tet " +
                                    std::to_string(e));
            }
    }
    for (std::size_t e = 0; e < m; ++e) {
        const Vec3 &a = nodes[tets[4 * e]], &b = nodes[tets[4 * e + 1]], &c = nodes[tets[4 * e + 2]], &d = nodes[tets[4 * e + 3]];
        const Real v = tet_volume(a, b, c, d);
        const Real l = std::max({(b - a).norm(), (c - a).norm(), (d - a).norm(), (c - b).norm(), (d - b).norm(), (d - c).norm()});
        if (!(v > Real(1e-6) * l * l * l))
            fail(where, tet_text(tets, e) + " has volume " + to_text(v) + " m^3" +
                            (v < 0 ? " (inverted: its nodes are ordered the wrong way round)"
                                   : " (degenerate: flat or collapsed, below 1e-6 of its longest edge cubed)"));
    }
    // Nodes at the same place: sort by position quantised to 1e-7 of the mesh's size.
    Vec3 lo = nodes[0], hi = nodes[0];
    for (const Vec3& x : nodes) {
        lo = lo.cwiseMin(x);
        hi = hi.cwiseMax(x);
    }
    const double cell = std::max(1e-30, 1e-7 * double((hi - lo).norm()));
    std::vector<std::pair<std::array<long long, 3>, std::uint32_t>> keyed(n);
    for (std::size_t i = 0; i < n; ++i)
        keyed[i] = {{std::llround(double(nodes[i].x() - lo.x()) / cell), std::llround(double(nodes[i].y() - lo.y()) / cell),
                     std::llround(double(nodes[i].z() - lo.z()) / cell)},
                    std::uint32_t(i)};
    std::sort(keyed.begin(), keyed.end());
    for (std::size_t i = 1; i < n; ++i)
        if (keyed[i].first == keyed[i - 1].first)
            fail(where, "nodes " + std::to_string(std::min(keyed[i - 1].second, keyed[i].second)) + " and " +
                            std::to_string(std::max(keyed[i - 1].second, keyed[i].second)) + " are at the same place " +
                            to_text(nodes[keyed[i].second]));
    std::vector<char> used(n, 0);
    for (const std::uint32_t i : all_tets) used[i] = 1;
    for (std::size_t i = 0; i < n; ++i)
        if (!used[i]) fail(where, "node " + std::to_string(i) + " belongs to no tet");
    // Faces: shared by at most two tets; the boundary a closed 2-manifold (each edge on two boundary faces).
    const std::vector<Face> faces = sorted_faces(tets);
    std::vector<std::array<std::uint32_t, 2>> edges;
    for (std::size_t i = 0; i < faces.size();) {
        std::size_t j = i + 1;
        while (j < faces.size() && faces[j].key == faces[i].key) ++j;
        if (j - i > 2)
            fail(where, "the face (" + std::to_string(faces[i].key[0]) + ", " + std::to_string(faces[i].key[1]) + ", " +
                            std::to_string(faces[i].key[2]) + ") belongs to " + std::to_string(j - i) + " tets (" +
                            tet_text(tets, faces[i].tet) + " is one): at most two may share a face");
        if (j - i == 1)
            for (int c = 0; c < 3; ++c) {
                std::uint32_t a = faces[i].key[c], b = faces[i].key[(c + 1) % 3];
                edges.push_back({std::min(a, b), std::max(a, b)});
            }
        i = j;
    }
    std::sort(edges.begin(), edges.end());
    for (std::size_t i = 0; i < edges.size();) {
        std::size_t j = i + 1;
        while (j < edges.size() && edges[j] == edges[i]) ++j;
        if (j - i != 2)
            fail(where, "the boundary is not a closed manifold: the edge (" + std::to_string(edges[i][0]) + ", " +
                            std::to_string(edges[i][1]) + ") lies on " + std::to_string(j - i) + " boundary faces (2 expected)");
        i = j;
    }
}

std::vector<Real> lumped_masses(const std::vector<Vec3>& nodes, const std::vector<std::uint32_t>& tets, Real density,
                                int order) {
    std::vector<double> m(nodes.size(), 0.0);
    const std::size_t per = std::size_t(tet_nodes(order));
    for (std::size_t e = 0; e < tets.size() / per; ++e) {
        const std::uint32_t* t = &tets[per * e];
        const double me = double(density) * double(std::abs(tet_volume(nodes[t[0]], nodes[t[1]], nodes[t[2]], nodes[t[3]])));
        // HRZ for quadratic tets: ∫N_corner² = V/70 and ∫N_edge² = 8V/105, scaled to sum to ρ V.
        const double corner = order == 2 ? me / 36 : me / 4, edge = me * 4 / 27;
        for (int c = 0; c < 4; ++c) m[t[c]] += corner;
        for (std::size_t c = 4; c < per; ++c) m[t[c]] += edge;
    }
    return std::vector<Real>(m.begin(), m.end());
}

void orient_tets(const std::vector<Vec3>& nodes, std::vector<std::uint32_t>& tets) {
    std::size_t negative = 0;
    const std::size_t m = tets.size() / 4;
    for (std::size_t e = 0; e < m; ++e) {
        const std::uint32_t* t = &tets[4 * e];
        if (t[0] >= nodes.size() || t[1] >= nodes.size() || t[2] >= nodes.size() || t[3] >= nodes.size()) return;
        if (tet_volume(nodes[t[0]], nodes[t[1]], nodes[t[2]], nodes[t[3]]) < 0) ++negative;
    }
    if (m > 0 && negative == m)
        for (std::size_t e = 0; e < m; ++e) std::swap(tets[4 * e + 2], tets[4 * e + 3]);
}

}  // namespace sinew
