// Instances: a prototype (a group of geometries in object space) placed by an affine
// object-to-world transform. Plain data, header-only: the scene model (scenes/scene.h)
// stores its instances in this very layout, so the renderer hands them to a backend
// without a copy, which at 10^7 instances is most of a scene's memory.
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>

#include "accel/math.h"

namespace accel {

/// An affine transform p' = L p + t, row-major 3x4: m[row][0..2] = L, m[row][3] = t.
/// 48 bytes, where a Mat4f takes 64 for a bottom row that is always (0, 0, 0, 1).
struct Affine3f {
    float m[3][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}};

    static Affine3f identity() { return {}; }
    /// The affine part of a 4x4 matrix (its bottom row is ignored).
    static Affine3f from(const Mat4f& a) {
        Affine3f r;
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 4; ++j) r.m[i][j] = a.m[i][j];
        return r;
    }
    Vec3f point(const Vec3f& p) const {
        return {m[0][0] * p.x + m[0][1] * p.y + m[0][2] * p.z + m[0][3],
                m[1][0] * p.x + m[1][1] * p.y + m[1][2] * p.z + m[1][3],
                m[2][0] * p.x + m[2][1] * p.y + m[2][2] * p.z + m[2][3]};
    }
    Vec3f vector(const Vec3f& v) const {
        return {m[0][0] * v.x + m[0][1] * v.y + m[0][2] * v.z, m[1][0] * v.x + m[1][1] * v.y + m[1][2] * v.z,
                m[2][0] * v.x + m[2][1] * v.y + m[2][2] * v.z};
    }
    /// L^T v: with the inverse transform's L, this carries an object-space normal to a
    /// world-space one (the inverse transpose), up to a positive or negative scale.
    Vec3f transpose_vector(const Vec3f& v) const {
        return {m[0][0] * v.x + m[1][0] * v.y + m[2][0] * v.z, m[0][1] * v.x + m[1][1] * v.y + m[2][1] * v.z,
                m[0][2] * v.x + m[1][2] * v.y + m[2][2] * v.z};
    }
    /// det L, in double.
    double det() const {
        return double(m[0][0]) * (double(m[1][1]) * m[2][2] - double(m[1][2]) * m[2][1]) -
               double(m[0][1]) * (double(m[1][0]) * m[2][2] - double(m[1][2]) * m[2][0]) +
               double(m[0][2]) * (double(m[1][0]) * m[2][1] - double(m[1][1]) * m[2][0]);
    }
    /// The inverse, computed in double and rounded once per entry; all-NaN when L is
    /// singular (callers test is_finite).
    Affine3f inverse() const {
        const double d = det();
        Affine3f r;
        if (!(d != 0.0) || !std::isfinite(d)) {
            for (auto& row : r.m)
                for (float& x : row) x = std::numeric_limits<float>::quiet_NaN();
            return r;
        }
        const double a = m[0][0], b = m[0][1], c = m[0][2], e = m[1][0], f = m[1][1], g = m[1][2], h = m[2][0],
                     i = m[2][1], k = m[2][2];
        const double inv[3][3] = {{(f * k - g * i) / d, (c * i - b * k) / d, (b * g - c * f) / d},
                                  {(g * h - e * k) / d, (a * k - c * h) / d, (c * e - a * g) / d},
                                  {(e * i - f * h) / d, (b * h - a * i) / d, (a * f - b * e) / d}};
        for (int row = 0; row < 3; ++row) {
            double t = 0;
            for (int col = 0; col < 3; ++col) {
                r.m[row][col] = float(inv[row][col]);
                t -= inv[row][col] * m[col][3];
            }
            r.m[row][3] = float(t);
        }
        return r;
    }
    /// This after `o` (p -> this(o(p))), in double, rounded once per entry.
    Affine3f operator*(const Affine3f& o) const {
        Affine3f r;
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 4; ++j) {
                double acc = j == 3 ? double(m[i][3]) : 0.0;
                for (int k = 0; k < 3; ++k) acc += double(m[i][k]) * o.m[k][j];
                r.m[i][j] = float(acc);
            }
        return r;
    }
    bool finite() const {
        for (const auto& row : m)
            for (float x : row)
                if (!std::isfinite(x)) return false;
        return true;
    }
    /// The box of a transformed box (Arvo 1990, "Transforming Axis-Aligned Bounding
    /// Boxes"), widened by the rounding of point(): every transformed corner, and so every
    /// transformed point of the box as point() computes it, lies inside.
    Bounds3f bounds(const Bounds3f& b) const {
        Bounds3f r;
        if (b.empty()) return r;
        for (int row = 0; row < 3; ++row) {
            double lo = m[row][3], hi = m[row][3], mag = std::fabs(double(m[row][3]));
            for (int col = 0; col < 3; ++col) {
                const double x = double(m[row][col]) * b.lo[col], y = double(m[row][col]) * b.hi[col];
                lo += std::min(x, y), hi += std::max(x, y);
                mag += std::max(std::fabs(x), std::fabs(y));
            }
            // point() rounds four products and three sums: within gamma(4) * mag of
            // the exact value (Higham 2002, section 3.1), doubled for safety.
            const double err = mag * 8.0 * double(std::numeric_limits<float>::epsilon());
            r.lo[row] = std::nextafter(float(lo - err), -std::numeric_limits<float>::infinity());
            r.hi[row] = std::nextafter(float(hi + err), std::numeric_limits<float>::infinity());
        }
        return r;
    }
};

/// A prototype: the geometries [first_geom, first_geom + num_geoms) of the views given
/// to create_accelerator, in object space. They are traced only through instances.
struct PrototypeView {
    uint32_t first_geom = 0;
    uint32_t num_geoms = 0;
};

/// One placement of a prototype. 52 bytes.
struct InstanceView {
    uint32_t prototype = 0;
    Affine3f object_to_world;
};

}  // namespace accel
