// Numbers and vectors as text, for error messages that name the bad value.
#pragma once

#include <string>

#include "engine/core/math.hpp"

namespace sinew {

/// Shortest round-trip-ish text of x as iostreams print it ("0.5", "-1", "nan", "1e+30").
std::string to_text(double x);
/// "(x, y, z)".
std::string to_text(const Vec3& v);

}  // namespace sinew
