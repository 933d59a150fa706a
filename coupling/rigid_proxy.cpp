// The rigid proxy of a set of nodes (coupling/rigid_proxy.hpp).
#include "coupling/rigid_proxy.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>

#include <algorithm>

#include "engine/core/aabb.hpp"

namespace sinew {

Mat3 polar_rotation(const Mat3& a) {
    Eigen::Matrix3d ad = a.cast<double>();
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(ad, Eigen::ComputeFullU | Eigen::ComputeFullV);
    const Eigen::Vector3d sv = svd.singularValues();
    if (sv(2) < 1e-6 * sv(0)) {
        // Rank-deficient (a rope, a flat cloth): the rotation about the missing directions is free, and
        // the SVD's null vectors would pick one at random from step to step. A small multiple of the
        // identity resolves it towards no turn.
        ad.diagonal().array() += 1e-6 * sv(0);
        svd.compute(ad, Eigen::ComputeFullU | Eigen::ComputeFullV);
    }
    Eigen::Matrix3d u = svd.matrixU();
    const Eigen::Matrix3d vt = svd.matrixV().transpose();
    // A reflection (a flattened or inverted shape) becomes the nearest rotation by turning the axis of
    // the smallest singular value (the last column of U).
    if ((u * vt).determinant() < 0) u.col(2) = -u.col(2);
    return (u * vt).cast<Real>();
}

bool all_finite(const std::vector<Vec3>& points) {
    for (const Vec3& x : points)
        if (!is_finite(x)) return false;
    return true;
}

Shape make_proxy_hull(std::vector<Vec3>& local, Real thickness, Real flatness) {
    try {
        return make_convex_hull(local, flatness);
    } catch (const ShapeError&) {
        Aabb box;
        for (const Vec3& y : local) box.grow(y);
        const Real pad = std::max(thickness, flatness * (box.hi - box.lo).norm());
        const std::size_t n = local.size();
        for (std::size_t i = 0; i < n; ++i)
            for (int a = 0; a < 3; ++a) {
                Vec3 d = Vec3::Zero();
                d[a] = pad;
                local.push_back(local[i] + d);
                local.push_back(local[i] - d);
            }
        return make_convex_hull(local);
    }
}

RigidProxyState measure_rigid_proxy(const std::vector<Vec3>& x, const std::vector<Vec3>& v,
                                    const std::vector<Real>& mass, const std::vector<Vec3>& rest, Real radius) {
    // Sums in double: a few thousand float nodes summed in float lose the round-off the tests compare at.
    const std::size_t n = x.size();
    double m_total = 0;
    Eigen::Vector3d xm = Eigen::Vector3d::Zero(), p = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < n; ++i) {
        const double m = mass[i];
        m_total += m;
        xm += m * x[i].cast<double>();
        p += m * v[i].cast<double>();
    }
    RigidProxyState out;
    out.mass = Real(m_total);
    const Eigen::Vector3d c = xm / m_total;
    out.com = c.cast<Real>();
    out.momentum = p.cast<Real>();
    out.v = (p / m_total).cast<Real>();
    Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero(), a = Eigen::Matrix3d::Zero();
    Eigen::Vector3d l = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < n; ++i) {
        const double m = mass[i];
        const Eigen::Vector3d r = x[i].cast<double>() - c;
        inertia += m * (r.squaredNorm() * Eigen::Matrix3d::Identity() - r * r.transpose());
        l += m * r.cross(v[i].cast<double>());
        a += m * r * rest[i].cast<double>().transpose();
    }
    // A rope has no moment about its axis, a flat cloth's normal moment is the sum of the other two:
    // only the first is singular; raise the smallest principal moment to 1e-3 of the largest there.
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(inertia);
    const Eigen::Vector3d moments = eig.eigenvalues();
    const double floor = std::max(1e-3 * moments(2), 0.4 * m_total * double(radius) * double(radius));
    if (moments(0) < floor && floor > 0) {
        Eigen::Vector3d raised = moments.cwiseMax(floor);
        inertia = eig.eigenvectors() * raised.asDiagonal() * eig.eigenvectors().transpose();
        out.regularised = true;
    }
    out.inertia = inertia.cast<Real>();
    out.angular_momentum = l.cast<Real>();
    out.w = inertia.ldlt().solve(l).cast<Real>();
    out.rotation = polar_rotation(a.cast<Real>());
    return out;
}

}  // namespace sinew
