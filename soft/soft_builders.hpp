// Builders that fill a SoftBodyDef's geometry: ropes, cloth grids, a particle ragdoll, a "stick box",
// icospheres and bodies from any triangle mesh. The method and the solver settings come from `base`.
#pragma once

#include <vector>

#include "soft/soft_body.hpp"
#include "soft/tet_mesh.hpp"

namespace sinew {

/// Stiffness per link kind. Mass-spring methods read stiffness/damping; Verlet reads fraction.
struct LinkMaterial {
    Real stretch = 1000;  ///< N/m, structural links
    Real shear = 1000;    ///< N/m, shear (diagonal) links
    Real bend = 100;      ///< N/m, bend links (two apart)
    Real damping = 0;     ///< N s/m, every link
    Real fraction = 1;    ///< Verlet stiffness fraction, every link
};

/// A rope of `segments` links from a to b, mass spread evenly over segments+1 particles.
SoftBodyDef make_rope(const Vec3& a, const Vec3& b, int segments, Real total_mass, const LinkMaterial& m,
                      SoftBodyDef base = {});

struct ClothGridDesc {
    int nx = 32, ny = 32;            ///< nodes along u and v (>= 2)
    Vec3 origin = Vec3::Zero();      ///< position of node (0, 0)
    Vec3 edge_u = Vec3(2, 0, 0);     ///< from node (0,0) to node (nx-1, 0) (m)
    Vec3 edge_v = Vec3(0, -2, 0);    ///< from node (0,0) to node (0, ny-1) (m)
    Real total_mass = 1;             ///< kg, spread evenly over the nodes
    bool shear = true;               ///< both diagonals of every quad
    bool bend = false;               ///< links between nodes two apart along u and v
    LinkMaterial material;
};
/// Node (i, j) is particle j * nx + i. Two triangles per quad, counter-clockwise around edge_u × edge_v.
SoftBodyDef make_cloth_grid(const ClothGridDesc& d, SoftBodyDef base = {});
/// Index of node (i, j) in a cloth grid.
inline std::uint32_t cloth_node(const ClothGridDesc& d, int i, int j) {
    return static_cast<std::uint32_t>(j * d.nx + i);
}

/// A particle ragdoll (Jakobsen §"articulated bodies"): head, neck, shoulders, elbows, hands, pelvis, knees,
/// feet, held by stiff sticks and kept from folding by min-distance (inequality) links, e.g. knee-to-knee
/// and hand-to-hip. `feet` is the point between the feet, `height` the standing height (m).
SoftBodyDef make_particle_ragdoll(const Vec3& feet, Real height, Real total_mass, SoftBodyDef base = {});

/// A box of 8 particles with its 12 edges, 12 face diagonals and 4 body diagonals as stiff links: under
/// Verlet it behaves as a rigid box (Jakobsen's "stick box").
SoftBodyDef make_stick_box(const Vec3& centre, const Vec3& half_extents, Real total_mass,
                           SoftBodyDef base = {});

/// A geodesic sphere: an icosahedron subdivided `subdivisions` times (0 -> 12 vertices, 3 -> 642), surface
/// triangles outward, links along the edges (graph distance 1).
SoftBodyDef make_icosphere(const Vec3& centre, Real radius, int subdivisions, Real total_mass,
                           const LinkMaterial& m, SoftBodyDef base = {});

/// Links for any triangle mesh: between every pair of vertices at graph distance <= `link_distance`
/// along the mesh edges (1 = edges only; 2 adds bend-like links), rest lengths from the given positions.
/// Mass spread evenly. Throws SoftError for an index out of range or a degenerate (zero-area) triangle.
SoftBodyDef make_mesh_body(const std::vector<Vec3>& vertices, const std::vector<std::uint32_t>& indices,
                           int link_distance, Real total_mass, const LinkMaterial& m, SoftBodyDef base = {});

/// An FEM body from a tet mesh (soft/tet_mesh.hpp), linear or quadratic (mesh.order): the mesh is checked
/// (check_tet_mesh), its nodes become the particles with lumped masses from base.fem.density (lumped_masses),
/// its tets the elements, its boundary the surface triangles. The method must be force-based (explicit,
/// semi-implicit or implicit) or fast-ms (projective dynamics, linear tets): set base.method, whose
/// default, Verlet, create_body refuses for tets.
SoftBodyDef make_tet_body(const TetMesh& mesh, SoftBodyDef base = {});

}  // namespace sinew
