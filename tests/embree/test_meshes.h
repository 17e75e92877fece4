// Test meshes shared by the Embree tests: indexed triangles with Embree's vertex padding,
// random points in a box, a closed UV sphere.
#pragma once

#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "accel/accelerator.h"

namespace test_meshes {

using accel::GeometryView;
using accel::kPi;
using accel::Vec3f;

/// Indexed triangles that own their memory, with the one element of vertex padding
/// Embree's 16-byte loads need (GeometryView contract).
struct TestMesh {
    std::vector<Vec3f> positions;  // num_vertices + 1
    std::vector<uint32_t> indices;
    uint32_t num_vertices = 0;

    void finish() {
        num_vertices = uint32_t(positions.size());
        positions.push_back(Vec3f(0.0f));
    }
    GeometryView view() const {
        return GeometryView::triangles(positions.data(), num_vertices, indices.data(), uint32_t(indices.size() / 3));
    }
};

inline Vec3f random_in_box(std::mt19937& rng, const Vec3f& lo, const Vec3f& hi) {
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    return {lo.x + u(rng) * (hi.x - lo.x), lo.y + u(rng) * (hi.y - lo.y), lo.z + u(rng) * (hi.z - lo.z)};
}

/// Closed UV sphere with outward winding and shared vertices (poles shared too).
inline TestMesh tessellated_sphere(uint32_t stacks, uint32_t slices, const Vec3f& c, float r) {
    TestMesh m;
    m.positions.push_back(c + Vec3f(0.0f, r, 0.0f));  // north pole: 0
    for (uint32_t i = 1; i < stacks; ++i) {
        float th = kPi * float(i) / float(stacks);
        for (uint32_t j = 0; j < slices; ++j) {
            float ph = 2.0f * kPi * float(j) / float(slices);
            m.positions.push_back(c + Vec3f(r * std::sin(th) * std::cos(ph), r * std::cos(th),
                                            r * std::sin(th) * std::sin(ph)));
        }
    }
    const uint32_t south = uint32_t(m.positions.size());
    m.positions.push_back(c + Vec3f(0.0f, -r, 0.0f));
    auto ring = [&](uint32_t i, uint32_t j) { return 1 + (i - 1) * slices + (j % slices); };
    for (uint32_t j = 0; j < slices; ++j) {
        m.indices.insert(m.indices.end(), {0, ring(1, j + 1), ring(1, j)});
        m.indices.insert(m.indices.end(), {south, ring(stacks - 1, j), ring(stacks - 1, j + 1)});
    }
    for (uint32_t i = 1; i + 1 < stacks; ++i)
        for (uint32_t j = 0; j < slices; ++j) {
            uint32_t a = ring(i, j), b = ring(i, j + 1), cc = ring(i + 1, j), d = ring(i + 1, j + 1);
            m.indices.insert(m.indices.end(), {a, b, d});
            m.indices.insert(m.indices.end(), {a, d, cc});
        }
    m.finish();
    return m;
}

}  // namespace test_meshes
