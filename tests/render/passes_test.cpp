// Progressive rendering in passes: the image does not depend on how the work is split
// (threads, tile size, pass size), adaptive sampling stays deterministic, and a render
// stopped after some passes and resumed from its state (or from a checkpoint file) is
// bit-identical to the uninterrupted one, counters included.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>

#include "renderer/bsdf/common.h"
#include "renderer/camera.h"
#include "renderer/checkpoint.h"
#include "renderer/integrator.h"
#include "renderer/lights.h"
#include "renderer/render.h"
#include "renderer/scene_geometry.h"
#include "scenes/load.h"

namespace {

using namespace renderer;

struct Cornell {
    scenes::Scene scene = scenes::load_scene(PT_SOURCE_DIR "/scenes/cornell.dae");
    SceneGeometry geometry{scene};
    std::vector<std::string> notes;
    LightSet lights{scene, LightModel::Course, notes};
    std::unique_ptr<accel::Accelerator> accel = build_accelerator("custom", geometry, {}, false);
    std::unique_ptr<Integrator> integrator;
    Camera camera;
    explicit Cornell(int split = 1, bool split_by_noise = true) {
        IntegratorSettings is;
        is.name = "path";
        is.max_depth = 4;
        is.split = split;
        is.split_by_noise = split_by_noise;
        integrator = make_integrator(is, scene, geometry, &lights);
        camera = make_camera(scene, CameraMode::Auto, 40, 30).camera;
    }
    RenderResult render(RenderSettings rs) const {
        rs.width = 40;
        rs.height = 30;
        rs.progress = false;
        return renderer::render(camera, *integrator, *accel, rs);
    }
};

const Cornell& world() {
    static Cornell c;
    return c;
}

/// The same box with the camera hit's bounce split three ways (--split 3).
const Cornell& split_world() {
    static Cornell c(3);
    return c;
}

/// The same with every pixel split three ways (--split-by uniform).
const Cornell& uniform_split_world() {
    static Cornell c(3, false);
    return c;
}

void expect_same(const RenderResult& a, const RenderResult& b) {
    ASSERT_EQ(a.image.pixels.size(), b.image.pixels.size());
    EXPECT_EQ(0, std::memcmp(a.image.pixels.data(), b.image.pixels.data(),
                             a.image.pixels.size() * sizeof(float)));
    EXPECT_EQ(a.stats.rays, b.stats.rays);
    EXPECT_EQ(a.stats.shadow_rays, b.stats.shadow_rays);
    EXPECT_EQ(a.stats.nodes_visited, b.stats.nodes_visited);
    EXPECT_EQ(a.stats.prim_tests, b.stats.prim_tests);
    EXPECT_EQ(a.samples, b.samples);
}

RenderSettings base(int spp) {
    RenderSettings rs;
    rs.spp = spp;
    rs.seed = 7;
    return rs;
}

/// Two splits of the same 12-spp work with sampler k: one thread, one pass, 32-pixel
/// tiles; two threads, 5-sample passes, 7-pixel tiles.
std::pair<RenderSettings, RenderSettings> two_splits(SamplerKind k) {
    RenderSettings a = base(12);
    a.sampler = k;
    a.threads = 1;
    a.pass_spp = 12;
    a.tile = 32;
    RenderSettings b = a;
    b.threads = 2;
    b.pass_spp = 5;
    b.tile = 7;
    return {a, b};
}

}  // namespace

TEST(Passes, AnySplitOfTheWorkGivesTheSameBits) {
    const auto [a, b] = two_splits(RenderSettings{}.sampler);  // b: passes of 5, 5, 2
    const RenderResult ra = world().render(a), rb = world().render(b);
    expect_same(ra, rb);
    EXPECT_EQ(ra.samples, 40u * 30u * 12u);
    EXPECT_GT(ra.stats.total_rays(), ra.samples);  // path tracing: more rays than samples
    // A different seed changes the picture: the comparison above is not vacuous.
    RenderSettings c = a;
    c.seed = 8;
    const RenderResult rc = world().render(c);
    EXPECT_NE(0, std::memcmp(ra.image.pixels.data(), rc.image.pixels.data(),
                             ra.image.pixels.size() * sizeof(float)));
}

TEST(Passes, AdaptiveSamplingIsDeterministicAndStopsEarly) {
    RenderSettings a = base(64);
    a.adaptive_batch = 8;
    a.adaptive_tol = 0.2f;
    a.threads = 1;
    RenderSettings b = a;
    b.threads = 2;
    b.tile = 5;
    const RenderResult ra = world().render(a), rb = world().render(b);
    expect_same(ra, rb);
    EXPECT_LT(ra.samples, 40u * 30u * 64u);  // some pixels converged early
    EXPECT_GT(ra.samples, 40u * 30u * 8u);   // and some did not
}

TEST(Passes, ResumeIsBitIdentical) {
    RenderSettings full = base(16);
    full.pass_spp = 4;
    const RenderResult whole = world().render(full);

    // Stop after the first pass (a cancel raised by the checkpoint hook), then resume.
    std::atomic<bool> cancel{false};
    RenderSettings first = full;
    first.checkpoint_every = 0;
    first.cancel = &cancel;
    Accumulation saved;
    first.on_checkpoint = [&](const Accumulation& acc, bool) {
        saved = acc;
        cancel = true;
    };
    const RenderResult part = world().render(first);
    EXPECT_TRUE(part.partial);
    EXPECT_EQ(part.samples, 40u * 30u * 4u);

    const std::string path = ::testing::TempDir() + "passes_test.ckpt";
    write_checkpoint(path, saved, "fp");
    EXPECT_THROW(read_checkpoint(path, "other settings"), CheckpointError);
    const Accumulation loaded = read_checkpoint(path, "fp");
    RenderSettings rest = full;
    rest.resume = &loaded;
    rest.threads = 1;
    expect_same(whole, world().render(rest));
    std::filesystem::remove(path);
}

// Every sampler draws each number from (seed, pixel, sample, dimension) alone, so the
// image is the same for any split of the work, under adaptive sampling too, and after a
// resume; and the samplers do draw different numbers.
TEST(Passes, EverySamplerGivesTheSameBitsForAnySplit) {
    std::vector<RenderResult> images;
    for (SamplerKind k : {SamplerKind::Independent, SamplerKind::Stratified, SamplerKind::Sobol,
                          SamplerKind::ZSobol, SamplerKind::Pmj02}) {
        SCOPED_TRACE(sampler_name(k));
        const auto [a, b] = two_splits(k);
        const RenderResult ra = world().render(a);
        expect_same(ra, world().render(b));

        RenderSettings ad = base(32);
        ad.sampler = k;
        ad.adaptive_batch = 8;
        ad.adaptive_tol = 0.2f;
        ad.threads = 1;
        RenderSettings bd = ad;
        bd.threads = 2;
        bd.tile = 5;
        const RenderResult rad = world().render(ad);
        expect_same(rad, world().render(bd));
        EXPECT_LT(rad.samples, 40u * 30u * 32u) << "adaptive sampling stops some pixels early";

        // Stopped after the first pass and resumed.
        std::atomic<bool> cancel{false};
        RenderSettings first = a;
        first.pass_spp = 4;
        first.checkpoint_every = 0;
        first.cancel = &cancel;
        Accumulation saved;
        first.on_checkpoint = [&](const Accumulation& acc, bool) {
            saved = acc;
            cancel = true;
        };
        EXPECT_TRUE(world().render(first).partial);
        RenderSettings rest = a;
        rest.resume = &saved;
        rest.threads = 2;
        expect_same(ra, world().render(rest));
        images.push_back(ra);
    }
    for (size_t i = 1; i < images.size(); ++i)
        EXPECT_NE(0, std::memcmp(images[0].image.pixels.data(), images[i].image.pixels.data(),
                                 images[0].image.pixels.size() * sizeof(float)))
            << sampler_name(SamplerKind(i)) << " draws the same numbers as independent";
}

// Split branches draw their numbers as samples index * split + j of a sampler of split
// times the sample count: still a pure function of (seed, pixel, sample), so any split of
// the work gives the same bits, and the branches are really drawn apart.
TEST(Passes, SplitBranchesGiveTheSameBitsForAnySplitOfTheWork) {
    for (SamplerKind k : {SamplerKind::Independent, SamplerKind::Stratified,
                          SamplerKind::Sobol, SamplerKind::ZSobol, SamplerKind::Pmj02}) {
        SCOPED_TRACE(sampler_name(k));
        const auto [a, b] = two_splits(k);
        const RenderResult ra = split_world().render(a);
        expect_same(ra, split_world().render(b));
        const RenderResult unsplit = world().render(a);
        EXPECT_GT(ra.stats.rays, unsplit.stats.rays + unsplit.stats.rays / 2)
            << "three bounce rays per camera hit";
        EXPECT_NE(0, std::memcmp(ra.image.pixels.data(), unsplit.image.pixels.data(),
                                 ra.image.pixels.size() * sizeof(float)));
    }
}

// Split by noise (renderer/split_map.h): the map comes from every pixel's first samples,
// so a render resumed from a checkpoint, whose sums mix all its samples, draws them
// again apart and goes on with the same map, bit for bit.
TEST(Passes, SplitByNoiseResumesBitIdentical) {
    RenderSettings full = base(16);
    full.pass_spp = 4;
    const RenderResult whole = split_world().render(full);
    ASSERT_GE(whole.split_shares.size(), 2u) << "the map is not uniform";

    std::atomic<bool> cancel{false};
    RenderSettings first = full;
    first.checkpoint_every = 0;
    first.cancel = &cancel;
    Accumulation saved;
    int checkpoints = 0;
    first.on_checkpoint = [&](const Accumulation& acc, bool) {
        saved = acc;
        // After the second pass: the map's first samples are behind, later ones too.
        if (++checkpoints == 2) cancel = true;
    };
    const RenderResult part = split_world().render(first);
    EXPECT_TRUE(part.partial);
    EXPECT_EQ(part.samples, 40u * 30u * 8u);
    RenderSettings rest = full;
    rest.resume = &saved;
    rest.threads = 1;
    expect_same(whole, split_world().render(rest));
}

// Branch counts that follow the noise change how the image's noise is spread, never
// what it converges to: region means of the split-by-noise and the uniform render agree
// within their standard errors (the variance channel), and the two differ.
TEST(Passes, SplitByNoiseKeepsTheImage) {
    RenderSettings rs = base(64);
    const RenderResult noise = split_world().render(rs),
                       uniform = uniform_split_world().render(rs);
    ASSERT_GE(noise.split_shares.size(), 2u);
    EXPECT_TRUE(uniform.split_shares.empty());
    EXPECT_NE(0, std::memcmp(noise.image.pixels.data(), uniform.image.pixels.data(),
                             noise.image.pixels.size() * sizeof(float)));
    int checked = 0;
    for (int ry = 0; ry < 3; ++ry)
        for (int rx = 0; rx < 4; ++rx) {
            double mean[2] = {0, 0}, var[2] = {0, 0};
            int i = 0;
            for (const RenderResult* r : {&noise, &uniform}) {
                for (int y = ry * 10; y < ry * 10 + 10; ++y)
                    for (int x = rx * 10; x < rx * 10 + 10; ++x) {
                        const float* p = r->image.at(x, y);
                        mean[i] += bsdf::luminance(Vec3f(p[kR], p[kG], p[kB])) / 100.0;
                        var[i] += double(p[kVariance]) / (100.0 * 100.0);
                    }
                ++i;
            }
            const double se = std::sqrt(var[0] + var[1]);
            if (!(se > 0)) continue;
            ++checked;
            EXPECT_LT(std::abs(mean[0] - mean[1]), 4.0 * se)
                << "region " << rx << "," << ry << ": " << mean[0] << " against "
                << mean[1];
        }
    EXPECT_GE(checked, 10);
}
