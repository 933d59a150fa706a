// Constraint rows from outside the contact manifolds, solved inside the rigid solvers' iterations.
//
// The rigid system's own joints (rigid/joint_set.hpp) are the first such source; a coupling layer adds
// its own (particles pushing on rigid bodies, proxies of soft bodies) through RigidSystem::add_rows().
// Every solver calls every source at the same points of its step:
//
//   prepare(step)           once per step, for the (sub-)step length the solver iterates with
//   warm_start(velocities)  once per (sub-)step, if warm starting is on
//   solve(velocities, bias) in every iteration, before the contact rows (Box2D's order: joints first);
//                           a sub-stepping solver also calls it without bias in its relax passes
//   positions_advanced(h)   whenever the solver has moved the rigid bodies' positions by h: after every
//                           sub-step of the soft step, once per step for the others. The source moves
//                           the bodies it owns (particles) over the same interval, so its rows see poses
//                           that agree with the rigid bodies' in the next sub-step.
//   finish(h)               once per step, after the positions: reaction forces, breaking, projection
//
// A source is called once per pass, never per row: its own loops run over plain arrays it prepared, with
// no virtual call and no allocation inside (the call per pass is the same one-per-stage cost as the
// pipeline's). Velocities are passed as a BodyVelocities view of the solver's own body array, so a source
// reads and writes the values the contacts see next, without copying the bodies' state around it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

#include "engine/core/math.hpp"

namespace sinew {

class RigidSystem;

/// The linear and angular velocities of the rigid bodies as the running solver stores them, indexed by
/// body slot: a base address for each and a byte stride per body. Split impulses keep them in their
/// `SolverBody` records, the soft step in its `WideBody` rows, the Newtonian solver in the system's own
/// arrays; each gives rows this view of the array it iterates on.
struct BodyVelocities {
    unsigned char* v = nullptr;  ///< address of body 0's linear velocity (3 Reals)
    unsigned char* w = nullptr;  ///< address of body 0's angular velocity (3 Reals)
    std::size_t stride = 0;      ///< bytes from one body's record to the next
    std::size_t count = 0;       ///< bodies in the view

    Vec3 linear(std::uint32_t i) const { return load(v + i * stride); }
    Vec3 angular(std::uint32_t i) const { return load(w + i * stride); }
    void set_linear(std::uint32_t i, const Vec3& x) const { store(v + i * stride, x); }
    void set_angular(std::uint32_t i, const Vec3& x) const { store(w + i * stride, x); }

    /// A view of records of type Body whose members `lin` and `ang` each start three consecutive Reals.
    template <class Body, class Member>
    static BodyVelocities of(std::vector<Body>& bodies, Member Body::*lin, Member Body::*ang) {
        BodyVelocities out;
        if (bodies.empty()) return out;
        out.v = reinterpret_cast<unsigned char*>(&(bodies[0].*lin));
        out.w = reinterpret_cast<unsigned char*>(&(bodies[0].*ang));
        out.stride = sizeof(Body);
        out.count = bodies.size();
        return out;
    }
    /// A view of two arrays of Vec3 (the system's state, or a pass's pseudo-velocities).
    static BodyVelocities of_arrays(std::vector<Vec3>& lin, std::vector<Vec3>& ang) {
        static_assert(sizeof(Vec3) == 3 * sizeof(Real), "Vec3 must be three packed Reals");
        BodyVelocities out;
        if (lin.empty()) return out;
        out.v = reinterpret_cast<unsigned char*>(lin.data());
        out.w = reinterpret_cast<unsigned char*>(ang.data());
        out.stride = sizeof(Vec3);
        out.count = lin.size();
        return out;
    }

private:
    // memcpy: the records are not arrays of Real, so the bytes are copied rather than aliased.
    static Vec3 load(const unsigned char* p) {
        Real r[3];
        std::memcpy(r, p, sizeof r);
        return Vec3(r[0], r[1], r[2]);
    }
    static void store(unsigned char* p, const Vec3& x) {
        const Real r[3] = {x.x(), x.y(), x.z()};
        std::memcpy(p, r, sizeof r);
    }
};

/// How rows remove position error in the step being prepared (chosen by the solver).
struct RowSoftness {
    /// false: Baumgarte's fraction of the error per step as a velocity bias -(baumgarte/h) C (or a
    /// position projection after the step, where a source offers one); true: Catto 2011 soft rows of
    /// `hertz` and `damping_ratio` in the biased passes (the sub-stepping soft step).
    bool soft = false;
    /// Not soft: the solver's velocity passes carry no position bias and the source may project the error
    /// out after the step instead (split impulses with warm starting: the joints' analogue of split
    /// impulses). Otherwise the Baumgarte bias acts in the velocity passes.
    bool projection = false;
    Real baumgarte = Real(0.2);
    Real hertz = 60;          ///< soft: stiffness (Hz)
    Real damping_ratio = 2;   ///< soft
};

/// What a source is told when the solver prepares a step.
struct RowStep {
    Real h = 0;                ///< length of the (sub-)step each pass of rows acts over (s)
    int substeps = 1;          ///< (sub-)steps of length h in the step (the step is h * substeps)
    bool warm_starting = true; ///< keep the accumulated impulses of the last step (else start from zero)
    RowSoftness softness;
};

class ConstraintRows {
public:
    virtual ~ConstraintRows() = default;
    virtual void prepare(RigidSystem& sys, const RowStep& step) = 0;
    virtual void warm_start(const RigidSystem& sys, const BodyVelocities& vel) = 0;
    virtual void solve(const RigidSystem& sys, const BodyVelocities& vel, bool use_bias) = 0;
    virtual void positions_advanced(const RigidSystem&, const BodyVelocities&, Real /*h*/) {}
    /// After prepare(): false when this step's passes would do nothing at all (no rows, nothing to push),
    /// so a solver may skip the source, e.g. to work through independent islands one block at a time.
    virtual bool active() const { return true; }
    virtual void finish(RigidSystem&, Real /*h*/) {}
};

}  // namespace sinew
