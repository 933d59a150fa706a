// Tetrahedral meshes for FEM bodies: the structured box builder, the checks every mesh passes before a
// body is built from it, the boundary surface, lumped masses, and loaders for TetGen's .node/.ele and
// gmsh's .msh files (soft/tet_mesh_io.cpp). A tetrahedron (a, b, c, d) is positively oriented when
// (b - a) · ((c - a) × (d - a)) > 0; every mesh here is.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "engine/core/math.hpp"

namespace sinew {

/// Nodes per tetrahedron of an element order: 4 for linear tets (order 1), 10 for quadratic ones (order 2).
inline int tet_nodes(int order) { return order == 2 ? 10 : 4; }

/// A quadratic (10-node) tet lists its 4 corners, then the node at the midpoint of each edge in this order
/// (VTK's): node 4 + k is the midpoint of corners kTetEdges[k][0] and kTetEdges[k][1]. Its edges are
/// straight (the geometry is the corners' affine map; only the displacement is quadratic).
constexpr int kTetEdges[6][2] = {{0, 1}, {1, 2}, {0, 2}, {0, 3}, {1, 3}, {2, 3}};

struct TetMesh {
    std::vector<Vec3> nodes;          ///< m
    std::vector<std::uint32_t> tets;  ///< tet_nodes(order) node indices per tetrahedron, positively oriented
    int order = 1;                    ///< 1: linear 4-node tets; 2: quadratic 10-node tets
    std::size_t tet_count() const { return tets.size() / std::size_t(tet_nodes(order)); }
};

/// Signed volume (b - a) · ((c - a) × (d - a)) / 6 (m³).
inline Real tet_volume(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
    return (b - a).dot((c - a).cross(d - a)) / Real(6);
}

/// How each hexahedron of a structured box is cut into tetrahedra.
enum class HexSplit : std::uint8_t {
    Five,  ///< 4 corner tets and a central one; the cut alternates between neighbouring cells
    Six,   ///< Kuhn's 6 tets around a cell diagonal, each cell mirrored by the parity of its index
};

/// A box from `min_corner` of extents `size`, cut into nx × ny × nz hexahedra and each into tets; the cuts
/// are mirrored from cell to cell so the faces match and the mesh is symmetric about its mid-planes when
/// the counts are even. Node (i, j, k) is i + (nx + 1) (j + (ny + 1) k). Throws SoftError for counts outside
/// [1, 1000] or above 2e6 cells in all, a size that is not finite and positive, or a corner that is not finite.
TetMesh make_tet_box(const Vec3& min_corner, const Vec3& size, int nx, int ny, int nz, HexSplit split = HexSplit::Five);

/// The same mesh with quadratic (10-node) tets: a node added at the midpoint of every edge, after the
/// corners (which keep their indices), shared by the tets around the edge.
TetMesh make_quadratic(const TetMesh& linear);

/// The 4 corners of each tet of `order` (a copy of `tets` for order 1).
std::vector<std::uint32_t> corner_tets(const std::vector<std::uint32_t>& tets, int order);

/// Checks a mesh before a body is built from it and throws SoftError naming the first problem:
/// an order other than 1 or 2, an index count that is not a multiple of 4 (10 for quadratic tets), an index out of range, a non-finite node, a tet with
/// non-positive or degenerate volume (below 1e-6 of its longest edge cubed; the message gives the element,
/// its nodes and its volume), two nodes at the same place, a node no tet uses, a face shared by more than
/// two tets, or a boundary that is not a closed 2-manifold (an edge on other than two boundary faces).
/// Quadratic tets also: an edge node away from its edge's midpoint (by more than 1e-4 of the edge) or two
/// tets giving one edge different nodes.
/// `where` prefixes the message (e.g. the file name).
void check_tet_mesh(const std::vector<Vec3>& nodes, const std::vector<std::uint32_t>& tets, const std::string& where,
                    int order = 1);

/// The faces that belong to exactly one tet, 3 indices each, counter-clockwise seen from outside. A
/// quadratic tet's boundary face is cut into 4 triangles through its edge nodes.
std::vector<std::uint32_t> boundary_triangles(const std::vector<std::uint32_t>& tets, int order = 1);

/// Lumped masses that sum to ρ V_mesh. Linear tets: each node gets a quarter of ρ V of every tet it belongs
/// to. Quadratic tets: the consistent mass matrix's diagonal scaled to the element's mass (Hinton, Rock &
/// Zienkiewicz 1976), 1/36 of ρ V to each corner and 4/27 to each edge node (row sums would give the
/// corners negative masses).
std::vector<Real> lumped_masses(const std::vector<Vec3>& nodes, const std::vector<std::uint32_t>& tets, Real density,
                                int order = 1);

/// Loads TetGen's `<base>.node` and `<base>.ele` (0- or 1-based, comments with #, extra attributes and
/// markers ignored; 10-node tets keep their 4 corners). Throws SoftError naming the file and line.
TetMesh load_tetgen(const std::string& node_path, const std::string& ele_path);
/// Loads a gmsh .msh file, ASCII format 2.2 or 4.1: its nodes and its 4-node tetrahedra (other elements
/// are skipped; unused nodes are dropped). Throws SoftError naming the file and line.
TetMesh load_gmsh(const std::string& path);

/// Writes `mesh` as TetGen's .node and .ele files (0-based, the orientation this file uses; quadratic tets
/// with their 10 nodes, which load_tetgen reads back as corners); throws
/// SoftError naming a file that cannot be written.
void save_tetgen(const TetMesh& mesh, const std::string& node_path, const std::string& ele_path);

/// Orients a loaded mesh: if every tet is negatively oriented (a file format's convention), two nodes of
/// each are swapped; mixed orientations are left for check_tet_mesh to report.
void orient_tets(const std::vector<Vec3>& nodes, std::vector<std::uint32_t>& tets);

}  // namespace sinew
