// The particle core shared by every soft model (Verlet bodies, mass-spring cloth, pressure bodies and,
// later, the nodes of FEM bodies): flat arrays indexed by particle, one set per soft body.
#pragma once

#include <cstdint>
#include <vector>

#include "engine/core/math.hpp"

namespace sinew {

struct Particles {
    std::vector<Vec3> x;         ///< position (m)
    std::vector<Vec3> v;         ///< velocity (m/s)
    std::vector<Vec3> x_prev;    ///< position at the start of the current step (Verlet's x_{n-1} after the step)
    std::vector<Vec3> f;         ///< external force accumulator (N), cleared after each step
    std::vector<Real> mass;      ///< kg, the particle's own mass (kept when it is pinned)
    std::vector<Real> inv_mass;  ///< 1/kg; 0 = pinned or attached (moved only by its target)
    // Step scratch of the soft system's stages (soft/soft_system.cpp), meaningless between steps:
    std::vector<Vec3> x_next;    ///< end-of-step positions, from IntegrateVelocities to IntegratePositions
    std::vector<Vec3> v_solved;  ///< velocities as SolveVelocities left them (a coupling change since moves x)

    std::size_t size() const { return x.size(); }
    std::uint32_t add(const Vec3& position, Real m) {
        x.push_back(position);
        v.push_back(Vec3::Zero());
        x_prev.push_back(position);
        f.push_back(Vec3::Zero());
        mass.push_back(m);
        inv_mass.push_back(m > 0 ? Real(1) / m : Real(0));
        x_next.push_back(position);
        v_solved.push_back(Vec3::Zero());
        return static_cast<std::uint32_t>(x.size() - 1);
    }
};

}  // namespace sinew
