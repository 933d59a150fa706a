// Validation of a SoftBodyDef before anything is created (the world stays as it was on bad input).
#pragma once

#include "soft/soft_body.hpp"

namespace sinew {

/// Throws SoftError naming the first bad field and its index, e.g.
/// "soft body: links[12].b = 900 is out of range (840 particles)".
void validate_soft_body_def(const SoftBodyDef& def);

}  // namespace sinew
