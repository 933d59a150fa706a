// Internal to the builders (soft/build_*.cpp): argument checks that name the builder and the argument,
// and the one way a link is made from built positions.
#pragma once

#include <string>
#include <vector>

#include "engine/core/format.hpp"
#include "soft/soft_builders.hpp"

namespace sinew::builder {

[[noreturn]] inline void fail(const char* where, const std::string& what) {
    throw SoftError(std::string(where) + ": " + what);
}

inline void check_point(const char* where, const char* name, const Vec3& v) {
    if (!is_finite(v)) fail(where, std::string(name) + " must be finite, got " + to_text(v));
}

inline void check_positive(const char* where, const char* name, Real x) {
    if (!(is_finite(x) && x > 0)) fail(where, std::string(name) + " must be finite and > 0, got " + to_text(x));
}

inline void check_material(const char* where, const LinkMaterial& m) {
    const struct {
        const char* name;
        Real value;
    } nonneg[] = {{"material.stretch", m.stretch}, {"material.shear", m.shear}, {"material.bend", m.bend},
                  {"material.damping", m.damping}};
    for (const auto& f : nonneg)
        if (!(is_finite(f.value) && f.value >= 0))
            fail(where, std::string(f.name) + " must be finite and >= 0, got " + to_text(f.value));
    if (!(is_finite(m.fraction) && m.fraction > 0 && m.fraction <= 1))
        fail(where, "material.fraction must be in (0, 1], got " + to_text(m.fraction));
}

/// A link at the current distance of a and b (the body starts unstressed): k_s from the material by kind,
/// k_d and the Verlet fraction from the material, an equality constraint under Verlet (Jakobsen 2003).
inline Link make_link(const std::vector<Vec3>& x, std::uint32_t a, std::uint32_t b, LinkKind kind,
                      const LinkMaterial& m) {
    Link l;
    l.a = a;
    l.b = b;
    l.rest = (x[a] - x[b]).norm();
    l.stiffness = kind == LinkKind::Shear ? m.shear : kind == LinkKind::Bend ? m.bend : m.stretch;
    l.damping = m.damping;
    l.fraction = m.fraction;
    l.min_length = l.rest;
    l.max_length = l.rest;
    l.kind = kind;
    return l;
}

/// The builder's geometry replaces whatever geometry `base` held; its settings, pins and attachments stay.
inline void reset_geometry(SoftBodyDef& d) {
    d.positions.clear();
    d.masses.clear();
    d.links.clear();
    d.triangles.clear();
    d.tets.clear();
    d.tet_order = 1;
    d.rest_positions.clear();
    d.plastic_strain.clear();
}

}  // namespace sinew::builder
