// An FEM body from a tet mesh (soft/soft_builders.hpp).
#include "soft/builder_common.hpp"
#include "soft/soft_builders.hpp"

namespace sinew {

SoftBodyDef make_tet_body(const TetMesh& mesh, SoftBodyDef base) {
    const char* where = "make_tet_body";
    check_tet_mesh(mesh.nodes, mesh.tets, where, mesh.order);
    builder::check_positive(where, "fem.density", base.fem.density);
    SoftBodyDef d = std::move(base);
    builder::reset_geometry(d);
    d.positions = mesh.nodes;
    d.masses = lumped_masses(mesh.nodes, mesh.tets, d.fem.density, mesh.order);
    d.tets = mesh.tets;
    d.tet_order = mesh.order;
    d.triangles = boundary_triangles(mesh.tets, mesh.order);
    return d;
}

}  // namespace sinew
