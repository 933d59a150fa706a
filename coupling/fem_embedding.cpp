// Rigid bodies as stiff FEM proxies in the soft system (strategy embed-fem; coupling/fem_embedding.hpp).
#include "coupling/fem_embedding.hpp"

#include <algorithm>
#include <string>

#include "coupling/coupling_layer.hpp"
#include "soft/soft_builders.hpp"
#include "soft/tet_mesh.hpp"

namespace sinew {
namespace {

// The proxy's material: stiff enough that its elements keep the shape within a step (it is reset each
// step, so only the step's own deformation matters), damped so that nothing rings.
constexpr Real kProxyYoung = Real(1e8);
constexpr Real kProxyPoisson = Real(0.3);
// Collision thickness of the proxy's nodes (m): the rigid body has none; the soft body's own keeps the gap.
constexpr Real kProxyThickness = Real(1e-4);

// A box's surface: each face a 2 x 2 grid of quads, counter-clockwise from outside, vertices shared.
void box_surface(const Vec3& he, std::vector<Vec3>& v, std::vector<std::uint32_t>& t) {
    const auto index = [&](const Vec3& x) {
        for (std::size_t k = 0; k < v.size(); ++k)
            if (v[k] == x) return std::uint32_t(k);
        v.push_back(x);
        return std::uint32_t(v.size() - 1);
    };
    for (int a = 0; a < 3; ++a)
        for (int s = -1; s <= 1; s += 2) {
            const int u = (a + 1) % 3, w = (a + 2) % 3;  // e_u x e_w = e_a
            const auto point = [&](int i, int j) {
                Vec3 x = Vec3::Zero();
                x[a] = Real(s) * he[a];
                x[u] = Real(i) * he[u];
                x[w] = Real(j) * he[w];
                return index(x);
            };
            for (int i = -1; i < 1; ++i)
                for (int j = -1; j < 1; ++j) {
                    const std::uint32_t q[4] = {point(i, j), point(i + 1, j), point(i + 1, j + 1), point(i, j + 1)};
                    if (s > 0) t.insert(t.end(), {q[0], q[1], q[2], q[0], q[2], q[3]});
                    else t.insert(t.end(), {q[0], q[2], q[1], q[0], q[3], q[2]});
                }
        }
}

}  // namespace

bool FemEmbedding::proxy_mesh(const Shape& shape, std::vector<Vec3>& nodes, std::vector<std::uint32_t>& tets) {
    nodes.clear();
    tets.clear();
    std::vector<std::uint32_t> surface;
    switch (shape.type) {
        case ShapeType::Box: box_surface(shape.half_extents, nodes, surface); break;
        case ShapeType::Sphere:
        case ShapeType::Capsule: {
            // A geodesic sphere (320 triangles); a capsule's halves moved apart along its axis (local y).
            const SoftBodyDef d = make_icosphere(Vec3::Zero(), shape.radius, 2, 1, LinkMaterial{});
            nodes = d.positions;
            surface = d.triangles;
            if (shape.type == ShapeType::Capsule)
                for (Vec3& x : nodes) x.y() += x.y() > 0 ? shape.half_height : x.y() < 0 ? -shape.half_height : Real(0);
            break;
        }
        case ShapeType::ConvexHull: {
            nodes = shape.hull->vertices;
            for (const ConvexHullData::Face& f : shape.hull->faces)
                for (std::size_t k = 1; k + 1 < f.verts.size(); ++k)
                    surface.insert(surface.end(), {f.verts[0], f.verts[k], f.verts[k + 1]});
            break;
        }
        default: return false;
    }
    // A fan of tets from the centre (inside a convex shape) to every surface triangle.
    Vec3 centre = Vec3::Zero();
    for (const Vec3& x : nodes) centre += x;
    centre /= Real(nodes.size());
    const std::uint32_t c = std::uint32_t(nodes.size());
    nodes.push_back(centre);
    for (std::size_t k = 0; k + 2 < surface.size(); k += 3) {
        const std::uint32_t a = surface[k], b = surface[k + 1], d = surface[k + 2];
        // Outward triangles (a b d) with the centre behind them: (a d b c) is positively oriented.
        if (tet_volume(nodes[a], nodes[d], nodes[b], nodes[c]) > 0) tets.insert(tets.end(), {a, d, b, c});
        else if (tet_volume(nodes[a], nodes[b], nodes[d], nodes[c]) > 0) tets.insert(tets.end(), {a, b, d, c});
    }
    return !tets.empty();
}

namespace {

bool has_proxy_shape(const Shape& s) {
    return s.type == ShapeType::Box || s.type == ShapeType::Sphere || s.type == ShapeType::Capsule ||
           s.type == ShapeType::ConvexHull;
}

}  // namespace

void FemEmbedding::check(const CouplingSettings& settings) const {
    for (std::size_t k = 0; k < settings.pairs.size(); ++k) {
        const CouplingPair& p = settings.pairs[k];
        if (p.strategy != CouplingStrategy::EmbedFem || p.rigid.is_null() || !rigid_.valid(p.rigid)) continue;
        if (rigid_.type(p.rigid) != BodyType::Dynamic)
            throw CouplingError("coupling pair " + std::to_string(k) + ": embed-fem embeds a dynamic rigid body, and rigid body " +
                                std::to_string(p.rigid.index) + " is not dynamic");
        if (!has_proxy_shape(rigid_.shape(p.rigid)))
            throw CouplingError("coupling pair " + std::to_string(k) + ": embed-fem has no FEM proxy for rigid body " +
                                std::to_string(p.rigid.index) + "'s shape (" + shape_type_name(rigid_.shape(p.rigid).type) +
                                "): boxes, spheres, capsules and convex hulls have one");
    }
}

bool FemEmbedding::is_proxy(SoftBodyId soft) const {
    for (const Proxy& px : proxies_)
        if (px.soft == soft) return true;
    return false;
}

std::size_t FemEmbedding::count() const {
    std::size_t n = 0;
    for (const Proxy& px : proxies_) n += soft_.valid(px.soft) ? 1 : 0;
    return n;
}

SoftBodyId FemEmbedding::proxy(BodyId rigid) const {
    for (const Proxy& px : proxies_)
        if (px.rigid == rigid) return px.soft;
    return {};
}

bool FemEmbedding::wanted(const CouplingSettings& settings, std::uint32_t o) const {
    // Enabled, solid (a sensor pushes nothing), dynamic bodies of a shape with a proxy, not themselves the
    // rigid proxy of an embedded soft body (reshaped each step).
    if (!rigid_.slot_alive(o) || rigid_.slot_type(o) != BodyType::Dynamic || !rigid_.slot_enabled(o) ||
        rigid_.slot_sensor(o) || !has_proxy_shape(rigid_.slot_shape(o)))
        return false;
    const BodyId id = rigid_.id_of_slot(o);
    if (rigid_proxies_.is_proxy(id)) return false;
    partners(settings, id, partner_scratch_);
    return !partner_scratch_.empty();
}

void FemEmbedding::partners(const CouplingSettings& settings, BodyId rigid, std::vector<std::uint32_t>& out) const {
    out.clear();
    for (std::uint32_t s = 0; s < soft_.slot_count(); ++s)
        if (soft_.slot_alive(s) && !soft_.slot_body(s).meets_soft_bodies_only &&
            coupling_strategy_of(settings, soft_.id_of_slot(s), rigid) == CouplingStrategy::EmbedFem)
            out.push_back(s);
}

void FemEmbedding::drop(Proxy& px) {
    if (soft_.valid(px.soft)) soft_.destroy_body(px.soft);
    px.soft = {};
}

void FemEmbedding::place(const CouplingSettings& settings, bool any, Real h) {
    // Proxies of bodies gone or no longer embedded go.
    for (Proxy& px : proxies_)
        if (!any || !rigid_.valid(px.rigid) || !soft_.valid(px.soft) || !wanted(settings, px.rigid.index)) drop(px);
    proxies_.erase(std::remove_if(proxies_.begin(), proxies_.end(), [](const Proxy& px) { return px.soft.is_null(); }),
                   proxies_.end());
    for (std::uint32_t s = 0; s < soft_.slot_count(); ++s)
        if (soft_.slot_alive(s)) soft_.slot_body(s).ignored_owners.clear();
    if (!any) return;

    // New ones, in rigid slot order (deterministic).
    std::vector<Vec3> nodes;
    std::vector<std::uint32_t> tets;
    for (std::uint32_t o = 0; o < rigid_.slot_count(); ++o) {
        if (!wanted(settings, o) || !proxy(rigid_.id_of_slot(o)).is_null()) continue;
        if (!proxy_mesh(rigid_.slot_shape(o), nodes, tets)) continue;
        const BodyId id = rigid_.id_of_slot(o);
        Real volume = 0;
        for (std::size_t k = 0; k + 3 < tets.size(); k += 4)
            volume += tet_volume(nodes[tets[k]], nodes[tets[k + 1]], nodes[tets[k + 2]], nodes[tets[k + 3]]);
        SoftBodyDef d;
        d.method = SoftMethod::ImplicitEuler;
        d.iterations = 50;
        d.preconditioner = SoftPreconditioner::RestFactor;  // stiff: block Jacobi ran to its cap
        d.fem.young = kProxyYoung;
        d.fem.poisson = kProxyPoisson;
        d.fem.density = rigid_.mass(id) / volume;  // the body's mass, spread uniformly
        d.thickness = kProxyThickness;
        d.friction = rigid_.slot_material(o).friction;
        d.restitution = rigid_.slot_material(o).restitution;
        d.gravity_scale = 0;  // the rigid body's velocity carries gravity (place)
        d.allow_sleep = false;  // it sleeps with its rigid body
        d.filter = rigid_.slot_filter(o);  // it meets the soft bodies its rigid body would
        Proxy px;
        px.rigid = id;
        px.local = nodes;  // body frame
        const Transform xf = rigid_.slot_transform(o);
        TetMesh mesh;
        mesh.nodes.reserve(nodes.size());
        for (const Vec3& x : nodes) mesh.nodes.push_back(xf.apply(x));
        mesh.tets = tets;
        try {
            px.soft = soft_.create_body(make_tet_body(mesh, d));
        } catch (const SoftError&) {
            continue;  // a mesh the checks refuse (a capsule over 100 radii long): the body stays a collider
        }
        soft_.slot_body(px.soft.index).meets_soft_bodies_only = true;
        proxies_.push_back(std::move(px));
    }

    // Who meets whom: a proxy meets the soft bodies embed-fem with its rigid body, which ignore its collider.
    const RigidSystem::State& st = rigid_.state();
    const bool gravity_pending = rigid_.gravity_in_solve();
    for (Proxy& px : proxies_) {
        SoftBody& b = soft_.body(px.soft);
        partners(settings, px.rigid, b.soft_partners);
        for (std::uint32_t s : b.soft_partners) soft_.slot_body(s).ignored_owners.push_back(px.rigid.index);
        // Reset to the body's pose and velocity field (with the gravity the solver adds over the step).
        const std::uint32_t o = px.rigid.index;
        const Transform xf = rigid_.slot_transform(o);
        const bool asleep = !rigid_.awake(px.rigid);
        Vec3 v = st.v[o];
        if (gravity_pending) v += h * rigid_.gravity_scale(px.rigid) * rigid_.settings().gravity;
        for (std::size_t i = 0; i < px.local.size(); ++i) {
            const Vec3 x = xf.apply(px.local[i]);
            b.p.x[i] = x;
            b.p.x_prev[i] = x;
            b.p.v[i] = asleep ? Vec3::Zero() : Vec3(v + st.w[o].cross(x - st.x[o]));
        }
        SoftBody::RigidMotion& m = b.as_rigid;
        m.active = true;
        m.inv_mass = st.inv_mass[o];
        m.inv_inertia = st.inv_inertia_world[o];
        m.com = st.x[o];
        m.v = v;
        m.w = st.w[o];
        m.impulse.setZero();
        m.angular_impulse.setZero();
        if (asleep && soft_.awake(px.soft)) soft_.put_to_sleep(px.soft);
        if (!asleep && !soft_.awake(px.soft)) soft_.wake(px.soft);
    }
}

void FemEmbedding::wake_touched() {
    const RigidSystem::State& st = rigid_.state();
    for (const Proxy& px : proxies_) {
        SoftBody& b = soft_.body(px.soft);
        if (!b.stepping || rigid_.awake(px.rigid)) continue;
        rigid_.wake(px.rigid);
        // Placed asleep, the proxy took the body's zero inverse mass: the pass would have held it immovable
        // and sent the whole stopping impulse to the body now awake.
        const std::uint32_t o = px.rigid.index;
        b.as_rigid.inv_mass = st.inv_mass[o];
        b.as_rigid.inv_inertia = st.inv_inertia_world[o];
    }
}

void FemEmbedding::send_back(std::vector<CouplingImpulse>& sent) {
    if (proxies_.empty()) return;
    RigidSystem::State& st = rigid_.state();
    for (Proxy& px : proxies_) {
        const SoftBody& b = soft_.body(px.soft);
        if (!b.stepping) continue;
        const std::uint32_t o = px.rigid.index;
        // Parker & O'Brien sum the proxy's nodal forces to a force and a torque about the centre of mass:
        // here the impulses the soft-soft contacts gave its nodes, summed by the pass, which moved the proxy
        // as one rigid body (SoftBody::as_rigid).
        const Vec3 j = b.as_rigid.impulse, l = b.as_rigid.angular_impulse;
        if (j.isZero() && l.isZero()) continue;
        if (st.inv_mass[o] == 0) {
            if (j.norm() > rigid_.mass(px.rigid) * rigid_.settings().sleep_linear_velocity) rigid_.wake(px.rigid);
        } else {
            st.v[o] += st.inv_mass[o] * j;
            st.w[o] += st.inv_inertia_world[o] * l;
        }
        // One record per contact, as the rigid body received it. A body touching an awake soft body stays
        // awake (its sleep timer restarts): it sleeps after the soft bodies under it do, which then hold
        // still under it.
        bool touches_awake = false;
        for (const SoftSoftContact& c : soft_.soft_contacts()) {
            const Vec3 on_particle = c.impulse * c.normal + c.friction;
            const std::uint32_t other = c.body == px.soft.index ? c.other : c.body;
            if ((c.body == px.soft.index || c.other == px.soft.index) && soft_.slot_body(other).stepping) touches_awake = true;
            if (c.body == px.soft.index) {
                sent.push_back({o, c.other, soft_.slot_body(c.other).triangles[3 * std::size_t(c.triangle)],
                                b.p.x[c.particle], -c.normal, on_particle});
            } else if (c.other == px.soft.index) {
                const SoftBody& other = soft_.slot_body(c.body);
                sent.push_back({o, c.body, c.particle, Vec3(other.p.x[c.particle] - other.def.thickness * c.normal),
                                c.normal, -on_particle});
            }
        }
        // Edge on edge: reported at the proxy's edge point, against the other body's nearer particle.
        for (const SoftEdgeContact& c : soft_.soft_edge_contacts()) {
            const Vec3 on_a = c.impulse * c.normal + c.friction;  // what edge a's point received
            const bool mine_a = c.body == px.soft.index, mine_b = c.other == px.soft.index;
            if (!mine_a && !mine_b) continue;
            const std::uint32_t other = mine_a ? c.other : c.body;
            if (soft_.slot_body(other).stepping) touches_awake = true;
            if (mine_a) {
                const Vec3 at = (1 - c.s) * b.p.x[c.a[0]] + c.s * b.p.x[c.a[1]];
                sent.push_back({o, c.other, c.t < Real(0.5) ? c.b[0] : c.b[1], at, -c.normal, on_a});
            } else {
                const Vec3 at = (1 - c.t) * b.p.x[c.b[0]] + c.t * b.p.x[c.b[1]];
                sent.push_back({o, c.body, c.s < Real(0.5) ? c.a[0] : c.a[1], at, c.normal, -on_a});
            }
        }
        if (touches_awake) rigid_.wake(px.rigid);
    }
}

}  // namespace sinew
