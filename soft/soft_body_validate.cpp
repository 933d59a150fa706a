#include "soft/soft_body_validate.hpp"

#include <cmath>
#include <string>

#include "engine/core/format.hpp"
#include "soft/fem_elements.hpp"
#include "soft/soft_integrators.hpp"
#include "soft/tet_mesh.hpp"

namespace sinew {
namespace {

[[noreturn]] void fail(const std::string& what) { throw SoftError("soft body: " + what); }

std::string at(const char* field, std::size_t i) { return std::string(field) + "[" + std::to_string(i) + "]"; }

void require_finite(Real x, const std::string& name) {
    if (!std::isfinite(x)) fail(name + " must be finite, got " + to_text(x));
}
void require_range(Real x, Real lo, Real hi, const std::string& name) {
    if (!(x >= lo && x <= hi)) fail(name + " must be in [" + to_text(lo) + ", " + to_text(hi) + "], got " + to_text(x));
}
void require_index(std::uint32_t i, std::size_t n, const std::string& name) {
    if (i >= n) fail(name + " = " + std::to_string(i) + " is out of range (" + std::to_string(n) + " particles)");
}

}  // namespace

void validate_soft_body_def(const SoftBodyDef& d) {
    const int method = static_cast<int>(d.method);
    if (method < 0 || method >= static_cast<int>(SoftMethod::Count))
        fail("method = " + std::to_string(method) + " is not a soft method");
    const std::size_t n = d.positions.size();
    if (n == 0) fail("positions is empty (a soft body needs at least one particle)");
    if (d.masses.size() != n)
        fail("masses has " + std::to_string(d.masses.size()) + " entries for " + std::to_string(n) + " positions");
    for (std::size_t i = 0; i < n; ++i) {
        if (!is_finite(d.positions[i])) fail(at("positions", i) + " must be finite, got " + to_text(d.positions[i]));
        if (!(d.masses[i] > 0 && std::isfinite(d.masses[i])))
            fail(at("masses", i) + " must be > 0 and finite, got " + to_text(d.masses[i]));
    }
    for (std::size_t k = 0; k < d.links.size(); ++k) {
        const Link& l = d.links[k];
        const std::string name = at("links", k);
        require_index(l.a, n, name + ".a");
        require_index(l.b, n, name + ".b");
        if (l.a == l.b) fail(name + " joins particle " + std::to_string(l.a) + " to itself");
        if (!(l.rest > 0 && std::isfinite(l.rest))) fail(name + ".rest must be > 0 and finite, got " + to_text(l.rest));
        require_range(l.stiffness, 0, kRealMax, name + ".stiffness");
        require_range(l.damping, 0, kRealMax, name + ".damping");
        if (!(l.fraction > 0 && l.fraction <= 1)) fail(name + ".fraction must be in (0, 1], got " + to_text(l.fraction));
        require_range(l.min_length, 0, kRealMax, name + ".min_length");
        if (!(l.max_length >= l.min_length) || !std::isfinite(l.max_length))
            fail(name + ".max_length must be finite and >= min_length (" + to_text(l.min_length) + "), got " +
                 to_text(l.max_length));
    }
    if (d.triangles.size() % 3 != 0)
        fail("triangles has " + std::to_string(d.triangles.size()) + " indices, not a multiple of 3");
    for (std::size_t k = 0; k < d.triangles.size(); ++k) require_index(d.triangles[k], n, at("triangles", k));
    for (std::size_t k = 0; k < d.pinned.size(); ++k) require_index(d.pinned[k], n, at("pinned", k));
    for (std::size_t k = 0; k < d.attachments.size(); ++k) {
        require_index(d.attachments[k].particle, n, at("attachments", k) + ".particle");
        if (!is_finite(d.attachments[k].local_point))
            fail(at("attachments", k) + ".local_point must be finite, got " + to_text(d.attachments[k].local_point));
    }
    if (!is_finite(d.initial_velocity)) fail("initial_velocity must be finite, got " + to_text(d.initial_velocity));
    if (d.iterations < 1 || d.iterations > 10000)
        fail("iterations must be in [1, 10000], got " + std::to_string(d.iterations));
    if (!(d.cg_tolerance > 0 && d.cg_tolerance < 1)) fail("cg_tolerance must be in (0, 1), got " + to_text(d.cg_tolerance));
    const int relaxation = static_cast<int>(d.relaxation);
    if (relaxation < 0 || relaxation >= static_cast<int>(SoftRelaxation::Count))
        fail("relaxation = " + std::to_string(relaxation) + " is not a relaxation order");
    if (d.relaxation == SoftRelaxation::ByColour && d.method != SoftMethod::Verlet)
        fail("relaxation by-colour is for Verlet bodies (method " + std::string(soft_method_name(d.method)) + ")");
    const int preconditioner = static_cast<int>(d.preconditioner);
    if (preconditioner < 0 || preconditioner >= static_cast<int>(SoftPreconditioner::Count))
        fail("preconditioner = " + std::to_string(preconditioner) + " is not a preconditioner");
    if (d.preconditioner == SoftPreconditioner::RestFactor && (d.tets.empty() || d.method != SoftMethod::ImplicitEuler))
        fail("preconditioner rest-factor is for FEM bodies (tets) under the implicit method");
    require_range(d.isotropic_blend, 0, 1, "isotropic_blend");
    require_range(d.implicit_lambda, Real(0.5), 1, "implicit_lambda");
    require_range(d.drag, 0, kRealMax, "drag");
    require_range(d.pressure, 0, kRealMax, "pressure");
    require_range(d.friction, 0, kRealMax, "friction");
    require_range(d.restitution, 0, 1, "restitution");
    if (!(d.thickness > 0 && std::isfinite(d.thickness))) fail("thickness must be > 0 and finite, got " + to_text(d.thickness));
    require_finite(d.gravity_scale, "gravity_scale");
    if (d.tets.empty() && (!d.rest_positions.empty() || !d.plastic_strain.empty()))
        fail("rest_positions and plastic_strain belong to FEM bodies, and this one has no tets");
    if (!d.tets.empty()) {
        const std::string bad = fem_material_problem(d.fem, "fem.");
        if (!bad.empty()) fail(bad);
        const std::string unfit = fem_method_problem(d.fem, d.method, d.tet_order);
        if (!unfit.empty()) fail(unfit);
        if (!d.rest_positions.empty() && d.rest_positions.size() != n)
            fail("rest_positions has " + std::to_string(d.rest_positions.size()) + " entries for " + std::to_string(n) + " positions");
        check_tet_mesh(d.rest_positions.empty() ? d.positions : d.rest_positions, d.tets, "soft body: tets", d.tet_order);
        const std::size_t count = d.tets.size() / std::size_t(tet_nodes(d.tet_order));
        if (!d.plastic_strain.empty() && d.plastic_strain.size() != count)
            fail("plastic_strain has " + std::to_string(d.plastic_strain.size()) + " entries for " + std::to_string(count) + " tets");
        for (std::size_t e = 0; e < d.plastic_strain.size(); ++e)
            for (const Real x : d.plastic_strain[e])
                if (!std::isfinite(x)) fail(at("plastic_strain", e) + " must be finite");
    }
    if (d.pressure > 0) {
        if (d.triangles.empty()) fail("pressure = " + to_text(d.pressure) + " needs a closed triangle surface, got none");
        const Real v = enclosed_volume(d.triangles, d.positions);
        if (!(v > 0))
            fail("pressure = " + to_text(d.pressure) + " needs a closed outward surface; its enclosed volume is " +
                 to_text(v) + " m^3");
    }
}

}  // namespace sinew
