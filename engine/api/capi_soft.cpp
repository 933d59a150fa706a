// C API: soft bodies (soft/soft_system.hpp), created through the builders of soft/soft_builders.hpp.
//
// Every argument is checked here, naming the C field (def->drag, cloth->nx, vertices[3], particle = 7),
// before anything is built; SoftError from the soft layer (e.g. a degenerate mesh triangle) is the last
// line of defence and is reported as SINEW_ERROR_INVALID_ARGUMENT with its own text.
#include <algorithm>
#include <cmath>

#include "engine/api/capi_internal.hpp"
#include "soft/soft_integrators.hpp"
#include "engine/core/format.hpp"
#include "soft/fem_elements.hpp"
#include "soft/soft_builders.hpp"
#include "soft/soft_stability.hpp"

using namespace sinew;
using namespace sinew::capi;

namespace {

std::string vec_text(const sinew_vec3& v) { return to_text(Vec3(Real(v.x), Real(v.y), Real(v.z))); }

bool nonneg(float x) { return std::isfinite(x) && x >= 0; }

/// "" if the definition is valid, else what is wrong with which field.
std::string check_soft_def(const sinew_soft_def& d) {
    const int method = enum_value(d.method);
    if (method < SINEW_SOFT_VERLET || method > SINEW_SOFT_FAST_MS)
        return "def->method = " + std::to_string(method) + " is not a sinew_soft_method";
    if (d.iterations < 1 || d.iterations > 10000)
        return "def->iterations = " + std::to_string(d.iterations) + " must be in [1, 10000]";
    if (!nonneg(d.drag)) return "def->drag = " + to_text(d.drag) + " must be finite and >= 0 (1/s)";
    if (!nonneg(d.friction)) return "def->friction = " + to_text(d.friction) + " must be finite and >= 0";
    if (!(d.restitution >= 0 && d.restitution <= 1))
        return "def->restitution = " + to_text(d.restitution) + " must be in [0, 1]";
    if (!(std::isfinite(d.thickness) && d.thickness > 0))
        return "def->thickness = " + to_text(d.thickness) + " must be finite and > 0 (m)";
    if (!nonneg(d.pressure)) return "def->pressure = " + to_text(d.pressure) + " must be finite and >= 0 (J)";
    if (d.long_range_attachments != 0 && d.long_range_attachments != 1)
        return "def->long_range_attachments = " + std::to_string(d.long_range_attachments) + " must be 0 or 1";
    if (d.self_collision != 0 && d.self_collision != 1)
        return "def->self_collision = " + std::to_string(d.self_collision) + " must be 0 or 1";
    if (d.tet_order != 1 && d.tet_order != 2)
        return "def->tet_order = " + std::to_string(d.tet_order) + " must be 1 (linear tets) or 2 (quadratic tets)";
    const int relaxation = enum_value(d.relaxation);
    if (relaxation < SINEW_RELAXATION_IN_ORDER || relaxation > SINEW_RELAXATION_BY_COLOUR)
        return "def->relaxation = " + std::to_string(relaxation) + " is not a sinew_soft_relaxation";
    const int preconditioner = enum_value(d.preconditioner);
    if (preconditioner < SINEW_PRECONDITIONER_BLOCK_JACOBI || preconditioner > SINEW_PRECONDITIONER_REST_FACTOR)
        return "def->preconditioner = " + std::to_string(preconditioner) + " is not a sinew_soft_preconditioner";
    const struct {
        const char* name;
        float value;
    } stiff[] = {{"stretch", d.links.stretch}, {"shear", d.links.shear}, {"bend", d.links.bend}, {"damping", d.links.damping}};
    for (const auto& s : stiff)
        if (!nonneg(s.value))
            return std::string("def->links.") + s.name + " = " + to_text(s.value) + " must be finite and >= 0";
    if (!(d.links.fraction > 0 && d.links.fraction <= 1))
        return "def->links.fraction = " + to_text(d.links.fraction) + " must be in (0, 1]";
    if (!(std::isfinite(d.total_mass) && d.total_mass > 0))
        return "def->total_mass = " + to_text(d.total_mass) + " must be finite and > 0 (kg)";
    if (!finite(d.velocity)) return "def->velocity = " + vec_text(d.velocity) + " must be finite";
    if (!std::isfinite(d.gravity_scale)) return "def->gravity_scale = " + to_text(d.gravity_scale) + " must be finite";
    if (d.allow_sleep != 0 && d.allow_sleep != 1)
        return "def->allow_sleep = " + std::to_string(d.allow_sleep) + " must be 0 or 1";
    return {};
}

SoftBodyDef base_def(const sinew_soft_def& d) {
    SoftBodyDef b;
    switch (enum_value(d.method)) {
        case SINEW_SOFT_EXPLICIT: b.method = SoftMethod::ExplicitEuler; break;
        case SINEW_SOFT_SEMI_IMPLICIT: b.method = SoftMethod::SemiImplicitEuler; break;
        case SINEW_SOFT_IMPLICIT: b.method = SoftMethod::ImplicitEuler; break;
        case SINEW_SOFT_FAST_MS: b.method = SoftMethod::FastMassSpring; break;
        default: b.method = SoftMethod::Verlet; break;
    }
    b.iterations = d.iterations;
    b.drag = Real(d.drag);
    b.friction = Real(d.friction);
    b.restitution = Real(d.restitution);
    b.thickness = Real(d.thickness);
    b.pressure = Real(d.pressure);
    b.long_range_attachments = d.long_range_attachments == 1;
    b.initial_velocity = to_vec(d.velocity);
    b.gravity_scale = Real(d.gravity_scale);
    b.allow_sleep = d.allow_sleep == 1;
    b.filter = to_filter(d.filter);
    b.self_collision = d.self_collision == 1;
    b.preconditioner = enum_value(d.preconditioner) == SINEW_PRECONDITIONER_REST_FACTOR ? SoftPreconditioner::RestFactor
                                                                                        : SoftPreconditioner::BlockJacobi;
    b.relaxation = enum_value(d.relaxation) == SINEW_RELAXATION_BY_COLOUR ? SoftRelaxation::ByColour : SoftRelaxation::InOrder;
    b.user_data = d.user_data;
    return b;
}

LinkMaterial link_material(const sinew_soft_def& d) {
    LinkMaterial m;
    m.stretch = Real(d.links.stretch);
    m.shear = Real(d.links.shear);
    m.bend = Real(d.links.bend);
    m.damping = Real(d.links.damping);
    m.fraction = Real(d.links.fraction);
    return m;
}

/// The checks every creation shares: pointers, the world (not stepping) and the definition.
sinew_status begin_create(const char* fn, sinew_world_id world, const sinew_soft_def* def, sinew_soft_body_id* out,
                          World** w) {
    if (!def) return null_arg(fn, "def");
    if (!out) return null_arg(fn, "out");
    *w = find_world(world, fn);
    if (!*w) return SINEW_ERROR_STALE_ID;
    if (sinew_status s = check_not_stepping(*w, fn)) return s;
    const std::string bad = check_soft_def(*def);
    if (!bad.empty()) return invalid(fn, bad);
    return SINEW_OK;
}

}  // namespace

void sinew::capi::warn_if_unstable(const char* fn, sinew_world_id world, const World& w, SoftBodyId id) {
    // Created, but past its method's documented stability limit at the step it takes (the world's, or a
    // coupling layer's sub-step): the host hears now, not when the body turns non-finite.
    const Real h = w.settings().time_step / Real(w.soft().substeps());
    const std::string warning = stability_warning(w.soft().body(id), h);
    if (warning.empty()) return;
    log_message(SINEW_LOG_WARNING, std::string(fn) + ": soft body {world " + std::to_string(pack_world(world)) +
                                       ", index " + std::to_string(id.index) + ", generation " +
                                       std::to_string(id.generation) + "}: " + warning);
}

namespace {

sinew_status finish_create(const char* fn, World* w, sinew_world_id world, SoftBodyDef def, sinew_soft_body_id* out) {
    const SoftBodyId id = w->soft().create_body(std::move(def));  // SoftError: nothing was created
    w->coupling().refresh_embedding();  // an embedded body has its proxy at once
    *out = {pack_world(world), id.index, id.generation};
    warn_if_unstable(fn, world, *w, id);
    return SINEW_OK;
}

/// The soft body and its world, or the failure recorded; also rejects mutations during a step.
struct Target {
    World* world = nullptr;
    SoftBodyId body;
    sinew_status status = SINEW_OK;
};
Target target(sinew_soft_body_id id, const char* fn, bool mutates) {
    Target t;
    if (id.generation == 0) {
        t.status = fail(SINEW_ERROR_STALE_ID, std::string(fn) + ": soft body is the null handle");
        return t;
    }
    const sinew_world_id wid{id.world & 0xFFFFu, id.world >> 16};
    t.world = find_world(wid, fn);
    if (!t.world) {
        t.status = SINEW_ERROR_STALE_ID;
        return t;
    }
    const SoftBodyId b{id.index, id.generation};
    if (!t.world->soft().valid(b)) {
        t.status = fail(SINEW_ERROR_STALE_ID, std::string(fn) + ": soft body {index " + std::to_string(id.index) +
                                                  ", generation " + std::to_string(id.generation) +
                                                  "} is null, destroyed or not in world " + std::to_string(id.world));
        return t;
    }
    if (mutates && t.world->in_step()) {
        t.status = fail(SINEW_ERROR_IN_STEP, std::string(fn) + ": the world is stepping");
        return t;
    }
    t.body = b;
    return t;
}

/// SINEW_OK if `particle` indexes the body's particles, else the failure recorded.
sinew_status check_particle(const Target& t, int particle, const char* fn) {
    const std::size_t n = t.world->soft().body(t.body).p.size();
    if (particle < 0 || static_cast<std::size_t>(particle) >= n)
        return invalid(fn, "particle = " + std::to_string(particle) + " is out of range (" + std::to_string(n) +
                               " particles)");
    return SINEW_OK;
}

/// "" if the material is valid (an unknown rotation or a NaN named by its C field), else the problem.
std::string check_fem_material(const sinew_fem_material& m);

FemMaterial fem_material(const sinew_fem_material& m) {
    FemMaterial f;
    f.young = Real(m.young);
    f.poisson = Real(m.poisson);
    f.density = Real(m.density);
    f.mass_damping = Real(m.mass_damping);
    f.stiffness_damping = Real(m.stiffness_damping);
    f.yield = Real(m.yield);
    f.creep = Real(m.creep);
    f.max_plastic = Real(m.max_plastic);
    f.rotation = enum_value(m.rotation) == SINEW_FEM_LINEAR ? FemRotation::Linear
                 : enum_value(m.rotation) == SINEW_FEM_QR   ? FemRotation::QR
                                                              : FemRotation::Polar;
    return f;
}

std::string check_fem_material(const sinew_fem_material& m) {
    const int r = enum_value(m.rotation);
    if (r < SINEW_FEM_LINEAR || r > SINEW_FEM_QR) return "material->rotation = " + std::to_string(r) + " is not a sinew_fem_rotation";
    return fem_material_problem(fem_material(m), "material->");
}

/// The checks of a tet body's creation beyond begin_create's: the material and a force-based method.
sinew_status check_fem_create(const char* fn, const sinew_soft_def& def, const sinew_fem_material* material) {
    if (!material) return null_arg(fn, "material");
    if (!accepts_tets(base_def(def).method))  // begin_create checked the value is a sinew_soft_method
        return invalid(fn, "def->method = " + std::to_string(enum_value(def.method)) +
                               ": a tet body needs SINEW_SOFT_IMPLICIT, SINEW_SOFT_SEMI_IMPLICIT, SINEW_SOFT_EXPLICIT or "
                               "SINEW_SOFT_FAST_MS (projective dynamics)");
    const std::string bad = check_fem_material(*material);
    if (!bad.empty()) return invalid(fn, bad);
    return SINEW_OK;
}

}  // namespace

extern "C" {

sinew_soft_def sinew_soft_def_default(void) {
    const SoftBodyDef b;
    const LinkMaterial m;
    sinew_soft_def d;
    d.method = SINEW_SOFT_VERLET;
    d.iterations = b.iterations;
    d.drag = float(b.drag);
    d.friction = float(b.friction);
    d.restitution = float(b.restitution);
    d.thickness = float(b.thickness);
    d.pressure = float(b.pressure);
    d.long_range_attachments = b.long_range_attachments ? 1 : 0;
    d.links = {float(m.stretch), float(m.shear), float(m.bend), float(m.damping), float(m.fraction)};
    d.total_mass = 1;
    d.velocity = to_c(b.initial_velocity);
    d.gravity_scale = float(b.gravity_scale);
    d.allow_sleep = b.allow_sleep ? 1 : 0;
    d.filter = to_c(b.filter);
    d.tet_order = 1;
    d.preconditioner = SINEW_PRECONDITIONER_BLOCK_JACOBI;
    d.self_collision = b.self_collision ? 1 : 0;
    d.user_data = 0;
    d.relaxation = SINEW_RELAXATION_IN_ORDER;
    return d;
}

sinew_cloth_def sinew_cloth_def_default(void) {
    const ClothGridDesc c;
    sinew_cloth_def d;
    d.nx = 16;
    d.ny = 16;
    d.origin = to_c(c.origin);
    d.edge_u = to_c(c.edge_u);
    d.edge_v = to_c(c.edge_v);
    d.shear = c.shear ? 1 : 0;
    d.bend = c.bend ? 1 : 0;
    d.pinned_corners = 0;
    return d;
}

sinew_status sinew_soft_create_cloth(sinew_world_id world, const sinew_soft_def* def, const sinew_cloth_def* cloth,
                                     sinew_soft_body_id* out) {
    const char* fn = "sinew_soft_create_cloth";
    return guarded(fn, [&] {
        if (!cloth) return null_arg(fn, "cloth");
        World* w = nullptr;
        if (sinew_status s = begin_create(fn, world, def, out, &w)) return s;
        const sinew_cloth_def& c = *cloth;
        if (c.nx < 2 || c.nx > 4096) return invalid(fn, "cloth->nx = " + std::to_string(c.nx) + " must be in [2, 4096]");
        if (c.ny < 2 || c.ny > 4096) return invalid(fn, "cloth->ny = " + std::to_string(c.ny) + " must be in [2, 4096]");
        if (!finite(c.origin)) return invalid(fn, "cloth->origin = " + vec_text(c.origin) + " must be finite");
        if (!finite(c.edge_u)) return invalid(fn, "cloth->edge_u = " + vec_text(c.edge_u) + " must be finite");
        if (!finite(c.edge_v)) return invalid(fn, "cloth->edge_v = " + vec_text(c.edge_v) + " must be finite");
        const Vec3 u = to_vec(c.edge_u), v = to_vec(c.edge_v);
        // Parallel or zero edges make zero-area triangles and zero-length links.
        if (!(u.cross(v).norm() > Real(1e-6) * u.norm() * v.norm()) || u.norm() == 0 || v.norm() == 0)
            return invalid(fn, "cloth->edge_u = " + vec_text(c.edge_u) + " and cloth->edge_v = " + vec_text(c.edge_v) +
                                   " must be non-zero and not parallel");
        if (c.shear != 0 && c.shear != 1) return invalid(fn, "cloth->shear = " + std::to_string(c.shear) + " must be 0 or 1");
        if (c.bend != 0 && c.bend != 1) return invalid(fn, "cloth->bend = " + std::to_string(c.bend) + " must be 0 or 1");
        if (c.pinned_corners < 0 || c.pinned_corners > 15)
            return invalid(fn, "cloth->pinned_corners = " + std::to_string(c.pinned_corners) +
                                   " must combine SINEW_CLOTH_PIN_* flags (0 to 15)");
        ClothGridDesc g;
        g.nx = c.nx;
        g.ny = c.ny;
        g.origin = to_vec(c.origin);
        g.edge_u = u;
        g.edge_v = v;
        g.total_mass = Real(def->total_mass);
        g.shear = c.shear == 1;
        g.bend = c.bend == 1;
        g.material = link_material(*def);
        SoftBodyDef d = make_cloth_grid(g, base_def(*def));
        const int corner_i[4] = {0, g.nx - 1, 0, g.nx - 1}, corner_j[4] = {0, 0, g.ny - 1, g.ny - 1};
        for (int k = 0; k < 4; ++k)
            if (c.pinned_corners & (1 << k)) d.pinned.push_back(cloth_node(g, corner_i[k], corner_j[k]));
        return finish_create(fn, w, world, std::move(d), out);
    });
}

sinew_status sinew_soft_create_rope(sinew_world_id world, const sinew_soft_def* def, sinew_vec3 from, sinew_vec3 to,
                                    int segments, sinew_soft_body_id* out) {
    const char* fn = "sinew_soft_create_rope";
    return guarded(fn, [&] {
        World* w = nullptr;
        if (sinew_status s = begin_create(fn, world, def, out, &w)) return s;
        if (!finite(from)) return invalid(fn, "from = " + vec_text(from) + " must be finite");
        if (!finite(to)) return invalid(fn, "to = " + vec_text(to) + " must be finite");
        if (!((to_vec(to) - to_vec(from)).norm() > 0)) return invalid(fn, "from and to are the same point " + vec_text(to));
        if (segments < 1 || segments > 100000)
            return invalid(fn, "segments = " + std::to_string(segments) + " must be in [1, 100000]");
        SoftBodyDef d = make_rope(to_vec(from), to_vec(to), segments, Real(def->total_mass), link_material(*def), base_def(*def));
        return finish_create(fn, w, world, std::move(d), out);
    });
}

sinew_status sinew_soft_create_icosphere(sinew_world_id world, const sinew_soft_def* def, sinew_vec3 center,
                                         float radius, int subdivisions, sinew_soft_body_id* out) {
    const char* fn = "sinew_soft_create_icosphere";
    return guarded(fn, [&] {
        World* w = nullptr;
        if (sinew_status s = begin_create(fn, world, def, out, &w)) return s;
        if (!finite(center)) return invalid(fn, "center = " + vec_text(center) + " must be finite");
        if (!(std::isfinite(radius) && radius > 0)) return invalid(fn, "radius = " + to_text(radius) + " must be finite and > 0 (m)");
        if (subdivisions < 0 || subdivisions > 6)
            return invalid(fn, "subdivisions = " + std::to_string(subdivisions) + " must be in [0, 6]");
        SoftBodyDef d = make_icosphere(to_vec(center), Real(radius), subdivisions, Real(def->total_mass),
                                       link_material(*def), base_def(*def));
        return finish_create(fn, w, world, std::move(d), out);
    });
}

sinew_status sinew_soft_create_mesh(sinew_world_id world, const sinew_soft_def* def, const sinew_vec3* vertices,
                                    int vertex_count, const uint32_t* indices, int index_count, int link_distance,
                                    sinew_soft_body_id* out) {
    const char* fn = "sinew_soft_create_mesh";
    return guarded(fn, [&] {
        if (!vertices) return null_arg(fn, "vertices");
        if (!indices) return null_arg(fn, "indices");
        World* w = nullptr;
        if (sinew_status s = begin_create(fn, world, def, out, &w)) return s;
        if (vertex_count < 1) return invalid(fn, "vertex_count = " + std::to_string(vertex_count) + " must be > 0");
        if (index_count < 3 || index_count % 3 != 0)
            return invalid(fn, "index_count = " + std::to_string(index_count) + " must be a positive multiple of 3");
        if (link_distance < 1 || link_distance > 3)
            return invalid(fn, "link_distance = " + std::to_string(link_distance) + " must be in [1, 3]");
        std::vector<Vec3> v(static_cast<std::size_t>(vertex_count));
        for (int i = 0; i < vertex_count; ++i) {
            if (!finite(vertices[i]))
                return invalid(fn, "vertices[" + std::to_string(i) + "] = " + vec_text(vertices[i]) + " must be finite");
            v[static_cast<std::size_t>(i)] = to_vec(vertices[i]);
        }
        std::vector<std::uint32_t> idx(indices, indices + index_count);
        for (int k = 0; k < index_count; ++k)
            if (idx[static_cast<std::size_t>(k)] >= static_cast<std::uint32_t>(vertex_count))
                return invalid(fn, "indices[" + std::to_string(k) + "] = " + std::to_string(idx[static_cast<std::size_t>(k)]) +
                                       " is out of range (" + std::to_string(vertex_count) + " vertices)");
        // Degenerate triangles are the builder's to find (SoftError names the triangle).
        SoftBodyDef d = make_mesh_body(v, idx, link_distance, Real(def->total_mass), link_material(*def), base_def(*def));
        return finish_create(fn, w, world, std::move(d), out);
    });
}

sinew_status sinew_soft_destroy(sinew_soft_body_id body) {
    const char* fn = "sinew_soft_destroy";
    return guarded(fn, [&] {
        Target t = target(body, fn, true);
        if (t.status) return t.status;
        t.world->soft().destroy_body(t.body);
        t.world->coupling().refresh_embedding();  // its proxy and the proxy's joints go with it
        return SINEW_OK;
    });
}

sinew_status sinew_soft_particle_count(sinew_soft_body_id body, int* out) {
    const char* fn = "sinew_soft_particle_count";
    return guarded(fn, [&] {
        if (!out) return null_arg(fn, "out");
        Target t = target(body, fn, false);
        if (t.status) return t.status;
        *out = static_cast<int>(t.world->soft().body(t.body).p.size());
        return SINEW_OK;
    });
}

sinew_status sinew_soft_get_positions(sinew_soft_body_id body, sinew_vec3* positions, int capacity, int* count) {
    const char* fn = "sinew_soft_get_positions";
    return guarded(fn, [&] {
        if (!count) return null_arg(fn, "count");
        if (capacity < 0) return invalid(fn, "capacity = " + std::to_string(capacity) + " must be >= 0");
        if (!positions && capacity > 0) return null_arg(fn, "positions");
        Target t = target(body, fn, false);
        if (t.status) return t.status;
        const std::vector<Vec3>& x = t.world->soft().body(t.body).p.x;
        const std::size_t n = std::min(x.size(), static_cast<std::size_t>(capacity));
        for (std::size_t i = 0; i < n; ++i) positions[i] = to_c(x[i]);
        *count = static_cast<int>(n);
        return SINEW_OK;
    });
}

sinew_status sinew_soft_set_pinned(sinew_soft_body_id body, int particle, int pinned) {
    const char* fn = "sinew_soft_set_pinned";
    return guarded(fn, [&] {
        Target t = target(body, fn, true);
        if (t.status) return t.status;
        if (sinew_status s = check_particle(t, particle, fn)) return s;
        if (pinned != 0 && pinned != 1) return invalid(fn, "pinned = " + std::to_string(pinned) + " must be 0 or 1");
        const std::uint32_t i = static_cast<std::uint32_t>(particle);
        if (t.world->soft().attached(t.body, i))
            return invalid(fn, "particle = " + std::to_string(particle) + " is attached to a rigid body; detach it first");
        t.world->soft().set_pinned(t.body, i, pinned == 1);
        t.world->coupling().refresh_embedding();  // a first or last pin changes an embedded body's proxy
        return SINEW_OK;
    });
}

sinew_status sinew_soft_attach(sinew_soft_body_id body, int particle, sinew_body_id rigid_body, sinew_vec3 local_point) {
    const char* fn = "sinew_soft_attach";
    return guarded(fn, [&] {
        Target t = target(body, fn, true);
        if (t.status) return t.status;
        if (sinew_status s = check_particle(t, particle, fn)) return s;
        if (rigid_body.world != body.world)
            return fail(SINEW_ERROR_STALE_ID, std::string(fn) + ": rigid_body {index " + std::to_string(rigid_body.index) +
                                                  ", generation " + std::to_string(rigid_body.generation) +
                                                  "} belongs to world " + std::to_string(rigid_body.world) +
                                                  ", not to the soft body's world " + std::to_string(body.world));
        const BodyId rb{rigid_body.index, rigid_body.generation};
        if (!t.world->rigid().valid(rb))
            return fail(SINEW_ERROR_STALE_ID, std::string(fn) + ": rigid_body {index " + std::to_string(rigid_body.index) +
                                                  ", generation " + std::to_string(rigid_body.generation) +
                                                  "} is null or destroyed");
        if (!finite(local_point)) return invalid(fn, "local_point = " + vec_text(local_point) + " must be finite");
        t.world->soft().attach(t.body, static_cast<std::uint32_t>(particle), pack_body_id(rb), to_vec(local_point));
        t.world->coupling().refresh_embedding();
        return SINEW_OK;
    });
}

sinew_status sinew_soft_detach(sinew_soft_body_id body, int particle) {
    const char* fn = "sinew_soft_detach";
    return guarded(fn, [&] {
        Target t = target(body, fn, true);
        if (t.status) return t.status;
        if (sinew_status s = check_particle(t, particle, fn)) return s;
        const std::uint32_t i = static_cast<std::uint32_t>(particle);
        if (!t.world->soft().attached(t.body, i))
            return invalid(fn, "particle = " + std::to_string(particle) + " is not attached");
        t.world->soft().detach(t.body, i);
        t.world->coupling().refresh_embedding();
        return SINEW_OK;
    });
}

sinew_status sinew_soft_set_particle_position(sinew_soft_body_id body, int particle, sinew_vec3 position) {
    const char* fn = "sinew_soft_set_particle_position";
    return guarded(fn, [&] {
        Target t = target(body, fn, true);
        if (t.status) return t.status;
        if (sinew_status s = check_particle(t, particle, fn)) return s;
        if (!finite(position)) return invalid(fn, "position = " + vec_text(position) + " must be finite");
        t.world->soft().set_particle_position(t.body, static_cast<std::uint32_t>(particle), to_vec(position));
        return SINEW_OK;
    });
}

sinew_status sinew_soft_apply_particle_force(sinew_soft_body_id body, int particle, sinew_vec3 force) {
    const char* fn = "sinew_soft_apply_particle_force";
    return guarded(fn, [&] {
        Target t = target(body, fn, true);
        if (t.status) return t.status;
        if (sinew_status s = check_particle(t, particle, fn)) return s;
        if (!finite(force)) return invalid(fn, "force = " + vec_text(force) + " must be finite");
        t.world->soft().apply_particle_force(t.body, static_cast<std::uint32_t>(particle), to_vec(force));
        return SINEW_OK;
    });
}

sinew_status sinew_soft_set_filter(sinew_soft_body_id body, sinew_filter filter) {
    const char* fn = "sinew_soft_set_filter";
    return guarded(fn, [&] {
        Target t = target(body, fn, true);
        if (t.status) return t.status;
        t.world->soft().set_filter(t.body, to_filter(filter));
        return SINEW_OK;
    });
}

sinew_status sinew_soft_get_filter(sinew_soft_body_id body, sinew_filter* out) {
    const char* fn = "sinew_soft_get_filter";
    return guarded(fn, [&] {
        if (!out) return null_arg(fn, "out");
        Target t = target(body, fn, false);
        if (t.status) return t.status;
        *out = to_c(t.world->soft().body(t.body).def.filter);
        return SINEW_OK;
    });
}

sinew_status sinew_soft_user_data(sinew_soft_body_id body, uint64_t* out) {
    const char* fn = "sinew_soft_user_data";
    return guarded(fn, [&] {
        if (!out) return null_arg(fn, "out");
        Target t = target(body, fn, false);
        if (t.status) return t.status;
        *out = t.world->soft().body(t.body).def.user_data;
        return SINEW_OK;
    });
}

sinew_status sinew_world_soft_body_count(sinew_world_id world, int* out) {
    const char* fn = "sinew_world_soft_body_count";
    return guarded(fn, [&] {
        if (!out) return null_arg(fn, "out");
        World* w = find_world(world, fn);
        if (!w) return SINEW_ERROR_STALE_ID;
        // embed-fem's proxies of rigid bodies are the coupling layer's, not the host's soft bodies.
        *out = static_cast<int>(w->soft().body_count() - w->coupling().fem_embedding().count());
        return SINEW_OK;
    });
}

sinew_status sinew_world_get_soft_bodies(sinew_world_id world, sinew_soft_body_id* ids, int capacity, int* count) {
    const char* fn = "sinew_world_get_soft_bodies";
    return guarded(fn, [&] {
        if (!count) return null_arg(fn, "count");
        if (capacity < 0) return invalid(fn, "capacity = " + std::to_string(capacity) + " must be >= 0");
        if (!ids && capacity > 0) return null_arg(fn, "ids");
        World* w = find_world(world, fn);
        if (!w) return SINEW_ERROR_STALE_ID;
        const SoftSystem& s = w->soft();
        int n = 0;
        for (std::uint32_t slot = 0; slot < s.slot_count() && n < capacity; ++slot) {
            if (!s.slot_alive(slot)) continue;
            const SoftBodyId id = s.id_of_slot(slot);
            if (w->coupling().fem_embedding().is_proxy(id)) continue;  // the coupling layer's (embed-fem)
            ids[n++] = {pack_world(world), id.index, id.generation};
        }
        *count = n;
        return SINEW_OK;
    });
}

sinew_fem_material sinew_fem_material_default(void) {
    const FemMaterial f;
    sinew_fem_material m;
    m.young = float(f.young);
    m.poisson = float(f.poisson);
    m.density = float(f.density);
    m.mass_damping = float(f.mass_damping);
    m.stiffness_damping = float(f.stiffness_damping);
    m.yield = float(f.yield);
    m.creep = float(f.creep);
    m.max_plastic = float(f.max_plastic);
    m.rotation = SINEW_FEM_POLAR;
    return m;
}

sinew_status sinew_soft_create_tet_box(sinew_world_id world, const sinew_soft_def* def, const sinew_fem_material* material,
                                       sinew_vec3 min_corner, sinew_vec3 size, int nx, int ny, int nz, int split,
                                       sinew_soft_body_id* out) {
    const char* fn = "sinew_soft_create_tet_box";
    return guarded(fn, [&] {
        World* w = nullptr;
        if (sinew_status s = begin_create(fn, world, def, out, &w)) return s;
        if (sinew_status s = check_fem_create(fn, *def, material)) return s;
        if (!finite(min_corner)) return invalid(fn, "min_corner = " + vec_text(min_corner) + " must be finite");
        if (!(finite(size) && size.x > 0 && size.y > 0 && size.z > 0))
            return invalid(fn, "size = " + vec_text(size) + " must be finite and > 0 along every axis (m)");
        const int cells[3] = {nx, ny, nz};
        const char* names[3] = {"nx", "ny", "nz"};
        for (int k = 0; k < 3; ++k)
            if (cells[k] < 1 || cells[k] > 1000) return invalid(fn, std::string(names[k]) + " = " + std::to_string(cells[k]) + " must be in [1, 1000]");
        if (split != 5 && split != 6) return invalid(fn, "split = " + std::to_string(split) + " must be 5 or 6 (tets per cell)");
        SoftBodyDef base = base_def(*def);
        base.fem = fem_material(*material);
        // make_tet_box checks the total cell count (SoftError names it).
        TetMesh mesh = make_tet_box(to_vec(min_corner), to_vec(size), nx, ny, nz, split == 5 ? HexSplit::Five : HexSplit::Six);
        SoftBodyDef d = make_tet_body(def->tet_order == 2 ? make_quadratic(mesh) : mesh, std::move(base));
        return finish_create(fn, w, world, std::move(d), out);
    });
}

sinew_status sinew_soft_create_tet_mesh(sinew_world_id world, const sinew_soft_def* def, const sinew_fem_material* material,
                                        const sinew_vec3* nodes, int node_count, const uint32_t* tets, int tet_count,
                                        sinew_soft_body_id* out) {
    const char* fn = "sinew_soft_create_tet_mesh";
    return guarded(fn, [&] {
        if (!nodes) return null_arg(fn, "nodes");
        if (!tets) return null_arg(fn, "tets");
        World* w = nullptr;
        if (sinew_status s = begin_create(fn, world, def, out, &w)) return s;
        if (sinew_status s = check_fem_create(fn, *def, material)) return s;
        if (node_count < 4) return invalid(fn, "node_count = " + std::to_string(node_count) + " must be >= 4");
        if (tet_count < 1 || tet_count > 50000000) return invalid(fn, "tet_count = " + std::to_string(tet_count) + " must be in [1, 5e7]");
        TetMesh mesh;
        mesh.nodes.resize(static_cast<std::size_t>(node_count));
        for (int i = 0; i < node_count; ++i) {
            if (!finite(nodes[i])) return invalid(fn, "nodes[" + std::to_string(i) + "] = " + vec_text(nodes[i]) + " must be finite");
            mesh.nodes[static_cast<std::size_t>(i)] = to_vec(nodes[i]);
        }
        mesh.order = def->tet_order;  // begin_create checked it: 1 or 2
        mesh.tets.assign(tets, tets + static_cast<std::size_t>(tet_nodes(mesh.order)) * static_cast<std::size_t>(tet_count));
        SoftBodyDef base = base_def(*def);
        base.fem = fem_material(*material);
        // make_tet_body checks the mesh first (SoftError names the tet, its nodes and its volume).
        SoftBodyDef d = make_tet_body(mesh, std::move(base));
        return finish_create(fn, w, world, std::move(d), out);
    });
}

sinew_status sinew_soft_set_fem_material(sinew_soft_body_id body, const sinew_fem_material* material) {
    const char* fn = "sinew_soft_set_fem_material";
    return guarded(fn, [&] {
        if (!material) return null_arg(fn, "material");
        Target t = target(body, fn, true);
        if (t.status) return t.status;
        const std::string bad = check_fem_material(*material);
        if (!bad.empty()) return invalid(fn, bad);
        SoftBody& b = t.world->soft().body(t.body);
        if (!b.fem) return invalid(fn, "the soft body has no tets (it is not an FEM solid)");
        const FemMaterial m = fem_material(*material);
        const std::string unfit = fem_method_problem(m, b.def.method, b.fem->order);
        if (!unfit.empty()) return invalid(fn, unfit);
        set_fem_material(b, m);  // checked above: does not throw
        t.world->soft().wake(t.body);
        return SINEW_OK;
    });
}

sinew_status sinew_soft_tet_count(sinew_soft_body_id body, int* out) {
    const char* fn = "sinew_soft_tet_count";
    return guarded(fn, [&] {
        if (!out) return null_arg(fn, "out");
        Target t = target(body, fn, false);
        if (t.status) return t.status;
        const SoftBody& b = t.world->soft().body(t.body);
        *out = b.fem ? static_cast<int>(b.fem->size()) : 0;
        return SINEW_OK;
    });
}

}  // extern "C"
