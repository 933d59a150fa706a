#include "engine/core/format.hpp"

#include <sstream>

namespace sinew {

std::string to_text(double x) {
    std::ostringstream s;
    s << x;
    return s.str();
}

std::string to_text(const Vec3& v) {
    std::ostringstream s;
    s << "(" << v.x() << ", " << v.y() << ", " << v.z() << ")";
    return s.str();
}

}  // namespace sinew
