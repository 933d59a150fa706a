// Placement helpers shared by the scene loader's generators and by anything that must build the very
// same scenes (the benchmark's Bullet worlds, tests).
#include <cmath>

#include "engine/world/scene.hpp"

namespace sinew {

std::vector<Vec3> pyramid_box_centres(int rows, Real half_extent, Real spacing, const Vec3& base) {
    std::vector<Vec3> centres;
    if (rows <= 0) return centres;
    centres.reserve(static_cast<std::size_t>(rows) * (rows + 1) / 2);
    const Real layer = 2 * half_extent;  // faces touching: one box height per row
    for (int r = 0; r < rows; ++r) {
        const int n = rows - r;
        const Real y = base.y() + half_extent + Real(r) * layer;
        for (int i = 0; i < n; ++i) {
            // Offset from the row centre in pitches: i - (n - 1) / 2, written as (2i - n + 1) / 2 so it is
            // an exact half-integer in floating point and the default pyramid lands on exact coordinates.
            const Real offset = Real(2 * i - n + 1) * Real(0.5) * spacing;
            centres.emplace_back(base.x() + offset, y, base.z());
        }
    }
    return centres;
}

std::vector<Vec3> tower_box_centres(int height, Real half_extent, const Vec3& base) {
    std::vector<Vec3> centres;
    if (height <= 0) return centres;
    centres.reserve(static_cast<std::size_t>(height));
    for (int r = 0; r < height; ++r)
        centres.emplace_back(base.x(), base.y() + half_extent + Real(r) * 2 * half_extent, base.z());
    return centres;
}

Quat quat_from_euler_xyz_deg(const Vec3& degrees) {
    // Converted in double so that e.g. 90 degrees gives a quaternion as close to exact as Real allows.
    const double to_rad = 3.14159265358979323846 / 180.0;
    auto axis = [&](double deg, const Eigen::Vector3d& a) { return Eigen::Quaterniond(Eigen::AngleAxisd(deg * to_rad, a)); };
    const Eigen::Quaterniond q = axis(degrees.z(), Eigen::Vector3d::UnitZ()) *
                                 axis(degrees.y(), Eigen::Vector3d::UnitY()) *
                                 axis(degrees.x(), Eigen::Vector3d::UnitX());
    return q.normalized().cast<Real>();
}

}  // namespace sinew
