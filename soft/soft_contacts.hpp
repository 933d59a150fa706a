// Contacts between soft bodies: every surface particle of one body against the surface triangles of the
// other, both ways, in the soft system's SolveVelocities after each body's own solve (its internal
// forces and its contacts with rigid shapes), before any position is integrated.
//
// A contact joins four particles: the particle p and the triangle's a, b, c at the barycentric weights
// (α, β, γ) of the triangle point closest to p, so the gap along the triangle's normal n is
// g = n·(x_p − α x_a − β x_b − γ x_c) − (r_p + r_tri), the two bodies' thicknesses. Each contact is
// resolved as Bridson, Fedkiw & Anderson 2002 (§7.1) treat cloth proximity: an impulse I along n shared
// by inverse mass, Δv_p = w_p I n and Δv_k = −λ_k w_k I n (λ the weights), whose effective inverse mass
// is W = w_p + Σ λ_k² w_k; the same sharing removes the penetration of the predicted positions (a
// position projection, as the particle-shape pass does) and then the approaching normal velocity, with
// Coulomb friction bounded by μ times the normal change. The impulses sum to zero, so the pass conserves
// linear momentum exactly; Gauss-Seidel sweeps over the contacts let stacks pass their weight down.
// A sleeping body takes part with inverse mass zero; a moving body that reaches one wakes it.
//
// A body with SoftBodyDef::self_collision also meets its own triangles, all but those within one edge of
// the particle (a cloth folding on itself).
//
// What it does not do (docs/soft-bodies.md, "Soft bodies against soft bodies"): edge-edge contacts (two
// cloths crossing edge on edge between particles), continuous collision (a particle that crosses a whole
// triangle in one step, or ends deeper inside a closed body than its search reach).
#pragma once

#include <cstdint>
#include <vector>

#include "soft/soft_body.hpp"

namespace sinew {

/// One soft-soft contact of the last step.
struct SoftSoftContact {
    std::uint32_t body = 0;       ///< slot of the body whose particle touches
    std::uint32_t particle = 0;
    std::uint32_t other = 0;      ///< slot of the body whose triangle is touched
    std::uint32_t triangle = 0;   ///< index into that body's triangles (3 particles each)
    Vec3 weights = Vec3::Zero();  ///< barycentric weights of the touched point on the triangle
    Vec3 normal = Vec3::UnitY();  ///< unit, from the triangle towards the particle
    Real depth = 0;               ///< penetration of the predicted positions before the pass (m, >= 0)
    Real impulse = 0;             ///< normal impulse the particle received (N s); the triangle took its opposite
    Vec3 friction = Vec3::Zero(); ///< tangential impulse the particle received (N s)
};

class SoftContactPass {
public:
    /// A body taking part this step: its slot, whether it steps (else it is asleep or sitting out, and
    /// takes part immovable at its positions x).
    struct Entry {
        std::uint32_t slot = 0;
        SoftBody* body = nullptr;
        bool stepping = false;
    };

    /// Resolves the contacts among `bodies` (positions: x_next of stepping bodies, velocities v) and
    /// records them (contacts()). Stepping bodies end with v_solved = v.
    void run(const std::vector<Entry>& bodies, Real h);
    const std::vector<SoftSoftContact>& contacts() const { return contacts_; }

    /// May bodies a and b (in slots sa and sb) touch at all: both have particles, one has triangles, their
    /// filters agree, neither meets the world only through a rigid proxy, and each is among the other's
    /// soft_partners if it has any?
    static bool may_touch(const SoftBody& a, std::uint32_t sa, const SoftBody& b, std::uint32_t sb);
    /// Do the triangles close a volume (every edge shared by exactly two)? Then a particle found behind
    /// one is inside the body; an open surface (cloth) has two sides instead.
    static bool closed_surface(const std::vector<std::uint32_t>& triangles);

    /// Gauss-Seidel sweeps over the contacts (positions, then velocities).
    static constexpr int kIterations = 16;

private:
    struct Side;  // one body's arrays for the step, in soft_contacts.cpp
    /// Contacts of the surface particles of entry ea with the triangles of entry eb within `reach`; `self`:
    /// ea == eb, and triangles within one edge of the particle are skipped (build_neighbours first).
    void detect(const Side& a, const Side& b, std::uint32_t ea, std::uint32_t eb, Real reach, bool self);
    /// The edge neighbours of every particle of b, for near_self.
    void build_neighbours(const SoftBody& b);
    /// Is the triangle on particle i or one edge from it?
    bool near_self(std::uint32_t i, const std::uint32_t* tri) const;
    std::vector<std::uint32_t> neighbour_start_, neighbours_;
    /// Entry e's triangles into its hash grid, each box fattened by `margin`.
    void build_grid(Side& s, std::uint32_t e, Real margin);

    /// Per participating body: where its positions are, its box, its surface particles and its triangle
    /// grid (cell keys sorted with the triangle index), reused from step to step.
    struct Grid {
        Real cell = 1;
        std::vector<std::uint64_t> keys;
        std::vector<std::uint32_t> tris;
        std::vector<Aabb> boxes;  ///< per triangle: its nodes swept over the step, fattened by the margin
        std::vector<std::uint32_t> stamp;  ///< per triangle: the last query that tested it
        std::uint32_t query = 0;
        Aabb bounds;  ///< of every finite triangle box
    };
    std::vector<std::uint32_t> cand_;  ///< scratch of detect: one particle's candidate triangles
    std::vector<Grid> grids_;
    std::vector<std::vector<std::uint32_t>> surface_;  ///< per entry: particles on its triangles (or all)
    std::vector<std::uint8_t> mark_;
    std::vector<std::pair<std::uint64_t, std::uint32_t>> sort_scratch_;
    std::vector<SoftSoftContact> contacts_;
    /// Per contact: the entries it joins, and its target normal speed (restitution) and summed push.
    struct Work {
        std::uint32_t ea, eb;
        Real target_vn;
        Real push;
    };
    std::vector<Work> work_;
};

}  // namespace sinew
