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
// Edge-edge contacts between two bodies: two surfaces crossing edge on edge between their particles (a
// cloth's edge across another's, a cube's edge across another's) are found between surface edges (the
// triangles' edges) whose closest points lie inside both edges (a closest point at an end of an edge is a
// particle, which the point-triangle contacts hold), and resolved with the four particles at the weights
// of the two closest points (Bridson et al. 2002 §7.1 treat both kinds alike), on velocities only: each
// impulse also moves the predicted positions by h times its velocity change, towards a speculative target
// (soft_contacts.cpp).
//
// What it does not do (docs/soft-bodies.md, "Soft bodies against soft bodies"): edge-edge contacts of a
// body with itself (built, off: they kept a piled cloth moving); continuous collision (a particle that
// crosses a whole triangle in one step, or ends deeper inside a closed body than its search reach, or an
// edge that passes another within a step); edges of bodies without triangles (ropes).
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

/// One edge-edge contact of the last step: an edge of one body's surface near an edge of another's (or
/// of its own), their closest points inside both edges.
struct SoftEdgeContact {
    std::uint32_t body = 0;          ///< slot of the body of edge a
    std::uint32_t a[2] = {0, 0};     ///< edge a's particles
    std::uint32_t other = 0;         ///< slot of the body of edge b
    std::uint32_t b[2] = {0, 0};     ///< edge b's particles
    Real s = 0, t = 0;               ///< the closest points: a[0] + s (a[1] - a[0]) and b[0] + t (b[1] - b[0])
    Vec3 normal = Vec3::UnitY();     ///< unit, from edge b towards edge a
    Real depth = 0;                  ///< penetration of the predicted positions before the pass (m, >= 0)
    Real impulse = 0;                ///< normal impulse edge a's point received (N s); edge b's took its opposite
    Vec3 friction = Vec3::Zero();    ///< tangential impulse edge a's point received (N s)
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
    /// Before the bodies' own solves (positions: x_next the predictions), finds the same point-triangle
    /// contacts between different bodies as run() would and gives each stepping body that holds its
    /// contacts inside its solve (SoftBody::holds_soft_planes: fast mass-spring) one plane per contact of
    /// its particles with another body: that body's surface at x_n, lifted by its thickness
    /// (SoftBody::soft_planes; every entry's list is replaced). Records no contacts: run() still resolves
    /// them after the solves.
    void gather_planes(const std::vector<Entry>& bodies, Real h);
    const std::vector<SoftSoftContact>& contacts() const { return contacts_; }
    const std::vector<SoftEdgeContact>& edge_contacts() const { return edge_contacts_; }

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
    /// The bodies' sides and the contacts among them into work_: point-triangle ones between different
    /// bodies, and when `all_kinds` edge-edge ones and a body's with itself too; false when there is none.
    bool detect_all(const std::vector<Entry>& bodies, Real h, std::vector<Side>& sides, bool all_kinds);
    /// The Gauss-Seidel sweeps over work_, then the records and the solved velocities.
    void resolve(std::vector<Side>& sides, Real h);
    /// Contacts of the surface particles of entry ea with the triangles of entry eb within `reach`; `self`:
    /// ea == eb, and triangles within one edge of the particle are skipped (build_neighbours first).
    void detect(const Side& a, const Side& b, std::uint32_t ea, std::uint32_t eb, Real reach, bool self);
    /// Edge-edge contacts of the surface edges of entry ea with those of entry eb (through eb's triangle
    /// grid); `self`: ea == eb, each pair once, edges within one edge of each other skipped.
    void detect_edges(const Side& a, const Side& b, std::uint32_t ea, std::uint32_t eb, Real reach, Real h, bool self);
    /// Entry e's surface edges (each triangle edge once) and each triangle's three edge indices.
    void build_edges(const SoftBody& b, std::uint32_t e);
    /// The edge neighbours of every particle of b, for near_self.
    void build_neighbours(const SoftBody& b);
    /// Is the triangle on particle i or one edge from it?
    bool near_self(std::uint32_t i, const std::uint32_t* tri) const;
    /// Is particle j particle i or one edge from it?
    bool adjacent(std::uint32_t i, std::uint32_t j) const;
    std::vector<std::uint32_t> neighbour_start_, neighbours_;
    /// Per entry: 2 particles per surface edge, 3 edge indices per triangle, the last query per edge.
    std::vector<std::vector<std::uint32_t>> edge_ends_, tri_edges_, edge_stamp_;
    std::vector<std::uint8_t> edges_built_;
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
    std::vector<SoftEdgeContact> edge_contacts_;
    /// Per contact of either kind, what the sweeps work on: the entries it joins, the particles of each
    /// side at the weights of the contact point (point-triangle: 1 and 3, edge-edge: 2 and 2), its normal
    /// (from side b to side a), target normal speed (restitution), summed push and impulses, and the
    /// record it reports to (index into contacts_ or edge_contacts_).
    struct Work {
        std::uint32_t ea = 0, eb = 0;
        std::uint32_t na = 0, nb = 0;
        std::uint32_t ia[2] = {0, 0}, ib[3] = {0, 0, 0};
        Real wa[2] = {0, 0}, wb[3] = {0, 0, 0};
        Vec3 normal = Vec3::Zero();
        Real target_vn = 0;
        Real push = 0;
        Real impulse = 0;
        Vec3 friction = Vec3::Zero();
        bool edge = false;
        std::uint32_t record = 0;
    };
    std::vector<Work> work_;
};

}  // namespace sinew
