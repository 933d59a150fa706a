// A body whose state turned non-finite during a step (a method far past its stability limit, a motor or
// a joint beyond what the solver can hold). The system that owns the body contains it where it finds it,
// in IntegratePositions, so the world stays valid: the body is put back where the step found it, at rest,
// and the fault is reported by World::faults() and, through the C API, as SINEW_ERROR_NON_FINITE and a
// log line (issue 18: a blow-up used to end as NaN while every step returned OK and the log stayed silent).
#pragma once

#include <cstdint>
#include <string>

namespace sinew {

/// A body (m/s, rad/s) or particle (m/s) faster than this at the end of a step has blown up although its
/// numbers are still finite: 100 times the fastest a body may be set moving (rigid_system.hpp), beyond any
/// game's bullet. A hinge motor of 1e5 N m driving an arm into the ground reached 2.4e13 rad/s one step
/// after its first NaN.
constexpr double kBlowUpSpeed = 1e6;

struct StepFault {
    enum class System : std::uint8_t { Rigid, Soft };
    System system = System::Rigid;
    std::uint32_t index = 0;     ///< the body's slot in its system
    std::uint32_t generation = 0;
    std::uint64_t step = 0;      ///< the world's step count when it happened (0 = the first step)
    std::string what;            ///< which quantity was not finite or too fast, with its value
    std::string hint;            ///< the method's stability limit and what to change (may be empty)

    /// "rigid" or "soft".
    const char* system_name() const { return system == System::Rigid ? "rigid" : "soft"; }
    /// What happened and what was done, then the hint: the text after a fault's body is named.
    std::string outcome() const {
        return what + "; put back where the step found it, at rest" + (hint.empty() ? "" : ". " + hint);
    }
};

}  // namespace sinew
