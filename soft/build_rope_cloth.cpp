// Rope and cloth-grid builders: positions, masses, links and surface triangles, no pins (callers pin).
//
// Every link gets its rest length from the built positions, k_s/k_d from the LinkMaterial of its kind
// (mass-spring methods) and the stiffness fraction (Verlet). Verlet reads min_length = max_length = rest
// as an equality distance constraint (Jakobsen 2003). The cloth grid is Provot's structural/shear/bend
// layout used by every mass-spring cloth (Baraff & Witkin 1998, Volino & Magnenat-Thalmann).
#include <algorithm>
#include <cmath>
#include <string>

#include "soft/builder_common.hpp"

namespace sinew {

using namespace builder;

SoftBodyDef make_rope(const Vec3& a, const Vec3& b, int segments, Real total_mass, const LinkMaterial& m,
                      SoftBodyDef base) {
    const char* where = "make_rope";
    check_point(where, "a", a);
    check_point(where, "b", b);
    if (segments < 1) fail(where, "segments must be >= 1, got " + std::to_string(segments));
    check_positive(where, "total_mass", total_mass);
    check_material(where, m);
    const Real length = (b - a).norm();
    if (!(length > 0)) fail(where, "a and b coincide (zero-length rope)");

    reset_geometry(base);
    const int n = segments + 1;
    const Real mass = total_mass / Real(n);
    base.positions.reserve(n);
    for (int i = 0; i < n; ++i) base.positions.push_back(a + (b - a) * (Real(i) / Real(segments)));
    base.masses.assign(n, mass);
    base.links.reserve(segments);
    for (int i = 0; i < segments; ++i)
        base.links.push_back(make_link(base.positions, std::uint32_t(i), std::uint32_t(i + 1), LinkKind::Structural, m));
    return base;
}

SoftBodyDef make_cloth_grid(const ClothGridDesc& d, SoftBodyDef base) {
    const char* where = "make_cloth_grid";
    if (d.nx < 2) fail(where, "nx must be >= 2, got " + std::to_string(d.nx));
    if (d.ny < 2) fail(where, "ny must be >= 2, got " + std::to_string(d.ny));
    check_point(where, "origin", d.origin);
    check_point(where, "edge_u", d.edge_u);
    check_point(where, "edge_v", d.edge_v);
    check_positive(where, "total_mass", d.total_mass);
    check_material(where, d.material);
    const Vec3 normal = d.edge_u.cross(d.edge_v);
    if (!(normal.norm() > kEpsilon * d.edge_u.norm() * d.edge_v.norm()) || !(normal.norm() > 0))
        fail(where, "edge_u and edge_v are zero or parallel (degenerate grid)");

    reset_geometry(base);
    const int nx = d.nx, ny = d.ny;
    const std::size_t count = std::size_t(nx) * std::size_t(ny);
    const Vec3 du = d.edge_u / Real(nx - 1), dv = d.edge_v / Real(ny - 1);
    base.positions.reserve(count);
    for (int j = 0; j < ny; ++j)
        for (int i = 0; i < nx; ++i) base.positions.push_back(d.origin + Real(i) * du + Real(j) * dv);
    base.masses.assign(count, d.total_mass / Real(count));

    auto node = [&](int i, int j) { return cloth_node(d, i, j); };
    const std::vector<Vec3>& x = base.positions;
    std::vector<Link>& links = base.links;
    std::size_t n_links = std::size_t(nx - 1) * ny + std::size_t(nx) * (ny - 1);
    if (d.shear) n_links += 2 * std::size_t(nx - 1) * (ny - 1);
    if (d.bend) n_links += std::size_t(std::max(nx - 2, 0)) * ny + std::size_t(nx) * std::max(ny - 2, 0);
    links.reserve(n_links);

    // Structural first (row by row), then shear, then bend: the Gauss-Seidel order of Verlet relaxation
    // follows this order, and the structural links matter most for stretch.
    for (int j = 0; j < ny; ++j)
        for (int i = 0; i + 1 < nx; ++i) links.push_back(make_link(x, node(i, j), node(i + 1, j), LinkKind::Structural, d.material));
    for (int j = 0; j + 1 < ny; ++j)
        for (int i = 0; i < nx; ++i) links.push_back(make_link(x, node(i, j), node(i, j + 1), LinkKind::Structural, d.material));
    if (d.shear)
        for (int j = 0; j + 1 < ny; ++j)
            for (int i = 0; i + 1 < nx; ++i) {
                links.push_back(make_link(x, node(i, j), node(i + 1, j + 1), LinkKind::Shear, d.material));
                links.push_back(make_link(x, node(i + 1, j), node(i, j + 1), LinkKind::Shear, d.material));
            }
    if (d.bend) {
        for (int j = 0; j < ny; ++j)
            for (int i = 0; i + 2 < nx; ++i) links.push_back(make_link(x, node(i, j), node(i + 2, j), LinkKind::Bend, d.material));
        for (int j = 0; j + 2 < ny; ++j)
            for (int i = 0; i < nx; ++i) links.push_back(make_link(x, node(i, j), node(i, j + 2), LinkKind::Bend, d.material));
    }

    // Two triangles per quad, (00, 10, 11) and (00, 11, 01): both have normal du x dv, i.e. they are
    // counter-clockwise seen from the side edge_u x edge_v points to.
    base.triangles.reserve(6 * std::size_t(nx - 1) * (ny - 1));
    for (int j = 0; j + 1 < ny; ++j)
        for (int i = 0; i + 1 < nx; ++i) {
            const std::uint32_t a = node(i, j), b = node(i + 1, j), c = node(i + 1, j + 1), e = node(i, j + 1);
            base.triangles.insert(base.triangles.end(), {a, b, c, a, c, e});
        }
    return base;
}

}  // namespace sinew
