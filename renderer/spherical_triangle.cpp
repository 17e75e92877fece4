#include "renderer/spherical_triangle.h"

#include <algorithm>
#include <cmath>

namespace renderer {
namespace {

double dot(const double* a, const double* b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
void cross(const double* a, const double* b, double* out) {
    out[0] = a[1] * b[2] - a[2] * b[1], out[1] = a[2] * b[0] - a[0] * b[2], out[2] = a[0] * b[1] - a[1] * b[0];
}
bool normalize(double* v) {
    const double l = std::sqrt(dot(v, v));
    if (!(l > 0) || !std::isfinite(l)) return false;
    v[0] /= l, v[1] /= l, v[2] /= l;
    return true;
}
/// The unit component of w orthogonal to unit n: the tangent at n of the arc toward w.
bool tangent(const double* w, const double* n, double* out) {
    const double k = dot(w, n);
    out[0] = w[0] - k * n[0], out[1] = w[1] - k * n[1], out[2] = w[2] - k * n[2];
    return normalize(out);
}

}  // namespace

// Everything from dot products, one atan2 and one sincos: this runs per light sample, and
// in the course's boxes tracing a ray costs about as much as three transcendental calls.
SphericalTriangle::SphericalTriangle(const accel::Vec3f& p, const accel::Vec3f& v0, const accel::Vec3f& v1,
                                     const accel::Vec3f& v2) {
    const accel::Vec3f* v[3] = {&v0, &v1, &v2};
    double* out[3] = {a_, b_, c_};
    for (int k = 0; k < 3; ++k) {
        for (int i = 0; i < 3; ++i) out[k][i] = double((*v[k])[i]) - double(p[i]);
        if (!normalize(out[k])) return;
    }
    double bc[3];
    cross(b_, c_, bc);
    const double triple = std::abs(dot(a_, bc));
    // Van Oosterom & Strackee 1983 for unit vectors: tan(area / 2) = |a.(b x c)| / (1 + a.b + b.c + c.a).
    area_ = 2 * std::atan2(triple, 1 + dot(a_, b_) + dot(b_, c_) + dot(c_, a_));
    // The interior angle at A, between the arcs' tangents there: their cross product is
    // parallel to a with length |a.(b x c)|; their lengths are the sines of arcs AB, AC.
    const double ab = dot(a_, b_), ac = dot(a_, c_);
    const double lb = std::sqrt(std::max(0.0, 1 - ab * ab)), lc = std::sqrt(std::max(0.0, 1 - ac * ac));
    if (!(lb > 0 && lc > 0)) return;
    for (int i = 0; i < 3; ++i) tc_[i] = (c_[i] - ac * a_[i]) / lc;
    cos_alpha_ = std::clamp((dot(b_, c_) - ab * ac) / (lb * lc), -1.0, 1.0);
    sin_alpha_ = std::min(1.0, triple / (lb * lc));
    valid_ = area_ > 0 && std::isfinite(area_) && sin_alpha_ > 0;
}

accel::Vec3f SphericalTriangle::sample(float u1, float u2) const {
    // Arvo 1995, section 3: the sub-triangle A B C' of area u1 * area fixes C' on arc AC,
    // at cosine q from A.
    const double sub = double(u1) * area_;
    const double ss = std::sin(sub), cs = std::cos(sub);
    const double s = ss * cos_alpha_ - cs * sin_alpha_, t = cs * cos_alpha_ + ss * sin_alpha_;  // of sub - alpha
    const double u = t - cos_alpha_, v = s + sin_alpha_ * dot(a_, b_);
    const double den = (v * s + u * t) * sin_alpha_;
    const double q = den != 0 ? std::clamp(((v * t - u * s) * cos_alpha_ - v) / den, -1.0, 1.0) : 1.0;
    const double r = std::sqrt(std::max(0.0, 1 - q * q));
    double c2[3], perp[3], w[3];
    for (int i = 0; i < 3; ++i) c2[i] = q * a_[i] + r * tc_[i];
    // Then a point on arc B C', the cosine of its angle to B uniform in [B.C', 1].
    const double z = 1 - double(u2) * (1 - dot(c2, b_));
    if (!tangent(c2, b_, perp)) return {float(b_[0]), float(b_[1]), float(b_[2])};
    const double rz = std::sqrt(std::max(0.0, 1 - z * z));
    for (int i = 0; i < 3; ++i) w[i] = z * b_[i] + rz * perp[i];
    normalize(w);
    return {float(w[0]), float(w[1]), float(w[2])};
}

bool barycentrics_toward(const accel::Vec3f& p, const accel::Vec3f& w, const accel::Vec3f& v0,
                         const accel::Vec3f& e1, const accel::Vec3f& e2, float& b1, float& b2) {
    // Moller-Trumbore in double.
    const double d[3] = {w.x, w.y, w.z}, a[3] = {e1.x, e1.y, e1.z}, c[3] = {e2.x, e2.y, e2.z};
    const double o[3] = {double(p.x) - v0.x, double(p.y) - v0.y, double(p.z) - v0.z};
    double pv[3], qv[3];
    cross(d, c, pv);
    const double det = dot(a, pv);
    if (!(std::abs(det) > 0)) return false;
    cross(o, a, qv);
    if (!(dot(c, qv) / det > 0)) return false;
    double x = std::max(0.0, dot(o, pv) / det), y = std::max(0.0, dot(d, qv) / det);
    if (x + y > 1) x /= x + y, y = 1 - x;
    b1 = float(x), b2 = float(y);
    return true;
}

}  // namespace renderer
