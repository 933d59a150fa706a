// How rigid and soft bodies act on each other: the coupling strategy of a world, and per soft-rigid pair
// overrides (seed 001 ch.4 §1 and ch.5 §6; ../shared/THEORY.md §6-7; docs/coupling.md).
//
//   one-way   rigid bodies push soft ones and carry their attached particles; soft bodies push nothing
//             back (a kinematic arm under a cloth; O'Brien 2000's one-way case).
//   two-way   soft particles touching a dynamic rigid body enter the rigid solve as point masses
//             (Sifakis 2007: rotational terms zero), solved in every rigid iteration and sub-step with
//             friction; what the soft system's own solve does to those particles afterwards (its links
//             pulling them back in) is sent back as the opposite impulse, and the rows are solved again
//             against the result `exchange_iterations - 1` more times. Momentum is exchanged exactly.
//   hybrid    one-way contacts, and the rigid body takes `gain` times the impulse the soft contacts gave
//             the particles (an estimate of the reaction from the soft side's momentum change at the
//             contacts: O'Brien 2000's ball through a net); gain 1 conserves momentum at the contacts,
//             gain 0 is one-way.
//   interleaved  Baraff & Witkin 1997: the systems step alternately, each against the other's previous
//             result, and only forces cross. The soft bodies meet the rigid bodies where their previous
//             velocities take them (no refinement from this step's rigid solve); the forces the soft
//             contacts exerted act on the rigid bodies in the next step; the repair step then carries
//             the particles that touched a body by the difference between where the body went and
//             where the soft bodies were told it would go. Best at a large mass disparity (a light
//             cloth on a heavy body), wrong at 1:1 (seed 001 ch.4 §1).
//   one-solver  two-way in one solver (the future work seed 001 names): a mass-spring body's whole solve
//             moves into the rigid solver. Its particles are point masses there, its springs swept a
//             particle at a time in every pass (block Gauss-Seidel on implicit Euler's system), in the same
//             loop as the rigid contacts, the joints, the particles' contacts with every collider and its
//             attachments; its own method only predicts (explicit forces) and runs the contact pass. FEM
//             and Verlet bodies are coupled as under two-way.
//   embed-rigid  embedding (Fishman 2012, seed 001 ch.4 §2 and ch.5 §7): the soft body enters the rigid
//             solver as one rigid proxy (mass, centre of mass, Steiner inertia, momentum and angular
//             momentum of its nodes, a rotation by polar decomposition, the convex hull of its nodes) that
//             meets every rigid body and joint there; what the rigid solve does to the proxy is given to
//             the nodes as a rigid motion (coupling/rigid_embedding.hpp). Per soft body: a pair naming
//             one rigid body cannot embed.
//   embed-fem  embedding the other way (Parker & O'Brien 2009, seed 001 ch.4 §3): a dynamic rigid body
//             gets a very stiff FEM proxy in the soft system, reset to the body's pose and velocity each
//             step, which meets the soft bodies paired with it through the soft-soft contacts; what those
//             contacts gave its nodes, summed to a force and a torque about the centre of mass, goes to the
//             rigid body (coupling/fem_embedding.hpp). Per pair or per world.
//   auto      per world: every soft body gets the cheapest of the above expected to stay within
//             `tolerance` (coupling/strategy_picker.hpp: the rules and the measurements they rest on);
//             pairs the settings name keep their strategy.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "rigid/rigid_body.hpp"
#include "soft/soft_body.hpp"

namespace sinew {

enum class CouplingStrategy : std::uint8_t {
    OneWay, TwoWay, Hybrid, Interleaved, OneSolver, EmbedRigid, EmbedFem,
    Auto,  ///< the world's only: resolved per soft body into one of the others (coupling/strategy_picker.hpp)
    Count
};

/// "one-way", "two-way", "hybrid", "interleaved", "one-solver", "embed-rigid", "embed-fem", "auto".
const char* coupling_strategy_name(CouplingStrategy s);
/// Parses a name of coupling_strategy_name (false if unknown).
bool parse_coupling_strategy(const std::string& text, CouplingStrategy& out);
/// "one-way, two-way, hybrid, interleaved, one-solver": for error messages.
std::string coupling_strategy_list();

/// embed-rigid's proxies of a soft body (seed 001 ch.5 §7): one rigid proxy for the whole body, or one per
/// element (per tet; per surface triangle without tets; per structural link without either), whose
/// shared nodes carry each proxy's velocity changes to its neighbours inside the rigid solver's
/// iterations (coupling/element_proxies.hpp).
enum class EmbedProxies : std::uint8_t { Body, Elements, Count };
/// How an element proxy weighs its nodes: by their own masses (an impulse on the proxy changes the nodes'
/// momentum by exactly that impulse), or each node at the whole body's mass over the element's node count
/// (seed 001 ch.5 §7: every tet given the whole mesh's mass, for faster convergence of the constraints;
/// the nodes then take only their share of an impulse, and momentum is not exchanged exactly).
enum class EmbedProxyMass : std::uint8_t { Physical, WholeBody, Count };

/// "body", "elements".
const char* embed_proxies_name(EmbedProxies p);
bool parse_embed_proxies(const std::string& text, EmbedProxies& out);
/// "physical", "whole-body".
const char* embed_proxy_mass_name(EmbedProxyMass m);
bool parse_embed_proxy_mass(const std::string& text, EmbedProxyMass& out);

/// A strategy for one soft body against one rigid body (or against every rigid body: `rigid` null).
struct CouplingPair {
    SoftBodyId soft;
    BodyId rigid;  ///< null: every rigid body
    CouplingStrategy strategy = CouplingStrategy::TwoWay;
};

struct CouplingSettings {
    CouplingStrategy strategy = CouplingStrategy::OneWay;  ///< for every pair no override names
    /// Two-way: passes of the particle rows per step (the rigid solve's, then one more after each
    /// exchange of the soft solve's reaction, up to this count), >= 1.
    int exchange_iterations = 2;
    /// Hybrid: the share of the soft contacts' impulse sent back to the rigid body, in [0, 1].
    Real gain = 1;
    /// One-way and hybrid: soft steps per rigid step, in [1, 64] (a stiff cloth at 300 Hz under a 60 Hz
    /// rigid world: 5), against the rigid bodies' poses interpolated over the step. Above 1 every pair must
    /// be one-way or hybrid (two-way and interleaved exchange within one step of both systems); hybrid's
    /// reaction from the sub-steps after the first reaches the rigid bodies in the next step.
    int substeps = 1;
    /// Auto: the position error (m) the picked strategies should stay within, against a converged run
    /// of the same scene (docs/compare.md), in (0, 1000].
    Real tolerance = Real(0.01);
    /// embed-rigid: one proxy per soft body, or one per element (for every embedded body of the world;
    /// "auto" embeds with one per body, the granularity its rules were measured with).
    EmbedProxies embed_proxies = EmbedProxies::Body;
    /// embed-rigid with element proxies: how each weighs its nodes.
    EmbedProxyMass embed_proxy_mass = EmbedProxyMass::Physical;
    /// Later entries win over earlier ones; a pair naming one rigid body wins over one naming none.
    std::vector<CouplingPair> pairs;
};

/// The largest `tolerance` (m) settings accept.
constexpr Real kMaxCouplingTolerance = 1000;

/// What is wrong with `s` (names the field and, for a pair, its index), or "" if nothing. Pairs are
/// checked for well-formed values only; whether their bodies exist is the world's check.
std::string coupling_settings_problem(const CouplingSettings& s);

}  // namespace sinew

namespace sinew {

/// The strategy of a soft-rigid pair under `settings`: the last pair naming both bodies, else the last
/// naming the soft body and every rigid body, else the world's strategy. Linear in the pairs (a scene
/// names a handful); layers call it once per (soft body, collider) per step, not per particle.
CouplingStrategy coupling_strategy_of(const CouplingSettings& settings, SoftBodyId soft, BodyId rigid);

}  // namespace sinew
