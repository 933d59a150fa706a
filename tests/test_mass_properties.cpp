// Mass properties against closed forms, an independent numerical integration, and the parallel-axis
// theorem.
//
// Tolerances. compute_mass_properties accumulates in double and rounds to Real once, and every expected
// value below is evaluated in double, so the only error in float is that final rounding plus the
// rounding of the float inputs (all exactly representable here or computed by the same cast): a few
// units of 2^-24 ≈ 6e-8. A relative 1e-5 leaves two orders of magnitude of margin yet would catch any
// wrong coefficient (the smallest formula slip, e.g. a missing 3/4 h r term, is > 1e-2). In double the
// hull sums cancel terms of order |x|^5 against results of the same order, so 1e-10 is still ~1e5 ulp.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <vector>

#include "engine/core/mass_properties.hpp"

using namespace sinew;

namespace {

using Vec3d = Eigen::Vector3d;
using Mat3d = Eigen::Matrix3d;

constexpr double kPiD = 3.14159265358979323846;
constexpr double kRel = sizeof(Real) == sizeof(float) ? 1e-5 : 1e-10;

bool close(double got, double want, double rel = kRel) {
    return std::abs(got - want) <= rel * std::max(1.0, std::abs(want));
}

/// Matrices agree to `rel` of their largest entry (off-diagonal zeros are judged on that scale).
bool close(const Mat3& got, const Mat3d& want, double rel = kRel) {
    const double scale = std::max(1e-300, want.cwiseAbs().maxCoeff());
    return (got.cast<double>() - want).cwiseAbs().maxCoeff() <= rel * scale;
}

bool close(const Vec3& got, const Vec3d& want, double scale, double rel = kRel) {
    return (got.cast<double>() - want).cwiseAbs().maxCoeff() <= rel * scale;
}

/// A hull assembled by hand from vertices and polygonal faces (counter-clockwise from outside), as the
/// hull builder would produce it. Normals come from Newell's method; the orientation is asserted so a
/// mistyped face fails here rather than as a confusing mass error.
Shape hand_hull(const std::vector<Vec3>& verts, const std::vector<std::vector<std::uint16_t>>& faces) {
    auto data = std::make_shared<ConvexHullData>();
    data->vertices = verts;
    Vec3 mean = Vec3::Zero();
    for (const Vec3& v : verts) mean += v;
    mean /= Real(verts.size());
    for (const auto& f : faces) {
        Vec3 n = Vec3::Zero();
        Vec3 c = Vec3::Zero();
        for (std::size_t i = 0; i < f.size(); ++i) {
            const Vec3& a = verts[f[i]];
            const Vec3& b = verts[f[(i + 1) % f.size()]];
            n += a.cross(b);
            c += a;
        }
        c /= Real(f.size());
        n.normalize();
        REQUIRE(n.dot(c - mean) > 0);  // outward, i.e. counter-clockwise seen from outside
        data->faces.push_back({n, n.dot(c), f});
        for (std::size_t i = 0; i < f.size(); ++i) {
            std::uint16_t a = f[i], b = f[(i + 1) % f.size()];
            if (a < b) data->edges.emplace_back(a, b);
        }
    }
    data->centroid = mean;
    Shape s;
    s.type = ShapeType::ConvexHull;
    s.hull = data;
    return s;
}

/// Box [-a,a]x[-b,b]x[-c,c] shifted by `off` as a hull with six quad faces. Vertex i has x = +a if bit 0
/// is set, y = +b for bit 1, z = +c for bit 2.
Shape cube_hull(const Vec3& he, const Vec3& off = Vec3::Zero()) {
    std::vector<Vec3> v;
    for (int i = 0; i < 8; ++i)
        v.push_back(off + Vec3(i & 1 ? he.x() : -he.x(), i & 2 ? he.y() : -he.y(), i & 4 ? he.z() : -he.z()));
    return hand_hull(v, {{1, 3, 7, 5}, {0, 4, 6, 2}, {2, 6, 7, 3}, {0, 1, 5, 4}, {4, 5, 7, 6}, {0, 2, 3, 1}});
}

Mat3d box_inertia(double m, const Vec3d& he) {
    const double a2 = 4 * he.x() * he.x(), b2 = 4 * he.y() * he.y(), c2 = 4 * he.z() * he.z();  // full widths²
    return Vec3d(m / 12 * (b2 + c2), m / 12 * (a2 + c2), m / 12 * (a2 + b2)).asDiagonal();
}

/// Parallel-axis shift of an inertia tensor from the centre of mass to a point at offset d from it.
Mat3d shifted(const Mat3d& i_cm, double m, const Vec3d& d) {
    return i_cm + m * (Mat3d::Identity() * d.squaredNorm() - d * d.transpose());
}

}  // namespace

TEST_CASE("sphere matches 4/3 pi r^3 and 2/5 m r^2", "[mass]") {
    const double r = 0.7, rho = 1300;
    MassProperties mp = compute_mass_properties(make_sphere(Real(r)), Real(rho));
    const double rr = double(Real(r));
    const double m = rho * 4.0 / 3.0 * kPiD * rr * rr * rr;
    CHECK(close(mp.mass, m));
    CHECK(close(mp.volume, m / rho));
    CHECK(mp.center.cwiseAbs().maxCoeff() == 0);
    CHECK(close(mp.inertia, Mat3d::Identity() * (0.4 * m * rr * rr)));
}

TEST_CASE("box matches m/12 (b^2 + c^2)", "[mass]") {
    const Vec3 he(Real(0.5), Real(1.25), Real(2));
    const double rho = 250;
    MassProperties mp = compute_mass_properties(make_box(he), Real(rho));
    const double m = rho * 8 * 0.5 * 1.25 * 2;
    CHECK(close(mp.mass, m));
    CHECK(close(mp.volume, 8 * 0.5 * 1.25 * 2));
    CHECK(mp.center.cwiseAbs().maxCoeff() == 0);
    CHECK(close(mp.inertia, box_inertia(m, he.cast<double>())));
}

TEST_CASE("capsule: closed form, sphere limit, and a voxel integration", "[mass]") {
    const Real h = Real(0.75), r = Real(0.5);
    const double hd = h, rd = r, rho = 2;
    MassProperties mp = compute_mass_properties(make_capsule(h, r), Real(rho));

    // Expected, derived independently of the implementation's hemisphere-by-hemisphere route: the two
    // hemispheres form a whole sphere (mass ms, 2/5 ms r² about its centre) that is cut and each half
    // pushed out by h. For a half of mass ms/2 whose centroid sits e = 3r/8 beyond the cut,
    // I_about_new_point = I_about_cut + (ms/2)((e + h)² - e²) by the parallel-axis theorem applied twice,
    // so together the halves gain ms (h² + 2 e h) = ms (h² + 3/4 h r) on the transverse axes.
    const double mc = rho * kPiD * rd * rd * 2 * hd;
    const double ms = rho * 4.0 / 3.0 * kPiD * rd * rd * rd;
    const double cyl_t = mc * (3 * rd * rd + (2 * hd) * (2 * hd)) / 12;  // m (3r² + L²)/12
    const double ixx = cyl_t + 0.4 * ms * rd * rd + ms * (hd * hd + 2 * (3 * rd / 8) * hd);
    const double iyy = mc * rd * rd / 2 + 0.4 * ms * rd * rd;
    CHECK(close(mp.mass, mc + ms));
    CHECK(close(mp.inertia, Mat3d(Vec3d(ixx, iyy, ixx).asDiagonal())));

    SECTION("zero length is a sphere") {
        MassProperties s = compute_mass_properties(make_capsule(0, r), Real(rho));
        MassProperties t = compute_mass_properties(make_sphere(r), Real(rho));
        CHECK(close(s.mass, t.mass));
        CHECK(close(s.inertia, t.inertia.cast<double>()));
    }

    SECTION("midpoint-rule voxel integration agrees") {
        // Integrate the indicator of the capsule over the positive octant (the capsule is symmetric in
        // all three axes) with cubic cells of side r/N. The boundary cells misclassify a shell of
        // thickness ~ cell/2 whose signed errors partly cancel, so the error is O(1/N) but erratic:
        // measured 1.6e-4 relative at N = 200 (5.8e-4 at N = 100, 2.6e-4 at N = 300). 1e-3 is a safe
        // bound that still catches a wrong term: dropping the hemispheres' 3/4 h r shift is 0.19 here.
        const int n = 200;
        const double cell = rd / n;
        const int ny = int(std::ceil((hd + rd) / cell));
        double vol = 0, sx2 = 0, sy2 = 0, sz2 = 0;
        for (int i = 0; i < n; ++i) {
            const double x = (i + 0.5) * cell;
            for (int k = 0; k < n; ++k) {
                const double z = (k + 0.5) * cell;
                const double rho2 = x * x + z * z;
                if (rho2 > rd * rd) continue;
                for (int j = 0; j < ny; ++j) {
                    const double y = (j + 0.5) * cell;
                    const double q = std::max(0.0, y - hd);
                    if (rho2 + q * q > rd * rd) break;
                    vol += 1;
                    sx2 += x * x;
                    sy2 += y * y;
                    sz2 += z * z;
                }
            }
        }
        const double dv = 8 * cell * cell * cell;
        vol *= dv;
        sx2 *= dv;
        sy2 *= dv;
        sz2 *= dv;
        CHECK(close(mp.volume, vol, 1e-3));
        CHECK(close(mp.inertia(0, 0), rho * (sy2 + sz2), 1e-3));
        CHECK(close(mp.inertia(1, 1), rho * (sx2 + sz2), 1e-3));
        CHECK(close(mp.inertia(2, 2), rho * (sx2 + sy2), 1e-3));
    }
}

TEST_CASE("hull built as a cube matches the box", "[mass]") {
    const Vec3 he(Real(1), Real(0.5), Real(2));
    const Real rho = 3;
    MassProperties hull = compute_mass_properties(cube_hull(he), rho);
    MassProperties box = compute_mass_properties(make_box(he), rho);
    CHECK(close(hull.mass, box.mass));
    CHECK(close(hull.volume, box.volume));
    CHECK(close(hull.center, Vec3d::Zero(), 1.0));
    CHECK(close(hull.inertia, box.inertia.cast<double>()));
}

TEST_CASE("off-centre hulls have the right centroid and inertia about it", "[mass]") {
    SECTION("shifted cube") {
        const Vec3 he(Real(0.5), Real(1), Real(1.5));
        const Vec3 off(Real(3), Real(-2), Real(5));
        MassProperties mp = compute_mass_properties(cube_hull(he, off), 1);
        CHECK(close(mp.center, off.cast<double>(), 5.0));
        CHECK(close(mp.inertia, box_inertia(6, he.cast<double>())));
    }
    SECTION("square pyramid (quad base, triangle sides): centroid a quarter up") {
        // Base side 2a at z = 0, apex at height H: V = 4a²H/3, centroid H/4 above the base,
        // Izz = m (2a)²/10, Ixx = Iyy = m ((2a)²/20 + 3H²/80).
        const double a = 1, hgt = 3;
        const Vec3d off(1, -2, 3);
        std::vector<Vec3> v = {Vec3(-1, -1, 0), Vec3(1, -1, 0), Vec3(1, 1, 0), Vec3(-1, 1, 0), Vec3(0, 0, 3)};
        for (Vec3& p : v) p += off.cast<Real>();
        MassProperties mp = compute_mass_properties(hand_hull(v, {{0, 3, 2, 1}, {0, 1, 4}, {1, 2, 4}, {2, 3, 4}, {3, 0, 4}}), 2);
        const double m = 2 * 4 * a * a * hgt / 3;
        CHECK(close(mp.mass, m));
        CHECK(close(mp.center, off + Vec3d(0, 0, hgt / 4), 3.0));
        const double it = m * (4 * a * a / 20 + 3 * hgt * hgt / 80);
        CHECK(close(mp.inertia, Mat3d(Vec3d(it, it, m * 4 * a * a / 10).asDiagonal())));
    }
    SECTION("corner tetrahedron: products of inertia") {
        // Vertices 0, a e_x, b e_y, c e_z: V = abc/6, centroid (a,b,c)/4, and about the centroid
        // Ixx = 3m (b² + c²)/80, Ixy = m a b/80 (from ∫x² = a² abc/60, ∫xy = ab abc/120 over the
        // tetrahedron, minus the centroid terms).
        const double a = 1, b = 2, c = 3;
        std::vector<Vec3> v = {Vec3(0, 0, 0), Vec3(Real(a), 0, 0), Vec3(0, Real(b), 0), Vec3(0, 0, Real(c))};
        MassProperties mp = compute_mass_properties(hand_hull(v, {{0, 3, 2}, {0, 1, 3}, {0, 2, 1}, {1, 2, 3}}), 1);
        const double m = a * b * c / 6;
        CHECK(close(mp.mass, m));
        CHECK(close(mp.center, Vec3d(a, b, c) / 4, 1.0));
        Mat3d want;
        want << 3 * m * (b * b + c * c) / 80, m * a * b / 80, m * a * c / 80,  //
            m * a * b / 80, 3 * m * (a * a + c * c) / 80, m * b * c / 80,      //
            m * a * c / 80, m * b * c / 80, 3 * m * (a * a + b * b) / 80;
        CHECK(close(mp.inertia, want));
    }
}

TEST_CASE("compounds sum children with the parallel-axis theorem", "[mass]") {
    SECTION("two touching halves equal the whole box") {
        const Vec3 half(Real(0.5), Real(1), Real(1.5));
        Transform left, right;
        left.p = Vec3(Real(-0.5), 0, 0);
        right.p = Vec3(Real(0.5), 0, 0);
        Shape c = make_compound({{left, make_box(half)}, {right, make_box(half)}});
        MassProperties mp = compute_mass_properties(c, 4);
        MassProperties whole = compute_mass_properties(make_box(Vec3(1, 1, Real(1.5))), 4);
        CHECK(close(mp.mass, whole.mass));
        CHECK(close(mp.center, Vec3d::Zero(), 1.0));
        CHECK(close(mp.inertia, whole.inertia.cast<double>()));
    }
    SECTION("two unequal boxes") {
        const Vec3d ha(1, 1, 1), hb(0.5, 0.25, 0.5), pa(2, 0, 0), pb(-1, 1, 0.5);
        const double rho = 2;
        Transform ta, tb;
        ta.p = pa.cast<Real>();
        tb.p = pb.cast<Real>();
        MassProperties mp =
            compute_mass_properties(make_compound({{ta, make_box(ha.cast<Real>())}, {tb, make_box(hb.cast<Real>())}}), Real(rho));
        const double ma = rho * 8 * ha.prod(), mb = rho * 8 * hb.prod();
        const Vec3d com = (ma * pa + mb * pb) / (ma + mb);
        const Mat3d want = shifted(box_inertia(ma, ha), ma, pa - com) + shifted(box_inertia(mb, hb), mb, pb - com);
        CHECK(close(mp.mass, ma + mb));
        CHECK(close(mp.center, com, 2.0));
        CHECK(close(mp.inertia, want));
    }
}

TEST_CASE("a rotated compound child gives the rotated tensor", "[mass]") {
    const Vec3d he(0.5, 1, 2);
    const double m = 8 * he.prod();
    SECTION("quarter turn about z swaps Ixx and Iyy") {
        Transform t;
        t.q = Quat(Eigen::AngleAxis<Real>(kPi / 2, Vec3::UnitZ()));
        MassProperties mp = compute_mass_properties(make_compound({{t, make_box(he.cast<Real>())}}), 1);
        const Mat3d i = box_inertia(m, he);
        CHECK(close(mp.inertia, Mat3d(Vec3d(i(1, 1), i(0, 0), i(2, 2)).asDiagonal())));
    }
    SECTION("generic rotation and offset: R I R^T about the moved centre") {
        Transform t;
        t.p = Vec3(Real(0.3), Real(-1), Real(2));
        t.q = Quat(Eigen::AngleAxis<Real>(Real(0.9), Vec3(1, 2, 3).normalized()));
        MassProperties mp = compute_mass_properties(make_compound({{t, make_box(he.cast<Real>())}}), 1);
        const Mat3d r = t.q.cast<double>().toRotationMatrix();
        CHECK(close(mp.center, t.p.cast<double>(), 2.0));
        CHECK(close(mp.inertia, r * box_inertia(m, he) * r.transpose()));
        // Rotation keeps the principal moments: same trace, and the tensor stays symmetric.
        CHECK(close(mp.inertia.trace(), box_inertia(m, he).trace()));
        CHECK(mp.inertia == mp.inertia.transpose());
    }
}

TEST_CASE("mass_properties_for_mass scales to the requested mass", "[mass]") {
    const Vec3 he(1, 2, 3);
    MassProperties mp = mass_properties_for_mass(make_box(he), 12);
    CHECK(close(mp.mass, 12));
    CHECK(close(mp.volume, 48));
    CHECK(close(mp.inertia, box_inertia(12, he.cast<double>())));
}

TEST_CASE("invalid densities, masses and static shapes throw ShapeError", "[mass]") {
    const Shape box = make_box(Vec3(1, 1, 1));
    const Real inf = std::numeric_limits<Real>::infinity();
    CHECK_THROWS_AS(compute_mass_properties(box, 0), ShapeError);
    CHECK_THROWS_WITH(compute_mass_properties(box, -2.5), Catch::Contains("-2.5"));
    CHECK_THROWS_WITH(compute_mass_properties(box, std::nan("")), Catch::Contains("nan"));
    CHECK_THROWS_WITH(compute_mass_properties(box, inf), Catch::Contains("inf"));
    CHECK_THROWS_WITH(mass_properties_for_mass(box, -7), Catch::Contains("-7"));
    CHECK_THROWS_AS(mass_properties_for_mass(box, 0), ShapeError);

    CHECK_THROWS_WITH(compute_mass_properties(make_plane(Vec3::UnitY(), 0), 1), Catch::Contains("plane"));
    Shape mesh;
    mesh.type = ShapeType::TriangleMesh;
    CHECK_THROWS_WITH(compute_mass_properties(mesh, 1), Catch::Contains("triangle_mesh"));

    // Shapes filled in by hand bypass the factories' checks; the mass code still refuses them.
    Shape bad_sphere;
    bad_sphere.type = ShapeType::Sphere;
    bad_sphere.radius = -1;
    CHECK_THROWS_WITH(compute_mass_properties(bad_sphere, 1), Catch::Contains("-1"));
    // A flat hull (all points in z = 0) has no volume.
    // (built directly: hand_hull would reject its faces, which have no outside).
    auto flat_data = std::make_shared<ConvexHullData>();
    flat_data->vertices = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0)};
    for (std::vector<std::uint16_t> f : {std::vector<std::uint16_t>{0, 1, 2}, {0, 2, 3}, {0, 3, 2}, {0, 2, 1}})
        flat_data->faces.push_back({Vec3::UnitZ(), 0, f});
    Shape flat;
    flat.type = ShapeType::ConvexHull;
    flat.hull = flat_data;
    CHECK_THROWS_WITH(compute_mass_properties(flat, 1), Catch::Contains("degenerate"));
}
