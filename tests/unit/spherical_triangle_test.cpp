// Arvo's spherical-triangle sampler (renderer/spherical_triangle.h) against independent
// references: the solid angle by Girard's theorem, and a chi-square test of uniformity
// over a subdivision of the triangle (central projection maps the planar subdivision to a
// partition of the spherical triangle, so each part must get its share of solid angle).
#include "renderer/spherical_triangle.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <random>
#include <vector>

namespace {

using accel::Vec3f;
using renderer::SphericalTriangle;
struct D3 {
    double x, y, z;
};
D3 sub(const Vec3f& a, const Vec3f& p) { return {double(a.x) - p.x, double(a.y) - p.y, double(a.z) - p.z}; }
double dot(const D3& a, const D3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
D3 cross(const D3& a, const D3& b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }

/// Girard's theorem, in long double: the interior angles (between the planes through the
/// point and each pair of vertices) sum to pi plus the solid angle.
double solid_angle(const Vec3f& p, const Vec3f& v0, const Vec3f& v1, const Vec3f& v2) {
    using L = long double;
    struct L3 {
        L x, y, z;
    };
    const auto lsub = [&](const Vec3f& v) { return L3{L(v.x) - p.x, L(v.y) - p.y, L(v.z) - p.z}; };
    const auto lcross = [](const L3& a, const L3& b) {
        return L3{a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
    };
    const auto ldot = [](const L3& a, const L3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; };
    const auto angle = [&](const L3& at, const L3& to1, const L3& to2) {  // dihedral angle along `at`
        const L3 n1 = lcross(at, to1), n2 = lcross(at, to2);
        return std::acos(std::clamp(ldot(n1, n2) / std::sqrt(ldot(n1, n1) * ldot(n2, n2)), L(-1), L(1)));
    };
    const L3 a = lsub(v0), b = lsub(v1), c = lsub(v2);
    return double(angle(a, b, c) + angle(b, c, a) + angle(c, a, b) - M_PIl);
}

/// Does the ray p + s d (s > 0) cross triangle (v0, v1, v2)? In double.
bool crosses(const Vec3f& p, const Vec3f& d, const Vec3f& v0, const Vec3f& v1, const Vec3f& v2) {
    const D3 e1 = sub(v1, v0), e2 = sub(v2, v0), o = sub(p, v0), dd{d.x, d.y, d.z};
    const D3 pv = cross(dd, e2);
    const double det = dot(e1, pv);
    if (det == 0) return false;
    const D3 qv = cross(o, e1);
    const double u = dot(o, pv) / det, v = dot(dd, qv) / det, s = dot(e2, qv) / det;
    return u >= 0 && v >= 0 && u + v <= 1 && s > 0;
}

Vec3f mid(const Vec3f& a, const Vec3f& b) { return (a + b) * 0.5f; }

/// 4^levels sub-triangles by midpoint subdivision.
std::vector<std::array<Vec3f, 3>> subdivide(std::array<Vec3f, 3> t, int levels) {
    std::vector<std::array<Vec3f, 3>> out{t};
    for (int l = 0; l < levels; ++l) {
        std::vector<std::array<Vec3f, 3>> next;
        for (const auto& s : out) {
            const Vec3f ab = mid(s[0], s[1]), bc = mid(s[1], s[2]), ca = mid(s[2], s[0]);
            next.push_back({s[0], ab, ca});
            next.push_back({ab, s[1], bc});
            next.push_back({ca, bc, s[2]});
            next.push_back({ab, bc, ca});
        }
        out = next;
    }
    return out;
}

struct Case {
    const char* name;
    Vec3f p;
};
// One triangle seen from a point 1 cm off its plane (about 2.3 sr, the CS184 ceiling above
// the panel), from moderate distances, obliquely, and from far (about 1e-3 sr).
const std::array<Vec3f, 3> kTri{Vec3f{-0.5f, -0.3f, 0.0f}, Vec3f{0.6f, -0.2f, 0.0f}, Vec3f{-0.1f, 0.4f, 0.0f}};
const Case kCases[] = {{"1 cm above", {0.0f, 0.0f, 0.01f}},
                       {"1 cm below, off the centroid", {0.3f, -0.15f, -0.01f}},
                       {"0.5 above", {0.1f, 0.1f, 0.5f}},
                       {"oblique", {2.0f, -1.5f, 0.3f}},
                       {"far", {5.0f, 12.0f, 20.0f}}};

TEST(SphericalTriangle, SolidAngleMatchesGirard) {
    for (const Case& c : kCases) {
        const SphericalTriangle st(c.p, kTri[0], kTri[1], kTri[2]);
        ASSERT_TRUE(st.valid()) << c.name;
        const double ref = solid_angle(c.p, kTri[0], kTri[1], kTri[2]);
        EXPECT_NEAR(st.solid_angle(), ref, 1e-5 * ref + 1e-9) << c.name;
    }
    // In the triangle's plane there is no solid angle to sample.
    EXPECT_FALSE(SphericalTriangle(Vec3f{3.0f, 3.0f, 0.0f}, kTri[0], kTri[1], kTri[2]).valid());
    EXPECT_FALSE(SphericalTriangle(kTri[1], kTri[0], kTri[1], kTri[2]).valid());
}

TEST(SphericalTriangle, SamplesAreUniformInSolidAngle) {
    const auto parts = subdivide(kTri, 2);  // 16 parts: 15 degrees of freedom
    const int n = 160000;
    for (const Case& c : kCases) {
        const SphericalTriangle st(c.p, kTri[0], kTri[1], kTri[2]);
        const double total = solid_angle(c.p, kTri[0], kTri[1], kTri[2]);
        std::vector<int> count(parts.size(), 0);
        int outside = 0;
        std::mt19937 rng(7);
        std::uniform_real_distribution<float> u(0.0f, 1.0f);
        for (int i = 0; i < n; ++i) {
            const Vec3f d = st.sample(u(rng), u(rng));
            EXPECT_NEAR(accel::length(d), 1.0f, 1e-5f);
            bool found = false;
            for (size_t k = 0; k < parts.size() && !found; ++k)
                if (crosses(c.p, d, parts[k][0], parts[k][1], parts[k][2])) ++count[k], found = true;
            outside += !found;
        }
        // Samples on a shared edge may miss every part by rounding: a handful at most.
        EXPECT_LE(outside, n / 10000) << c.name;
        double chi2 = 0;
        for (size_t k = 0; k < parts.size(); ++k) {
            const double expected = (n - outside) * solid_angle(c.p, parts[k][0], parts[k][1], parts[k][2]) / total;
            chi2 += (count[k] - expected) * (count[k] - expected) / expected;
        }
        // The 1e-4 upper quantile of chi-square with 15 degrees of freedom is 42.6.
        EXPECT_LT(chi2, 42.6) << c.name;
    }
}

}  // namespace
