// Names of the rigid settings' choices, and their parsing.
#include "rigid/rigid_settings.hpp"

#include <cstring>

#include "rigid/rigid_body.hpp"

namespace sinew {

const char* body_type_name(BodyType t) {
    switch (t) {
        case BodyType::Static: return "static";
        case BodyType::Kinematic: return "kinematic";
        case BodyType::Dynamic: return "dynamic";
    }
    return "unknown";
}

const char* rigid_solver_name(RigidSolverKind k) {
    switch (k) {
        case RigidSolverKind::SoftStep: return "soft_step";
        case RigidSolverKind::SplitImpulse: return "split_impulse";
        case RigidSolverKind::Baumgarte: return "baumgarte";
        case RigidSolverKind::Newton: return "newton";
        default: return "unknown";
    }
}

bool parse_rigid_solver(const char* name, RigidSolverKind& out) {
    for (int k = 0; k < int(RigidSolverKind::Count); ++k)
        if (std::strcmp(name, rigid_solver_name(RigidSolverKind(k))) == 0) {
            out = RigidSolverKind(k);
            return true;
        }
    return false;
}

}  // namespace sinew
