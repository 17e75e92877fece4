// Tests of every BSDF in renderer/bsdf/: chi-square goodness of fit of the sampled
// directions against the pdf over several incident angles and roughnesses (as pbrt-v4's
// bsdfs_test.cpp and Mitsuba 3's test_*.py chi2 tests do), white furnace, reciprocity,
// and the pdf's integral.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "renderer/bsdf/bsdf.h"
#include "renderer/bsdf/rough_dielectric.h"
#include "renderer/interaction.h"
#include "renderer/rng.h"

using namespace renderer::bsdf;
using accel::Vec3f;

namespace {

Vec3f dir(float theta_deg, float phi_deg = 0.0f) {
    const float t = theta_deg * kPi / 180.0f, p = phi_deg * kPi / 180.0f;
    return {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
}

/// Regularised upper incomplete gamma Q(a, x): the chi-square survival function is
/// Q(dof/2, x/2). Series for x < a+1, Lentz's continued fraction otherwise (Numerical
/// Recipes 6.2).
double gamma_q(double a, double x) {
    if (x <= 0) return 1.0;
    const double lg = std::lgamma(a);
    if (x < a + 1) {
        double sum = 1.0 / a, term = sum;
        for (int n = 1; n < 1000; ++n) {
            term *= x / (a + n);
            sum += term;
            if (std::abs(term) < std::abs(sum) * 1e-15) break;
        }
        return 1.0 - sum * std::exp(-x + a * std::log(x) - lg);
    }
    double b = x + 1 - a, c = 1e300, d = 1 / b, h = d;
    for (int i = 1; i < 1000; ++i) {
        const double an = -i * (i - a);
        b += 2;
        d = an * d + b;
        if (std::abs(d) < 1e-300) d = 1e-300;
        c = b + an / c;
        if (std::abs(c) < 1e-300) c = 1e-300;
        d = 1 / d;
        const double del = d * c;
        h *= del;
        if (std::abs(del - 1) < 1e-15) break;
    }
    return std::exp(-x + a * std::log(x) - lg) * h;
}

using PdfFn = std::function<float(const Vec3f&)>;
using SampleFn = std::function<bool(renderer::Rng&, Vec3f&)>;

struct Chi2Result {
    double p_value = 0;
    double pdf_integral = 0;
    int dof = 0;
};

/// Histogram of N sampled directions over (theta, phi) cells against the pdf integrated
/// over each cell (midpoint rule on a sub-grid, weighted by sin theta); cells with an
/// expected count below 5 are pooled (pbrt-v4's chi2test).
Chi2Result chi2(const PdfFn& pdf, const SampleFn& sample, int n = 400000, int nt = 48, int np = 48) {
    const int sub = 8;
    std::vector<double> expected(size_t(nt * np), 0.0), observed(size_t(nt * np), 0.0);
    double integral = 0;
    for (int i = 0; i < nt; ++i)
        for (int j = 0; j < np; ++j) {
            double acc = 0;
            for (int a = 0; a < sub; ++a)
                for (int b = 0; b < sub; ++b) {
                    const double t = (i + (a + 0.5) / sub) * kPi / nt;
                    const double p = (j + (b + 0.5) / sub) * 2 * kPi / np;
                    const Vec3f w{float(std::sin(t) * std::cos(p)), float(std::sin(t) * std::sin(p)),
                                  float(std::cos(t))};
                    acc += pdf(w) * std::sin(t);
                }
            acc *= (kPi / nt) * (2 * kPi / np) / (sub * sub);
            integral += acc;
            expected[size_t(i * np + j)] = acc * n;
        }
    renderer::Rng rng(7, 11);
    for (int k = 0; k < n; ++k) {
        Vec3f w;
        if (!sample(rng, w)) continue;
        const double t = std::acos(std::clamp(double(w.z), -1.0, 1.0));
        double p = std::atan2(double(w.y), double(w.x));
        if (p < 0) p += 2 * kPi;
        const int i = std::min(nt - 1, int(t / kPi * nt)), j = std::min(np - 1, int(p / (2 * kPi) * np));
        observed[size_t(i * np + j)] += 1;
    }
    // Pool small cells, then sum (O-E)^2/E.
    double chi = 0, pool_e = 0, pool_o = 0;
    int cells = 0;
    for (size_t c = 0; c < expected.size(); ++c) {
        if (expected[c] < 5) {
            pool_e += expected[c];
            pool_o += observed[c];
            continue;
        }
        chi += (observed[c] - expected[c]) * (observed[c] - expected[c]) / expected[c];
        ++cells;
    }
    if (pool_e >= 5) {
        chi += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
        ++cells;
    } else if (pool_o > 20) {
        chi += 1e9;  // samples where the pdf says there are none
    }
    Chi2Result r;
    r.dof = cells - 1;
    r.p_value = gamma_q(r.dof / 2.0, chi / 2.0);
    r.pdf_integral = integral;
    return r;
}

/// `cells`: histogram cells per axis; narrow lobes need finer ones, or the midpoint
/// quadrature of the pdf over a cell, not the sampler, is what fails.
template <class B>
void expect_fits(const B& b, const Vec3f& wo, const std::string& what, int cells = 48) {
    const Chi2Result r = chi2([&](const Vec3f& wi) { return b.pdf(wo, wi); },
                              [&](renderer::Rng& rng, Vec3f& wi) {
                                  Sample s;
                                  const float u1 = rng.next_float(), u2 = rng.next_float(), uc = rng.next_float();
                                  if (!b.sample(wo, u1, u2, uc, s)) return false;
                                  wi = s.wi;
                                  return true;
                              },
                              400000, cells, cells);
    // Significance 1% split over the ~55 fits in this file (Sidak).
    EXPECT_GT(r.p_value, 1e-2 / 55) << what << ": chi-square rejects the sampler (dof " << r.dof << ")";
    EXPECT_LE(r.pdf_integral, 1.02) << what << ": pdf integrates above 1";
    EXPECT_GT(r.pdf_integral, 0.5) << what << ": pdf integrates to almost nothing";
}

/// Monte Carlo directional albedo: E[weight] of the sampler, by channel.
template <class B>
Vec3f albedo(const B& b, const Vec3f& wo, int n = 200000) {
    renderer::Rng rng(3, 5);
    Vec3f sum(0.0f);
    for (int k = 0; k < n; ++k) {
        Sample s;
        const float u1 = rng.next_float(), u2 = rng.next_float(), uc = rng.next_float();
        if (b.sample(wo, u1, u2, uc, s)) sum += s.weight;
    }
    return sum / float(n);
}

const float kAngles[] = {0.0f, 30.0f, 60.0f, 80.0f};

}  // namespace

TEST(BsdfStats, ChiSquareUsesTheRightTail) {
    // Known values of the chi-square survival function: the test machinery itself.
    EXPECT_NEAR(gamma_q(1.0, 1.0), std::exp(-1.0), 1e-9);       // dof 2, x = 2
    EXPECT_NEAR(gamma_q(5.0, 9.1558 / 2 * 2 / 2), 0.0, 1.0);     // smoke: finite
    EXPECT_NEAR(gamma_q(2.5, 11.0705 / 2), 0.05, 1e-3);          // dof 5, 95th percentile
    EXPECT_NEAR(gamma_q(50.0, 124.342 / 2), 0.05, 1e-3);         // dof 100
}

TEST(BsdfStats, ChiSquareRejectsAWrongPdf) {
    // A cosine sampler tested against a uniform-hemisphere pdf must fail: the test can fail.
    const Lambert l{Vec3f(1.0f)};
    const Chi2Result r = chi2([](const Vec3f& wi) { return wi.z > 0 ? 1.0f / (2 * kPi) : 0.0f; },
                              [&](renderer::Rng& rng, Vec3f& wi) {
                                  Sample s;
                                  if (!l.sample(Vec3f(0, 0, 1), rng.next_float(), rng.next_float(), 0.5f, s))
                                      return false;
                                  wi = s.wi;
                                  return true;
                              },
                              50000);
    EXPECT_LT(r.p_value, 1e-6);
}

TEST(Lambert, ChiSquareFurnaceReciprocity) {
    const Lambert l{Vec3f(1.0f)};
    for (float a : kAngles) expect_fits(l, dir(a, 20), "lambert " + std::to_string(a));
    const Vec3f alb = albedo(l, dir(45));
    EXPECT_NEAR(alb.x, 1.0f, 1e-4f);
    EXPECT_FLOAT_EQ(l.f(dir(10), dir(70, 100)).x, l.f(dir(70, 100), dir(10)).x);
    EXPECT_EQ(l.f(dir(10), dir(120)).x, 0.0f) << "no transmission";
}

TEST(Mirror, ReflectsExactlyWithItsTint) {
    const Mirror m{Vec3f(1.0f, 0.5f, 0.25f)};
    Sample s;
    ASSERT_TRUE(m.sample(dir(40, 30), 0.3f, 0.6f, 0.1f, s));
    EXPECT_TRUE(s.delta);
    const Vec3f want = dir(40, 210);
    EXPECT_NEAR(s.wi.x, want.x, 1e-6f);
    EXPECT_NEAR(s.wi.y, want.y, 1e-6f);
    EXPECT_NEAR(s.wi.z, want.z, 1e-6f);
    EXPECT_EQ(s.weight, Vec3f(1.0f, 0.5f, 0.25f));
    EXPECT_EQ(m.pdf(dir(40, 30), want), 0.0f) << "a delta lobe has no density";
    EXPECT_TRUE(Bsdf(m).is_delta());
    EXPECT_FALSE(Bsdf(Lambert{Vec3f(1.0f)}).is_delta());
}

TEST(SmoothDielectric, FurnaceFresnelAndTotalInternalReflection) {
    for (float eta : {1.5f, 1.0f / 1.5f, 1.33f})
        for (float a : kAngles) {
            const SmoothDielectric g{Vec3f(1.0f), Vec3f(1.0f), eta};
            const Vec3f wo = dir(a, 15);
            const float F = fresnel_dielectric(wo.z, eta);
            // Reflection plus transmission is exactly 1 once the radiance scaling 1/eta^2
            // of the transmitted part is undone (white furnace).
            renderer::Rng rng(1, 2);
            double energy = 0, reflected = 0;
            const int n = 100000;
            for (int k = 0; k < n; ++k) {
                Sample s;
                ASSERT_TRUE(g.sample(wo, rng.next_float(), rng.next_float(), rng.next_float(), s));
                ASSERT_TRUE(s.delta);
                const bool refl = s.wi.z > 0;
                reflected += refl;
                energy += s.weight.x * (refl ? 1.0f : eta * eta);
                if (!refl) {
                    // Snell's law.
                    const float sin_o = std::sqrt(1 - wo.z * wo.z), sin_t = std::sqrt(1 - s.wi.z * s.wi.z);
                    EXPECT_NEAR(sin_o, eta * sin_t, 1e-5f);
                }
            }
            EXPECT_NEAR(energy / n, 1.0, 1e-5) << "eta " << eta << " angle " << a;
            EXPECT_NEAR(reflected / n, F, 4 * std::sqrt(F * (1 - F) / n) + 1e-9);
        }
    // Beyond the critical angle (inside glass, eta = 1/1.5: 41.8 deg) everything reflects.
    EXPECT_EQ(fresnel_dielectric(dir(60).z, 1.0f / 1.5f), 1.0f);
    EXPECT_NEAR(fresnel_dielectric(1.0f, 1.5f), 0.04f, 1e-6f);
}

TEST(RoughConductor, ChiSquareFurnaceReciprocity) {
    for (float alpha : {0.15f, 0.4f, 0.8f})
        for (float a : kAngles) {
            const RoughConductor c{Beckmann{alpha}, Vec3f(0.2f, 0.4f, 1.3f), Vec3f(3.2f, 2.5f, 1.9f)};
            expect_fits(c, dir(a, 30), "beckmann alpha " + std::to_string(alpha) + " angle " + std::to_string(a));
            // F = 1 (eta 0, k 1): a perfect reflector reflects at most 1, and nearly 1
            // where masking is small.
            const RoughConductor white{Beckmann{alpha}, Vec3f(0.0f), Vec3f(1.0f)};
            const Vec3f alb = albedo(white, dir(a, 30));
            EXPECT_LE(alb.x, 1.01f) << alpha << " " << a;
            if (a <= 30 && alpha <= 0.4f) {
                EXPECT_GT(alb.x, 0.9f) << alpha << " " << a;
            }
            const Vec3f w1 = dir(a, 30), w2 = dir(50, 250);
            EXPECT_NEAR(c.f(w1, w2).x, c.f(w2, w1).x, 1e-5f * (1 + c.f(w1, w2).x));
        }
}

// Visible-normal sampling (Heitz and d'Eon 2014) must match its pdf at grazing incidence
// too, where the slope inversion works hardest, and for smooth and rough surfaces.
TEST(RoughConductor, VisibleNormalsFitAtGrazingAngles) {
    // The reflected lobe squeezed against the horizon is narrow: 160 cells per axis, where
    // 48 fail the pdf's own quadrature (for the course's D cos sampling as well).
    for (float alpha : {0.15f, 0.3f, 1.0f})
        for (float a : {85.0f, 89.0f}) {
            const RoughConductor c{Beckmann{alpha}, Vec3f(0.2f, 0.4f, 1.3f), Vec3f(3.2f, 2.5f, 1.9f)};
            expect_fits(c, dir(a, 130), "beckmann alpha " + std::to_string(alpha) + " angle " + std::to_string(a),
                        160);
        }
}

// The density of visible normals integrates to 1 over the hemisphere (it is normalised by
// the exact Smith G1), and the sample weight of a white conductor is F G / G1(wo) <= 1 for
// every sample (up to the 0.3 % by which the course's rational G differs from the exact
// one), so grazing views no longer get the spikes of sampling D(m) cos(m).
TEST(RoughConductor, VisibleNormalDensityIsNormalisedAndWeightsBounded) {
    for (float alpha : {0.1f, 0.5f, 1.0f})
        for (float a : {0.0f, 45.0f, 80.0f, 88.0f}) {
            const Beckmann d{alpha};
            const Vec3f wo = dir(a, 40);
            const int nt = 2000, np = 400;
            double integral = 0;
            for (int i = 0; i < nt; ++i)
                for (int j = 0; j < np; ++j) {
                    const double t = (i + 0.5) / nt * 0.5 * kPi, p = (j + 0.5) / np * 2 * kPi;
                    const Vec3f m{float(std::sin(t) * std::cos(p)), float(std::sin(t) * std::sin(p)), float(std::cos(t))};
                    integral += d.pdf_m(wo, m) * std::sin(t) * (0.5 * kPi / nt) * (2 * kPi / np);
                }
            EXPECT_NEAR(integral, 1.0, 3e-3) << "alpha " << alpha << " angle " << a;
            const RoughConductor white{d, Vec3f(0.0f), Vec3f(1.0f)};
            renderer::Rng rng(4, 2);
            float worst = 0;
            for (int k = 0; k < 20000; ++k) {
                Sample s;
                if (white.sample(wo, rng.next_float(), rng.next_float(), 0.5f, s)) worst = std::max(worst, s.weight.x);
                if (k < 2000) {
                    const Vec3f m = d.sample_m(wo, rng.next_float(), rng.next_float());
                    ASSERT_GT(accel::dot(wo, m), 0.0f) << "a sampled normal wo cannot see";
                }
            }
            EXPECT_LE(worst, 1.0f + 5e-3f) << "alpha " << alpha << " angle " << a;
        }
}

// The float helpers behind Beckmann's visible-normal sampling against double precision:
// erfc_as within Abramowitz and Stegun's bound (1.5e-7) and the float rounding of its
// alternating quintic, Giles's erfinv within a few float ulps into the tails, and the
// slope inversion lands within its tolerance of u and keeps the order of u (a
// stratified u stays stratified).
TEST(Beckmann, FloatSlopeInversionMatchesDoublePrecision) {
    for (double z = 0; z < 9.0; z += 1e-3)
        ASSERT_NEAR(erfc_as(float(z), float(std::exp(-z * z))), std::erfc(z), 5e-7) << "erfc at " << z;
    const auto erfinv_ref = [](double y) {
        double x = 0;
        for (int i = 0; i < 100; ++i) {
            const double step = (std::erf(x) - y) / (2.0 / std::sqrt(double(kPi)) * std::exp(-x * x));
            x -= step;
            if (std::abs(step) < 1e-15 * (1 + std::abs(x))) break;
        }
        return x;
    };
    float worst = 0;
    for (int i = 1; i < 20000; ++i) {
        const float y = -1.0f + 2.0f * float(i) / 20000.0f;
        worst = std::max(worst, float(std::abs(erfinv(y) - erfinv_ref(y)) / std::abs(erfinv_ref(y))));
    }
    for (float y : {1e-7f, 0.999f, 0.99999f, 0x1.fffffep-1f, -0x1.fffffep-1f})
        worst = std::max(worst, float(std::abs(erfinv(y) - erfinv_ref(y)) / std::abs(erfinv_ref(y))));
    EXPECT_LT(worst, 5e-7f) << "erfinv's largest relative error";

    for (double theta_deg : {0.5, 10.0, 45.0, 70.0, 85.0, 89.9}) {
        const double t = theta_deg * kPi / 180.0, cot = std::cos(t) / std::sin(t);
        const double k = 0.5 * cot * std::sqrt(double(kPi));
        const auto cdf = [&](double x) {
            return (k * std::erfc(-x) + 0.5 * std::exp(-x * x)) / (k * std::erfc(-cot) + 0.5 * std::exp(-cot * cot));
        };
        float prev = -1e30f;
        for (int i = 0; i <= 4096; ++i) {
            const float u = float(i) / 4096.0f;
            float sx, sy;
            Beckmann::visible_slopes(float(std::cos(t)), float(std::sin(t)), u, u, sx, sy);
            if (i > 0 && i < 4096) {
                ASSERT_NEAR(cdf(sx), u, 2.0 * Beckmann::kSlopeTolerance) << "theta " << theta_deg << " u " << u;
            }
            ASSERT_GE(sx, prev) << "sx must grow with u: theta " << theta_deg << " u " << u;
            ASSERT_LE(sx, float(cot)) << "a slope wo cannot see";
            ASSERT_TRUE(std::isfinite(sy));
            prev = sx;
        }
    }
}

TEST(MetalRough, ChiSquareFurnaceReciprocity) {
    for (float rough : {0.35f, 0.6f, 0.9f})
        for (float metallic : {0.0f, 1.0f})
            for (float a : kAngles) {
                const MetalRough b = MetalRough::make(Vec3f(0.9f, 0.6f, 0.3f), metallic, rough, 0.0f, 1.5f, true);
                const std::string what = "ggx rough " + std::to_string(rough) + " metallic " +
                                         std::to_string(metallic) + " angle " + std::to_string(a);
                expect_fits(b, dir(a, 30), what);
                const Vec3f w1 = dir(a, 30), w2 = dir(50, 250);
                EXPECT_NEAR(b.f(w1, w2).x, b.f(w2, w1).x, 1e-5f * (1 + b.f(w1, w2).x)) << what;
                const MetalRough white = MetalRough::make(Vec3f(1.0f), metallic, rough, 0.0f, 1.5f, true);
                EXPECT_LE(albedo(white, dir(a, 30), 100000).x, 1.01f) << what;
            }
}

TEST(MetalRough, TransmissionChiSquareAndFurnace) {
    for (float rough : {0.35f, 0.7f})
        for (bool front : {true, false})
            for (float a : {0.0f, 30.0f, 60.0f}) {
                const MetalRough b = MetalRough::make(Vec3f(1.0f), 0.0f, rough, 1.0f, 1.5f, front);
                const std::string what = "transmission rough " + std::to_string(rough) +
                                         (front ? " entering" : " leaving") + " angle " + std::to_string(a);
                expect_fits(b, dir(a, 30), what);
                // Undo the 1/eta^2 radiance scaling on transmitted samples: at most 1.
                renderer::Rng rng(9, 9);
                double e = 0;
                const int n = 100000;
                for (int k = 0; k < n; ++k) {
                    Sample s;
                    if (!b.sample(dir(a, 30), rng.next_float(), rng.next_float(), rng.next_float(), s)) continue;
                    e += s.weight.x * (s.wi.z < 0 ? b.eta * b.eta : 1.0f);
                }
                EXPECT_LE(e / n, 1.01) << what;
                // Single-scattering microfacets lose energy to masking, more so when rough
                // and at grazing angles inside (Heitz et al. 2016 measure the same).
                EXPECT_GT(e / n, rough < 0.5f ? 0.6 : 0.35) << what << ": most energy must survive a white dielectric";
            }
}

TEST(RoughTransmission, GeneralisedReciprocity) {
    // Radiance BTDFs obey f(wo, wi) / eta_i^2 = f(wi, wo) / eta_o^2 up to the radiance
    // scaling both carry (Veach 1997, 5.2): with ours, f(wo, wi) eta^2 = f'(wi', wo')
    // for the reversed pair seen from the other side.
    for (float eta : {1.5f, 1.0f / 1.33f}) {
        const RoughTransmission t{Ggx{0.4f}, eta};
        const RoughTransmission back{Ggx{0.4f}, 1.0f / eta};
        const Vec3f wo = dir(35, 20);
        for (float ti : {140.0f, 160.0f, 175.0f}) {
            const Vec3f wi = dir(ti, 190);
            const float f1 = t.f(wo, wi);
            const Vec3f wo2{wi.x, wi.y, -wi.z}, wi2{wo.x, wo.y, -wo.z};
            const float f2 = back.f(wo2, wi2);
            ASSERT_GT(f1, 0.0f) << "a refraction pair";
            EXPECT_NEAR(f1 * eta * eta, f2, 1e-3f * f2)
                << "eta " << eta << " theta_i " << ti;
        }
    }
}

TEST(NormalMap, TangentSpaceConvention) {
    // A flat map (0.5, 0.5) keeps the normal; +x in the map leans toward dp/du (made
    // orthogonal to the normal). Only X and Y are read: Z is the unit normal's.
    scenes::Scene scene;
    scene.textures.push_back(scenes::Texture::from_rgb("flat", 1, 1, {0.5f, 0.5f, 0.0f}));
    // x = sqrt(1/2), y = 0, so z = sqrt(1/2): 45 degrees toward the tangent.
    const float x = 0.5f * (std::sqrt(0.5f) + 1.0f);
    scene.textures.push_back(scenes::Texture::from_rgb("lean", 1, 1, {x, 0.5f, 0.0f}));
    scenes::Material m;
    m.normal_texture = 0;
    renderer::Interaction it;
    it.ng = it.ns = Vec3f(0, 0, 1);
    it.dpdu = Vec3f(2, 0, 0.5f);
    const Vec3f flat = mapped_normal(scene, m, it);
    EXPECT_NEAR(flat.z, 1.0f, 1e-6f);
    m.normal_texture = 1;
    const Vec3f lean = mapped_normal(scene, m, it);
    EXPECT_NEAR(lean.x, std::sqrt(0.5f), 1e-5f) << "leans toward dp/du";
    EXPECT_NEAR(lean.y, 0.0f, 1e-5f);
    EXPECT_NEAR(lean.z, std::sqrt(0.5f), 1e-5f);
    it.dpdu = Vec3f(0.0f);
    EXPECT_EQ(mapped_normal(scene, m, it), it.ns) << "no tangent: the map is not applied";
}
