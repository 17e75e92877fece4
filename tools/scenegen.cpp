// scenegen: procedural triangle meshes for benchmarking accelerators, from 1k to many
// millions of triangles, written as binary glTF (.glb) so every tool reads them.
//
// Kinds, each chosen to stress a BVH differently:
//   sphere  - cube-mapped sphere, radially displaced by a sum of random waves: a closed,
//             well-behaved surface with evenly sized triangles (the "typical scan").
//   terrain - height field with fractal detail: large, flat-ish, wide extent, rays graze it.
//   field   - a huge two-triangle ground plus many instanced rocks whose scales span two
//             orders of magnitude: very uneven triangle sizes, many glTF nodes.
//   sliver  - a sheet of needle-thin triangles (aspect ~1000:1) turned diagonal to every
//             axis, so each triangle's bounding box is mostly empty space.
//
// The GLB is written here, not by a library: a 12-byte header, a JSON chunk (padded with
// spaces) and a BIN chunk (padded with zeros); float32 VEC3 POSITION with min/max,
// uint32 SCALAR indices. One buffer, one bufferView per accessor.
//
// The generator code sits above the main() guard so tests/benchmarks/scenegen_test.cpp
// can include this file and check the writer in-process (SCENEGEN_NO_MAIN).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace scenegen {

struct V3 {
    float x = 0, y = 0, z = 0;
};

/// One mesh as it goes into the file: positions and triangle indices.
struct MeshData {
    std::string name;
    std::vector<V3> positions;
    std::vector<uint32_t> indices;
    int material = 0;
    uint64_t triangles() const { return indices.size() / 3; }
};

/// A node instancing mesh `mesh` with a column-major 4x4 matrix (glTF convention).
struct Node {
    int mesh = 0;
    std::array<float, 16> matrix{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    bool identity = true;
};

struct MaterialData {
    std::string name;
    float r = 0.8f, g = 0.8f, b = 0.8f;
};

struct Document {
    std::vector<MeshData> meshes;
    std::vector<Node> nodes;
    std::vector<MaterialData> materials;
    /// Triangles a loader sees after instancing (each node contributes its mesh's).
    uint64_t instanced_triangles() const {
        uint64_t n = 0;
        for (const Node& nd : nodes) n += meshes[size_t(nd.mesh)].triangles();
        return n;
    }
};

// ---------------------------------------------------------------------------------------
// GLB writer

namespace detail {

inline void put_u32(std::string& s, uint32_t v) {
    char b[4];
    std::memcpy(b, &v, 4);  // GLB is little-endian, as is every x86-64 host we build for
    s.append(b, 4);
}

inline std::string fmt_float(float v) {
    // %.9g round-trips a float exactly: min/max must match the data bit for bit.
    char b[32];
    std::snprintf(b, sizeof b, "%.9g", double(v));
    return b;
}

inline std::string json_escape(const std::string& s) {
    std::string o;
    for (char c : s) {
        if (c == '"' || c == '\\') o += '\\';
        if (static_cast<unsigned char>(c) < 0x20) continue;
        o += c;
    }
    return o;
}

}  // namespace detail

/// Serialises `doc` to GLB bytes.
inline std::string to_glb(const Document& doc) {
    using namespace detail;
    std::string bin;
    std::ostringstream views, accessors, meshes;
    int view_count = 0;
    auto align4 = [&bin] {
        while (bin.size() % 4) bin.push_back('\0');
    };
    for (size_t mi = 0; mi < doc.meshes.size(); ++mi) {
        const MeshData& m = doc.meshes[mi];
        if (m.positions.empty() || m.indices.empty()) throw std::invalid_argument("empty mesh " + m.name);
        for (uint32_t i : m.indices)
            if (i >= m.positions.size()) throw std::invalid_argument("index out of range in " + m.name);
        V3 lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
        for (const V3& p : m.positions) {
            lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
            hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
        }
        align4();
        const size_t pos_off = bin.size(), pos_len = m.positions.size() * 12;
        bin.resize(bin.size() + pos_len);
        for (size_t i = 0; i < m.positions.size(); ++i) {
            const float f[3] = {m.positions[i].x, m.positions[i].y, m.positions[i].z};
            std::memcpy(&bin[pos_off + i * 12], f, 12);
        }
        align4();
        const size_t idx_off = bin.size(), idx_len = m.indices.size() * 4;
        bin.resize(bin.size() + idx_len);
        std::memcpy(&bin[idx_off], m.indices.data(), idx_len);

        if (view_count) views << ",";
        views << "{\"buffer\":0,\"byteOffset\":" << pos_off << ",\"byteLength\":" << pos_len
              << ",\"target\":34962},{\"buffer\":0,\"byteOffset\":" << idx_off << ",\"byteLength\":" << idx_len
              << ",\"target\":34963}";
        if (mi) accessors << ",";
        accessors << "{\"bufferView\":" << view_count << ",\"componentType\":5126,\"count\":" << m.positions.size()
                  << ",\"type\":\"VEC3\",\"min\":[" << fmt_float(lo.x) << "," << fmt_float(lo.y) << ","
                  << fmt_float(lo.z) << "],\"max\":[" << fmt_float(hi.x) << "," << fmt_float(hi.y) << ","
                  << fmt_float(hi.z) << "]},{\"bufferView\":" << view_count + 1
                  << ",\"componentType\":5125,\"count\":" << m.indices.size() << ",\"type\":\"SCALAR\"}";
        if (mi) meshes << ",";
        meshes << "{\"name\":\"" << json_escape(m.name) << "\",\"primitives\":[{\"attributes\":{\"POSITION\":"
               << 2 * mi << "},\"indices\":" << 2 * mi + 1 << ",\"material\":" << m.material << ",\"mode\":4}]}";
        view_count += 2;
    }
    align4();
    if (bin.size() >= (uint64_t(1) << 32) - 1024) throw std::length_error("GLB larger than 4 GiB");

    std::ostringstream js;
    js << "{\"asset\":{\"version\":\"2.0\",\"generator\":\"pathtracer scenegen\"},\"scene\":0,\"scenes\":[{\"nodes\":[";
    for (size_t i = 0; i < doc.nodes.size(); ++i) js << (i ? "," : "") << i;
    js << "]}],\"nodes\":[";
    for (size_t i = 0; i < doc.nodes.size(); ++i) {
        const Node& n = doc.nodes[i];
        js << (i ? "," : "") << "{\"mesh\":" << n.mesh;
        if (!n.identity) {
            js << ",\"matrix\":[";
            for (int k = 0; k < 16; ++k) js << (k ? "," : "") << fmt_float(n.matrix[size_t(k)]);
            js << "]";
        }
        js << "}";
    }
    js << "],\"materials\":[";
    for (size_t i = 0; i < doc.materials.size(); ++i) {
        const MaterialData& m = doc.materials[i];
        js << (i ? "," : "") << "{\"name\":\"" << json_escape(m.name)
           << "\",\"pbrMetallicRoughness\":{\"baseColorFactor\":[" << fmt_float(m.r) << "," << fmt_float(m.g)
           << "," << fmt_float(m.b) << ",1],\"metallicFactor\":0,\"roughnessFactor\":1}}";
    }
    js << "],\"meshes\":[" << meshes.str() << "],\"accessors\":[" << accessors.str() << "],\"bufferViews\":["
       << views.str() << "],\"buffers\":[{\"byteLength\":" << bin.size() << "}]}";
    std::string json = js.str();
    while (json.size() % 4) json.push_back(' ');  // the JSON chunk is padded with spaces

    std::string out;
    out.reserve(12 + 8 + json.size() + 8 + bin.size());
    put_u32(out, 0x46546C67u);  // "glTF"
    put_u32(out, 2u);
    put_u32(out, uint32_t(12 + 8 + json.size() + 8 + bin.size()));
    put_u32(out, uint32_t(json.size()));
    put_u32(out, 0x4E4F534Au);  // "JSON"
    out += json;
    put_u32(out, uint32_t(bin.size()));
    put_u32(out, 0x004E4942u);  // "BIN\0"
    out += bin;
    return out;
}

/// Writes the GLB under a temporary name and renames it, so a reader never sees half a file.
inline void write_glb(const std::string& path, const Document& doc) {
    const std::string bytes = to_glb(doc);
    const std::string tmp = path + ".tmp";
    // A full disk shows at the write or at the close; either way the temporary goes.
    std::ofstream f(tmp, std::ios::binary);
    f.write(bytes.data(), std::streamsize(bytes.size()));
    f.close();
    if (!f) {
        std::remove(tmp.c_str());
        throw std::runtime_error(path + ": write failed (the disk may be full)");
    }
    if (std::rename(tmp.c_str(), path.c_str()) != 0) {
        std::remove(tmp.c_str());
        throw std::runtime_error(path + ": rename failed");
    }
}

// ---------------------------------------------------------------------------------------
// Shapes

/// Sum of random plane waves: a cheap, seedable, smooth displacement field (no lattice
/// noise tables; deterministic across platforms up to libm's sin).
class Waves {
public:
    Waves(uint64_t seed, int count, float base_freq, float gain) {
        std::mt19937_64 rng(seed);
        std::uniform_real_distribution<float> u(-1.0f, 1.0f), ph(0.0f, 6.2831853f);
        float f = base_freq, a = 1.0f;
        for (int i = 0; i < count; ++i) {
            V3 d;
            float l2;
            do {
                d = {u(rng), u(rng), u(rng)};
                l2 = d.x * d.x + d.y * d.y + d.z * d.z;
            } while (l2 > 1.0f || l2 < 1e-3f);
            const float l = std::sqrt(l2);
            waves_.push_back({d.x / l * f, d.y / l * f, d.z / l * f, ph(rng), a});
            norm_ += a;
            // Octaves every 3 waves: frequencies double, amplitudes fall by `gain`.
            if (i % 3 == 2) {
                f *= 2.0f;
                a *= gain;
            }
        }
    }
    /// In [-1, 1].
    float operator()(const V3& p) const {
        float s = 0;
        for (const W& w : waves_) s += w.a * std::sin(w.x * p.x + w.y * p.y + w.z * p.z + w.phase);
        return s / norm_;
    }

private:
    struct W {
        float x, y, z, phase, a;
    };
    std::vector<W> waves_;
    float norm_ = 0;
};

/// Cube-mapped sphere of 12 n^2 triangles (6 faces of n x n quads), radius 1 displaced
/// by `amp` * waves. Seam vertices are computed from identical cube coordinates on both
/// faces, so the surface is closed (no cracks) even though seam vertices are duplicated.
inline MeshData displaced_sphere(int n, const Waves& waves, float amp, const std::string& name) {
    MeshData m;
    m.name = name;
    const int v = n + 1;
    m.positions.reserve(size_t(6) * v * v);
    m.indices.reserve(size_t(36) * n * n);
    for (int face = 0; face < 6; ++face) {
        const uint32_t base = uint32_t(m.positions.size());
        for (int j = 0; j <= n; ++j)
            for (int i = 0; i <= n; ++i) {
                const float a = -1.0f + 2.0f * float(i) / float(n), b = -1.0f + 2.0f * float(j) / float(n);
                V3 c;
                switch (face) {
                    case 0: c = {1, b, -a}; break;
                    case 1: c = {-1, b, a}; break;
                    case 2: c = {a, 1, -b}; break;
                    case 3: c = {a, -1, b}; break;
                    case 4: c = {a, b, 1}; break;
                    default: c = {-a, b, -1}; break;
                }
                const float l = std::sqrt(c.x * c.x + c.y * c.y + c.z * c.z);
                V3 d{c.x / l, c.y / l, c.z / l};
                const float r = 1.0f + amp * waves(d);
                m.positions.push_back({d.x * r, d.y * r, d.z * r});
            }
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) {
                const uint32_t q = base + uint32_t(j * v + i);
                m.indices.insert(m.indices.end(), {q, q + 1, q + uint32_t(v) + 1, q, q + uint32_t(v) + 1, q + uint32_t(v)});
            }
    }
    return m;
}

/// Height field over [-1,1]^2 (y up) with rows x cols quads.
inline MeshData height_field(int rows, int cols, const Waves& waves, float amp, const std::string& name) {
    MeshData m;
    m.name = name;
    m.positions.reserve(size_t(rows + 1) * (cols + 1));
    m.indices.reserve(size_t(6) * rows * cols);
    for (int j = 0; j <= rows; ++j)
        for (int i = 0; i <= cols; ++i) {
            const float x = -1.0f + 2.0f * float(i) / float(cols), z = -1.0f + 2.0f * float(j) / float(rows);
            // Ridged fBm: 1 - |w| sharpens crests, like eroded mountains.
            const float w = waves({x, 0.37f * x - 0.21f * z, z});
            const float h = amp * (1.0f - std::fabs(w)) * (0.6f + 0.4f * x * x);
            m.positions.push_back({x, h, z});
        }
    const uint32_t v = uint32_t(cols + 1);
    for (int j = 0; j < rows; ++j)
        for (int i = 0; i < cols; ++i) {
            const uint32_t q = uint32_t(j) * v + uint32_t(i);
            m.indices.insert(m.indices.end(), {q, q + v, q + 1, q + 1, q + v, q + v + 1});
        }
    return m;
}

inline uint64_t ceil_div(uint64_t a, uint64_t b) { return (a + b - 1) / b; }

/// Builds the document of `kind` with at least `triangles` triangles after instancing
/// (and at most a few percent more; see each kind). Throws std::invalid_argument on a
/// bad kind or count.
inline Document generate(const std::string& kind, uint64_t triangles, uint64_t seed) {
    if (triangles < 12) throw std::invalid_argument("--triangles must be at least 12");
    // 2^28 elements is the glTF loader's scene budget; 60M triangles stays well inside it.
    if (triangles > 60'000'000ull) throw std::invalid_argument("--triangles must be at most 60000000");
    Document doc;
    if (kind == "sphere") {
        doc.materials.push_back({"stone", 0.7f, 0.7f, 0.65f});
        const int n = int(std::ceil(std::sqrt(double(triangles) / 12.0)));
        Waves w(seed, 24, 2.0f, 0.5f);
        doc.meshes.push_back(displaced_sphere(n, w, 0.15f, "displaced sphere"));
        doc.nodes.push_back({0});
    } else if (kind == "terrain") {
        doc.materials.push_back({"ground", 0.5f, 0.45f, 0.35f});
        const int n = int(std::ceil(std::sqrt(double(triangles) / 2.0)));
        Waves w(seed, 30, 1.5f, 0.55f);
        doc.meshes.push_back(height_field(n, n, w, 0.35f, "terrain"));
        doc.nodes.push_back({0});
    } else if (kind == "sliver") {
        // rows x cols quads on a unit sheet, cols ~ 1000 x rows: each triangle is about
        // 1000 times longer than wide.
        doc.materials.push_back({"sheet", 0.8f, 0.8f, 0.8f});
        const uint64_t quads = ceil_div(triangles, 2);
        const int rows = std::max(1, int(std::lround(std::sqrt(double(quads) / 1000.0))));
        const int cols = int(ceil_div(quads, uint64_t(rows)));
        MeshData m;
        m.name = "slivers";
        const float s = std::sqrt(0.5f), t = std::sqrt(1.0f / 3.0f);
        for (int j = 0; j <= rows; ++j)
            for (int i = 0; i <= cols; ++i) {
                const float u = -1.0f + 2.0f * float(i) / float(cols), v = -1.0f + 2.0f * float(j) / float(rows);
                // A gentle fold, then a rotation so the needles are diagonal to x, y and z.
                const float w = 0.2f * std::sin(3.0f * u + 1.7f * v);
                const V3 p{u, v, w};
                const V3 r1{s * (p.x - p.y), s * (p.x + p.y), p.z};       // 45 deg about z
                const float c = std::sqrt(1.0f - t * t);
                m.positions.push_back({r1.x, c * r1.y - t * r1.z, t * r1.y + c * r1.z});  // tilt about x
            }
        const uint32_t v = uint32_t(cols + 1);
        for (int j = 0; j < rows; ++j)
            for (int i = 0; i < cols; ++i) {
                const uint32_t q = uint32_t(j) * v + uint32_t(i);
                m.indices.insert(m.indices.end(), {q, q + v, q + 1, q + 1, q + v, q + v + 1});
            }
        doc.meshes.push_back(std::move(m));
        doc.nodes.push_back({0});
    } else if (kind == "field") {
        // Ground: two triangles 100 units across. Rocks: four prototypes of different
        // tessellation, instanced with log-uniform scales from 0.01 to 1 so triangle sizes
        // span five orders of magnitude (ground vs smallest rock facet).
        doc.materials.push_back({"ground", 0.45f, 0.5f, 0.35f});
        doc.materials.push_back({"rock", 0.6f, 0.58f, 0.55f});
        MeshData ground;
        ground.name = "ground";
        ground.positions = {{-50, 0, -50}, {50, 0, -50}, {50, 0, 50}, {-50, 0, 50}};
        ground.indices = {0, 2, 1, 0, 3, 2};
        doc.meshes.push_back(std::move(ground));
        doc.nodes.push_back({0});
        // At most ~4096 instances: more nodes than that measures per-geometry overhead,
        // not traversal; big counts raise the prototypes' tessellation instead.
        const uint64_t budget = triangles > 2 ? triangles - 2 : 1;
        const double per_instance = std::max(12.0, double(budget) / 4096.0);
        // Prototype k has 12 (n0 2^k)^2 triangles: sizes 1:4:16:64, picked uniformly, so
        // the mean is 21.25 x the smallest; n0 makes that mean about per_instance.
        const int n0 = std::max(1, int(std::lround(std::sqrt(per_instance / 21.25 / 12.0))));
        for (int k = 0; k < 4; ++k) {
            const int n = n0 << k;
            Waves w(seed * 31 + uint64_t(k), 12, 1.5f, 0.6f);
            MeshData rock = displaced_sphere(n, w, 0.35f, "rock" + std::to_string(k));
            rock.material = 1;
            doc.meshes.push_back(std::move(rock));
        }
        std::mt19937_64 rng(seed);
        std::uniform_real_distribution<float> u01(0.0f, 1.0f);
        uint64_t total = 2;
        while (total < triangles) {
            Node nd;
            int k = int(rng() % 4);
            // Near the target, smaller rocks, so the count overshoots by < 12 triangles.
            while (k > 0 && total + doc.meshes[size_t(1 + k)].triangles() > triangles) --k;
            nd.mesh = 1 + k;
            const float scale = std::pow(10.0f, -2.0f + 2.0f * u01(rng));
            const float ang = 6.2831853f * u01(rng);
            const float x = -45.0f + 90.0f * u01(rng), z = -45.0f + 90.0f * u01(rng);
            const float c = std::cos(ang) * scale, s = std::sin(ang) * scale;
            // Column-major: rotation about y, uniform scale, half-buried in the ground.
            nd.matrix = {c, 0, -s, 0, 0, scale, 0, 0, s, 0, c, 0, x, 0.4f * scale, z, 1};
            nd.identity = false;
            total += doc.meshes[size_t(nd.mesh)].triangles();
            doc.nodes.push_back(nd);
        }
    } else {
        throw std::invalid_argument("unknown --kind '" + kind + "' (sphere, terrain, field, sliver)");
    }
    return doc;
}

}  // namespace scenegen

#ifndef SCENEGEN_NO_MAIN
#include <CLI/CLI.hpp>

#include <chrono>

#include "tools/cli.h"
#include "tools/memory/memory.h"

int main(int argc, char** argv) {
    CLI::App app{"Procedural triangle meshes for benchmarks, written as binary glTF (.glb)."};
    std::string kind = "sphere", out;
    uint64_t triangles = 100000, seed = 1;
    app.add_option("--kind", kind, "sphere | terrain | field | sliver (default sphere)");
    app.add_option("--triangles,-n", triangles, "At least this many triangles after instancing (default 100000)");
    app.add_option("--seed", seed, "Random seed (default 1)");
    app.add_option("-o,--output", out, "Output .glb file")->required();
    tools::memory::install("scenegen");
    CLI11_PARSE(app, argc, argv);
    // Before any work: a mesh of millions of triangles is not made for a folder it
    // cannot be written to.
    if (const std::string why = tools::check_writable("-o", out); !why.empty()) {
        std::fprintf(stderr, "scenegen: error: %s\n", why.c_str());
        return 2;
    }
    try {
        const auto t0 = std::chrono::steady_clock::now();
        tools::memory::set_stage("generating the mesh");
        const scenegen::Document doc = scenegen::generate(kind, triangles, seed);
        tools::memory::set_stage("writing the file");
        scenegen::write_glb(out, doc);
        const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        std::printf("scenegen: wrote %s: %s, %llu triangles after instancing (%zu meshes, %zu nodes), %.2f s\n",
                    out.c_str(), kind.c_str(), (unsigned long long)doc.instanced_triangles(), doc.meshes.size(),
                    doc.nodes.size(), s);
    } catch (const std::bad_alloc& e) {
        tools::memory::out_of_memory(e);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "scenegen: error: %s\n", e.what());
        return 2;
    }
    return 0;
}
#endif
