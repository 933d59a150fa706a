// SoftBody's own bookkeeping: moves (its caches are incomplete types elsewhere), measures and names.
#include "soft/soft_body.hpp"

#include <algorithm>
#include <cstring>

#include "soft/fem_elements.hpp"
#include "soft/soft_integrators.hpp"
#include "soft/solver_caches.hpp"

namespace sinew {

SoftBody::SoftBody() = default;
SoftBody::~SoftBody() = default;
SoftBody::SoftBody(SoftBody&&) noexcept = default;
SoftBody& SoftBody::operator=(SoftBody&&) noexcept = default;

Real SoftBody::volume() const { return triangles.empty() ? Real(0) : enclosed_volume(triangles, p.x); }

Real SoftBody::max_stretch() const {
    Real worst = 1;
    for (const Link& l : links) {
        if (l.kind != LinkKind::Structural && l.kind != LinkKind::Shear) continue;
        worst = std::max(worst, (p.x[l.a] - p.x[l.b]).norm() / l.rest);
    }
    return worst;
}

Real SoftBody::kinetic_energy() const {
    double e = 0;
    for (std::size_t i = 0; i < p.size(); ++i) e += 0.5 * double(p.mass[i]) * double(p.v[i].squaredNorm());
    return Real(e);
}

namespace {
constexpr const char* kMethodNames[] = {"verlet", "explicit", "semi-implicit", "implicit", "fast-ms"};
static_assert(sizeof(kMethodNames) / sizeof(kMethodNames[0]) == static_cast<int>(SoftMethod::Count), "");
}  // namespace

const char* soft_method_name(SoftMethod m) {
    const int i = static_cast<int>(m);
    return i >= 0 && i < static_cast<int>(SoftMethod::Count) ? kMethodNames[i] : "unknown";
}

namespace {
constexpr const char* kPreconditionerNames[] = {"block-jacobi", "rest-factor"};
static_assert(sizeof(kPreconditionerNames) / sizeof(kPreconditionerNames[0]) == static_cast<int>(SoftPreconditioner::Count), "");
}  // namespace

const char* soft_preconditioner_name(SoftPreconditioner p) {
    const int i = static_cast<int>(p);
    return i >= 0 && i < static_cast<int>(SoftPreconditioner::Count) ? kPreconditionerNames[i] : "unknown";
}

bool parse_soft_preconditioner(const std::string& text, SoftPreconditioner& out) {
    for (int i = 0; i < static_cast<int>(SoftPreconditioner::Count); ++i)
        if (text == kPreconditionerNames[i]) {
            out = static_cast<SoftPreconditioner>(i);
            return true;
        }
    return false;
}

namespace {
constexpr const char* kRelaxationNames[] = {"in-order", "by-colour"};
static_assert(sizeof(kRelaxationNames) / sizeof(kRelaxationNames[0]) == static_cast<int>(SoftRelaxation::Count), "");
}  // namespace

const char* soft_relaxation_name(SoftRelaxation r) {
    const int i = static_cast<int>(r);
    return i >= 0 && i < static_cast<int>(SoftRelaxation::Count) ? kRelaxationNames[i] : "unknown";
}

bool parse_soft_relaxation(const std::string& text, SoftRelaxation& out) {
    for (int i = 0; i < static_cast<int>(SoftRelaxation::Count); ++i)
        if (text == kRelaxationNames[i]) {
            out = static_cast<SoftRelaxation>(i);
            return true;
        }
    return false;
}

bool parse_soft_method(const char* text, SoftMethod& out) {
    for (int i = 0; i < static_cast<int>(SoftMethod::Count); ++i)
        if (std::strcmp(text, kMethodNames[i]) == 0) {
            out = static_cast<SoftMethod>(i);
            return true;
        }
    return false;
}

}  // namespace sinew
