// Small helpers of the C API that need no world: quaternions (the C API's {x, y, z, w} order), the
// interpolation of two transforms for rendering between fixed steps, and handle equality.
#include <cmath>

#include "engine/api/capi_internal.hpp"

extern "C" {

sinew_quat sinew_quat_from_axis_angle(sinew_vec3 axis, float angle) {
    const double n = std::sqrt(double(axis.x) * axis.x + double(axis.y) * axis.y + double(axis.z) * axis.z);
    if (!(n > 0) || !std::isfinite(n) || !std::isfinite(angle)) return {0, 0, 0, 1};  // documented: identity
    const double s = std::sin(0.5 * double(angle)) / n;
    return {float(axis.x * s), float(axis.y * s), float(axis.z * s), float(std::cos(0.5 * double(angle)))};
}

sinew_quat sinew_quat_from_euler(sinew_vec3 radians) {
    // As scene files' rotation_deg: about the fixed x, then y, then z axes (q = qz qy qx), in double.
    const Eigen::Quaterniond q = Eigen::AngleAxisd(radians.z, Eigen::Vector3d::UnitZ()) *
                                 Eigen::AngleAxisd(radians.y, Eigen::Vector3d::UnitY()) *
                                 Eigen::AngleAxisd(radians.x, Eigen::Vector3d::UnitX());
    if (!std::isfinite(q.w()) || !std::isfinite(q.x()) || !std::isfinite(q.y()) || !std::isfinite(q.z())) return {0, 0, 0, 1};
    return {float(q.x()), float(q.y()), float(q.z()), float(q.w())};
}

sinew_quat sinew_quat_multiply(sinew_quat a, sinew_quat b) {
    return {a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y, a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x,
            a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w, a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z};
}

sinew_vec3 sinew_quat_rotate(sinew_quat q, sinew_vec3 v) {
    // v + 2 w (u x v) + 2 u x (u x v), u = (x, y, z): the unit quaternion's rotation without a matrix.
    const float tx = 2 * (q.y * v.z - q.z * v.y), ty = 2 * (q.z * v.x - q.x * v.z), tz = 2 * (q.x * v.y - q.y * v.x);
    return {v.x + q.w * tx + (q.y * tz - q.z * ty), v.y + q.w * ty + (q.z * tx - q.x * tz),
            v.z + q.w * tz + (q.x * ty - q.y * tx)};
}

sinew_transform sinew_transform_interpolate(sinew_transform a, sinew_transform b, float alpha) {
    sinew_transform t;
    t.p = {a.p.x + (b.p.x - a.p.x) * alpha, a.p.y + (b.p.y - a.p.y) * alpha, a.p.z + (b.p.z - a.p.z) * alpha};
    // Normalised lerp along the shorter arc: for the small turn of one step it is slerp to rounding.
    const float dot = a.q.x * b.q.x + a.q.y * b.q.y + a.q.z * b.q.z + a.q.w * b.q.w;
    const float s = dot < 0 ? -1.0f : 1.0f;
    const float x = a.q.x + (s * b.q.x - a.q.x) * alpha, y = a.q.y + (s * b.q.y - a.q.y) * alpha;
    const float z = a.q.z + (s * b.q.z - a.q.z) * alpha, w = a.q.w + (s * b.q.w - a.q.w) * alpha;
    const float n = std::sqrt(x * x + y * y + z * z + w * w);
    t.q = n > 0 ? sinew_quat{x / n, y / n, z / n, w / n} : a.q;
    return t;
}

int sinew_world_id_equal(sinew_world_id a, sinew_world_id b) { return a.index == b.index && a.generation == b.generation; }
int sinew_body_id_equal(sinew_body_id a, sinew_body_id b) {
    return a.world == b.world && a.index == b.index && a.generation == b.generation;
}
int sinew_soft_body_id_equal(sinew_soft_body_id a, sinew_soft_body_id b) {
    return a.world == b.world && a.index == b.index && a.generation == b.generation;
}
int sinew_joint_id_equal(sinew_joint_id a, sinew_joint_id b) {
    return a.world == b.world && a.index == b.index && a.generation == b.generation;
}

}  // extern "C"
