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
//   forest  - a few hundred tree prototypes (an opaque trunk and alpha-masked leaf cards
//             each) placed up to 10^7 times by EXT_mesh_gpu_instancing: production-scale
//             instance counts, up to 10^11 instanced triangles in a file of a few hundred
//             MB, and cut-out geometry that alpha testing must see through.
//
// The GLB is written here, not by a library: a 12-byte header, a JSON chunk (padded with
// spaces) and a BIN chunk (padded with zeros); float32 VEC3 POSITION with min/max,
// uint32 SCALAR indices, float32 VEC2 TEXCOORD_0 where a mesh has uvs, float32 instance
// TRANSLATION/ROTATION/SCALE, and embedded PNG images. One buffer, one bufferView per
// accessor or image.
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

/// One mesh as it goes into the file: positions, triangle indices and optional uvs (two
/// floats per position).
struct MeshData {
    std::string name;
    std::vector<V3> positions;
    std::vector<uint32_t> indices;
    std::vector<float> uvs;
    int material = 0;
    /// Further primitives of the same glTF mesh (other materials), placed with it: a
    /// forest tree's leaves beside its trunk, so one placement is one instance.
    std::vector<MeshData> parts;
    uint64_t triangles() const {
        uint64_t n = indices.size() / 3;
        for (const MeshData& p : parts) n += p.triangles();
        return n;
    }
};

/// One instance's placement, as EXT_mesh_gpu_instancing stores it: translation, unit
/// rotation quaternion (x, y, z, w) and scale.
struct Trs {
    float t[3] = {0, 0, 0};
    float r[4] = {0, 0, 0, 1};
    float s[3] = {1, 1, 1};
};

/// A node instancing mesh `mesh` with a column-major 4x4 matrix (glTF convention), or,
/// with `instances` >= 0, once per placement of Document::instance_sets[instances]
/// (EXT_mesh_gpu_instancing; nodes that share a set share its accessors).
struct Node {
    int mesh = 0;
    std::array<float, 16> matrix{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    bool identity = true;
    int instances = -1;
};

struct MaterialData {
    std::string name;
    float r = 0.8f, g = 0.8f, b = 0.8f;
    int texture = -1;  ///< base colour texture: an index into Document::images
    bool mask = false;          ///< alphaMode MASK with alphaCutoff 0.5 (leaf cards)
    bool double_sided = false;  ///< glTF doubleSided (leaf cards)
};

struct Document {
    std::vector<MeshData> meshes;
    std::vector<Node> nodes;
    std::vector<MaterialData> materials;
    std::vector<std::vector<Trs>> instance_sets;
    std::vector<std::string> images;  ///< PNG files' bytes
    /// A perspective camera at `eye` looking at `target` (y up), written as the file's
    /// camera when `yfov` > 0 (radians).
    struct Camera {
        V3 eye, target;
        float yfov = 0;
    } camera;
    /// Placements of a node: 1, or its instance set's size.
    uint64_t placements(const Node& nd) const {
        return nd.instances < 0 ? 1 : instance_sets[size_t(nd.instances)].size();
    }
    /// Triangles a loader sees after instancing (each node contributes its mesh's, once
    /// per placement).
    uint64_t instanced_triangles() const {
        uint64_t n = 0;
        for (const Node& nd : nodes) n += meshes[size_t(nd.mesh)].triangles() * placements(nd);
        return n;
    }
    /// Distinct triangles stored in the file.
    uint64_t unique_triangles() const {
        uint64_t n = 0;
        for (const MeshData& m : meshes) n += m.triangles();
        return n;
    }
    /// Placed prototypes: a node without a set is one, and a set counts once however
    /// many nodes (a tree's trunk and leaves) share it.
    uint64_t instances() const {
        uint64_t n = 0;
        for (const Node& nd : nodes) n += nd.instances < 0;
        for (const std::vector<Trs>& set : instance_sets) n += set.size();
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
    int view_count = 0, accessor_count = 0;
    // Appends `bytes` bytes (4-aligned) as a new bufferView and returns its index.
    auto add_view = [&](const void* data, size_t bytes, int target) {
        while (bin.size() % 4) bin.push_back('\0');
        const size_t off = bin.size();
        bin.append(static_cast<const char*>(data), bytes);
        views << (view_count ? "," : "") << "{\"buffer\":0,\"byteOffset\":" << off << ",\"byteLength\":" << bytes;
        if (target) views << ",\"target\":" << target;
        views << "}";
        return view_count++;
    };
    // A float accessor over a new view of `count` elements of `type` ("VEC2", ...).
    auto add_floats = [&](const std::vector<float>& v, size_t count, const char* type, int target,
                          const std::string& minmax = "") {
        const int view = add_view(v.data(), v.size() * 4, target);
        accessors << (accessor_count ? "," : "") << "{\"bufferView\":" << view
                  << ",\"componentType\":5126,\"count\":" << count << ",\"type\":\"" << type << "\"" << minmax << "}";
        return accessor_count++;
    };
    // One primitive's accessors and its JSON object.
    auto primitive = [&](const MeshData& m) {
        if (m.positions.empty() || m.indices.empty()) throw std::invalid_argument("empty mesh " + m.name);
        for (uint32_t i : m.indices)
            if (i >= m.positions.size()) throw std::invalid_argument("index out of range in " + m.name);
        if (!m.uvs.empty() && m.uvs.size() != 2 * m.positions.size())
            throw std::invalid_argument("uv count mismatch in " + m.name);
        V3 lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
        std::vector<float> pos(m.positions.size() * 3);
        for (size_t i = 0; i < m.positions.size(); ++i) {
            const V3& p = m.positions[i];
            lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
            hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
            pos[3 * i] = p.x, pos[3 * i + 1] = p.y, pos[3 * i + 2] = p.z;
        }
        const int pa = add_floats(pos, m.positions.size(), "VEC3", 34962,
                                  ",\"min\":[" + fmt_float(lo.x) + "," + fmt_float(lo.y) + "," + fmt_float(lo.z) +
                                      "],\"max\":[" + fmt_float(hi.x) + "," + fmt_float(hi.y) + "," +
                                      fmt_float(hi.z) + "]");
        const int iv = add_view(m.indices.data(), m.indices.size() * 4, 34963);
        accessors << ",{\"bufferView\":" << iv << ",\"componentType\":5125,\"count\":" << m.indices.size()
                  << ",\"type\":\"SCALAR\"}";
        const int ia = accessor_count++;
        const int ua = m.uvs.empty() ? -1 : add_floats(m.uvs, m.positions.size(), "VEC2", 34962);
        std::ostringstream o;
        o << "{\"attributes\":{\"POSITION\":" << pa;
        if (ua >= 0) o << ",\"TEXCOORD_0\":" << ua;
        o << "},\"indices\":" << ia << ",\"material\":" << m.material << ",\"mode\":4}";
        return o.str();
    };
    for (size_t mi = 0; mi < doc.meshes.size(); ++mi) {
        const MeshData& m = doc.meshes[mi];
        meshes << (mi ? "," : "") << "{\"name\":\"" << json_escape(m.name) << "\",\"primitives\":[" << primitive(m);
        for (const MeshData& p : m.parts) meshes << "," << primitive(p);
        meshes << "]}";
    }
    // Instance sets: TRANSLATION, ROTATION, SCALE accessors, shared by the nodes using them.
    std::vector<int> set_accessor(doc.instance_sets.size());
    for (size_t k = 0; k < doc.instance_sets.size(); ++k) {
        const std::vector<Trs>& set = doc.instance_sets[k];
        if (set.empty()) throw std::invalid_argument("empty instance set");
        std::vector<float> t, r, sc;
        t.reserve(set.size() * 3), r.reserve(set.size() * 4), sc.reserve(set.size() * 3);
        for (const Trs& x : set) {
            t.insert(t.end(), x.t, x.t + 3);
            r.insert(r.end(), x.r, x.r + 4);
            sc.insert(sc.end(), x.s, x.s + 3);
        }
        set_accessor[k] = add_floats(t, set.size(), "VEC3", 0);
        add_floats(r, set.size(), "VEC4", 0);
        add_floats(sc, set.size(), "VEC3", 0);
    }
    std::vector<int> image_view;
    for (const std::string& png : doc.images) image_view.push_back(add_view(png.data(), png.size(), 0));
    while (bin.size() % 4) bin.push_back('\0');
    if (bin.size() >= (uint64_t(1) << 32) - 1024) throw std::length_error("GLB larger than 4 GiB");

    std::ostringstream js;
    js << "{\"asset\":{\"version\":\"2.0\",\"generator\":\"pathtracer scenegen\"},";
    if (!doc.instance_sets.empty()) js << "\"extensionsUsed\":[\"EXT_mesh_gpu_instancing\"],";
    const bool camera = doc.camera.yfov > 0;
    js << "\"scene\":0,\"scenes\":[{\"nodes\":[";
    for (size_t i = 0; i < doc.nodes.size() + (camera ? 1 : 0); ++i) js << (i ? "," : "") << i;
    js << "]}],\"nodes\":[";
    for (size_t i = 0; i < doc.nodes.size(); ++i) {
        const Node& n = doc.nodes[i];
        js << (i ? "," : "") << "{\"mesh\":" << n.mesh;
        if (!n.identity) {
            js << ",\"matrix\":[";
            for (int k = 0; k < 16; ++k) js << (k ? "," : "") << fmt_float(n.matrix[size_t(k)]);
            js << "]";
        }
        if (n.instances >= 0) {
            const int a = set_accessor[size_t(n.instances)];
            js << ",\"extensions\":{\"EXT_mesh_gpu_instancing\":{\"attributes\":{\"TRANSLATION\":" << a
               << ",\"ROTATION\":" << a + 1 << ",\"SCALE\":" << a + 2 << "}}}";
        }
        js << "}";
    }
    if (camera) {
        // The camera looks down its -z: the columns of its rotation are right, up and
        // back (from the target to the eye).
        const Document::Camera& c = doc.camera;
        V3 back{c.eye.x - c.target.x, c.eye.y - c.target.y, c.eye.z - c.target.z};
        auto normalise = [](V3 v) {
            const float l = std::sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
            return V3{v.x / l, v.y / l, v.z / l};
        };
        back = normalise(back);
        const V3 right = normalise({back.z, 0.0f, -back.x});  // (0, 1, 0) x back
        const V3 up{back.y * right.z - back.z * right.y, back.z * right.x - back.x * right.z,
                    back.x * right.y - back.y * right.x};
        const float m[16] = {right.x, right.y, right.z, 0, up.x, up.y, up.z, 0, back.x, back.y, back.z, 0,
                             c.eye.x, c.eye.y, c.eye.z, 1};
        js << (doc.nodes.empty() ? "" : ",") << "{\"camera\":0,\"matrix\":[";
        for (int k = 0; k < 16; ++k) js << (k ? "," : "") << fmt_float(m[k]);
        js << "]}";
    }
    js << "]";
    if (camera)
        js << ",\"cameras\":[{\"type\":\"perspective\",\"perspective\":{\"yfov\":" << fmt_float(doc.camera.yfov)
           << ",\"znear\":0.01}}]";
    js << ",\"materials\":[";
    for (size_t i = 0; i < doc.materials.size(); ++i) {
        const MaterialData& m = doc.materials[i];
        js << (i ? "," : "") << "{\"name\":\"" << json_escape(m.name)
           << "\",\"pbrMetallicRoughness\":{\"baseColorFactor\":[" << fmt_float(m.r) << "," << fmt_float(m.g)
           << "," << fmt_float(m.b) << ",1],\"metallicFactor\":0,\"roughnessFactor\":1";
        if (m.texture >= 0) js << ",\"baseColorTexture\":{\"index\":" << m.texture << "}";
        js << "}";
        if (m.mask) js << ",\"alphaMode\":\"MASK\",\"alphaCutoff\":0.5";
        if (m.double_sided) js << ",\"doubleSided\":true";
        js << "}";
    }
    js << "]";
    if (!doc.images.empty()) {
        js << ",\"samplers\":[{}],\"images\":[";
        for (size_t i = 0; i < doc.images.size(); ++i)
            js << (i ? "," : "") << "{\"bufferView\":" << image_view[i] << ",\"mimeType\":\"image/png\"}";
        js << "],\"textures\":[";
        for (size_t i = 0; i < doc.images.size(); ++i) js << (i ? "," : "") << "{\"source\":" << i << ",\"sampler\":0}";
        js << "]";
    }
    js << ",\"meshes\":[" << meshes.str() << "],\"accessors\":[" << accessors.str() << "],\"bufferViews\":["
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

/// An RGBA8 PNG of w x h pixels (row-major, 4 bytes each), its image data in stored
/// (uncompressed) deflate blocks: no compression library for a 16 KiB leaf (PNG
/// specification, ISO/IEC 15948; zlib and deflate framing, RFC 1950 and 1951).
inline std::string png_rgba(int w, int h, const std::vector<uint8_t>& rgba) {
    auto be32 = [](std::string& s, uint32_t v) {
        for (int k = 3; k >= 0; --k) s.push_back(char((v >> (8 * k)) & 255u));
    };
    auto crc32 = [](const std::string& bytes) {
        uint32_t c = 0xFFFFFFFFu;
        for (unsigned char b : bytes) {
            c ^= b;
            for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xEDB88320u & (0u - (c & 1u)));
        }
        return c ^ 0xFFFFFFFFu;
    };
    std::string raw;  // each row: filter type 0, then its pixels
    for (int y = 0; y < h; ++y) {
        raw.push_back('\0');
        raw.append(reinterpret_cast<const char*>(rgba.data()) + size_t(y) * size_t(w) * 4, size_t(w) * 4);
    }
    std::string z = "\x78\x01";
    uint32_t a = 1, b = 0;  // Adler-32
    for (unsigned char c : raw) a = (a + c) % 65521u, b = (b + a) % 65521u;
    for (size_t at = 0; at < raw.size() || at == 0; at += 65535) {
        const size_t n = std::min<size_t>(65535, raw.size() - at);
        z.push_back(char(at + n >= raw.size() ? 1 : 0));
        z.push_back(char(n & 255)), z.push_back(char(n >> 8));
        z.push_back(char(~n & 255)), z.push_back(char((~n >> 8) & 255));
        z.append(raw, at, n);
    }
    be32(z, (b << 16) | a);
    std::string out = "\x89PNG\r\n\x1a\n";
    auto chunk = [&](const char* type, const std::string& data) {
        be32(out, uint32_t(data.size()));
        const std::string body = type + data;
        out += body;
        be32(out, crc32(body));
    };
    std::string ihdr;
    be32(ihdr, uint32_t(w)), be32(ihdr, uint32_t(h));
    ihdr += std::string("\x08\x06\x00\x00\x00", 5);  // 8-bit RGBA, no interlace
    chunk("IHDR", ihdr);
    chunk("IDAT", z);
    chunk("IEND", "");
    return out;
}

/// A spray of leaves for the forest's cards, as production foliage cards carry: seven
/// pointed ellipses on a stem along the texture's v axis, opaque inside (greens varying
/// along each leaf, a paler vein), alpha 0 outside.
inline std::string leaf_png(int n) {
    std::vector<uint8_t> px(size_t(n) * size_t(n) * 4, 0);
    struct Leaf {
        float x, y, angle, length;
    };
    // Leaf bases along the stem (x = 0.5), alternating sides, shrinking toward the tip.
    const Leaf leaves[7] = {{0.5f, 0.95f, 0.0f, 0.32f},  {0.5f, 0.8f, -0.9f, 0.34f}, {0.5f, 0.68f, 0.9f, 0.33f},
                            {0.5f, 0.55f, -0.8f, 0.3f},  {0.5f, 0.43f, 0.8f, 0.28f}, {0.5f, 0.32f, -0.6f, 0.24f},
                            {0.5f, 0.24f, 0.6f, 0.22f}};
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
            const float px_u = (float(x) + 0.5f) / float(n), px_v = (float(y) + 0.5f) / float(n);
            uint8_t* p = &px[(size_t(y) * size_t(n) + size_t(x)) * 4];
            if (std::fabs(px_u - 0.5f) < 0.012f && px_v > 0.2f) {  // the stem
                p[0] = 90, p[1] = 70, p[2] = 40, p[3] = 255;
            }
            for (const Leaf& l : leaves) {
                // The leaf's own frame: `along` from its base toward its tip (up the
                // texture, turned by `angle`), `across` its width.
                const float dx = px_u - l.x, dy = l.y - px_v;
                const float c = std::cos(l.angle), s = std::sin(l.angle);
                const float along = (dx * s + dy * c) / l.length, across = (dx * c - dy * s) / l.length;
                if (along <= 0.0f || along >= 1.0f) continue;
                const float half = 0.3f * std::sin(3.14159265f * std::pow(along, 0.75f));
                if (std::fabs(across) >= half) continue;
                const bool vein = std::fabs(across) < 0.025f;
                p[0] = uint8_t(vein ? 120 : 35 + 45 * along);
                p[1] = uint8_t(vein ? 160 : 100 + 70 * (1.0f - std::fabs(across) / half) * (1.0f - 0.4f * along));
                p[2] = uint8_t(vein ? 60 : 25);
                p[3] = 255;
            }
        }
    return png_rgba(n, n, px);
}

/// Tree prototype k of roughly `triangles` triangles: a trunk (an 8-sided cylinder,
/// material 1) and leaf cards (quads with uvs over the leaf texture, material 2) filling
/// an ellipsoidal crown. Heights 4-12, crowns 1.5-4 across; y up, base at the origin.
inline void tree(uint64_t seed, uint64_t triangles, MeshData& trunk, MeshData& leaves) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<float> u01(0.0f, 1.0f);
    const float height = 4.0f + 8.0f * u01(rng), crown = 1.5f + 2.5f * u01(rng), radius = 0.04f * height;
    const int sides = 8;
    for (int k = 0; k <= sides; ++k) {
        const float a = 6.2831853f * float(k % sides) / float(sides);
        trunk.positions.push_back({radius * std::cos(a), 0.0f, radius * std::sin(a)});
        trunk.positions.push_back({0.6f * radius * std::cos(a), 0.85f * height, 0.6f * radius * std::sin(a)});
    }
    for (uint32_t k = 0; k < uint32_t(sides); ++k) {
        const uint32_t q = 2 * k;
        trunk.indices.insert(trunk.indices.end(), {q, q + 1, q + 2, q + 2, q + 1, q + 3});
    }
    trunk.material = 1;
    const uint64_t cards = std::max<uint64_t>(1, (triangles > 16 ? triangles - 16 : 2) / 2);
    // Cards of about the size that tiles the crown's surface a few times over.
    const float size = std::max(0.05f, 2.5f * crown / std::sqrt(float(cards)));
    const float cy = height - crown;
    for (uint64_t c = 0; c < cards; ++c) {
        V3 d;
        float l2;
        do {
            d = {2 * u01(rng) - 1, 2 * u01(rng) - 1, 2 * u01(rng) - 1};
            l2 = d.x * d.x + d.y * d.y + d.z * d.z;
        } while (l2 > 1.0f || l2 < 1e-4f);
        const V3 centre{crown * d.x, cy + 1.2f * crown * d.y, crown * d.z};
        // A random frame: the card's long side (the leaf's v) and its width.
        const float a = 6.2831853f * u01(rng), tilt = 1.2f * (u01(rng) - 0.5f);
        const V3 up{std::cos(a) * std::sin(tilt), std::cos(tilt), std::sin(a) * std::sin(tilt)};
        const V3 side{-std::sin(a), 0.0f, std::cos(a)};
        const uint32_t base = uint32_t(leaves.positions.size());
        for (int k = 0; k < 4; ++k) {
            const float su = (k == 1 || k == 2) ? 0.5f : -0.5f, sv = k >= 2 ? 1.0f : 0.0f;
            leaves.positions.push_back({centre.x + size * (su * side.x + sv * up.x),
                                        centre.y + size * (su * side.y + sv * up.y),
                                        centre.z + size * (su * side.z + sv * up.z)});
            leaves.uvs.insert(leaves.uvs.end(), {su + 0.5f, 1.0f - sv});
        }
        leaves.indices.insert(leaves.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
    }
    leaves.material = 2;
}

/// Builds the document of `kind` with at least `triangles` triangles after instancing
/// (and at most a few percent more; see each kind). Throws std::invalid_argument on a
/// bad kind or count.
inline Document generate(const std::string& kind, uint64_t triangles, uint64_t seed) {
    if (triangles < 12) throw std::invalid_argument("--triangles must be at least 12");
    // 2^28 elements is the glTF loader's scene budget for flattened meshes; 60M triangles
    // stays well inside it. A forest is meant to stay instanced: 10^11 triangles after
    // instancing from at most 10^7 placements.
    if (kind != "forest" && triangles > 60'000'000ull)
        throw std::invalid_argument("--triangles must be at most 60000000");
    if (triangles > 100'000'000'000ull) throw std::invalid_argument("--triangles must be at most 100000000000");
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
        std::vector<std::vector<Trs>> rocks(4);
        while (total < triangles) {
            int k = int(rng() % 4);
            // Near the target, smaller rocks, so the count overshoots by < 12 triangles.
            while (k > 0 && total + doc.meshes[size_t(1 + k)].triangles() > triangles) --k;
            const float scale = std::pow(10.0f, -2.0f + 2.0f * u01(rng));
            const float ang = 6.2831853f * u01(rng);
            const float x = -45.0f + 90.0f * u01(rng), z = -45.0f + 90.0f * u01(rng);
            // A turn about y, uniform scale, half-buried in the ground.
            Trs p;
            p.t[0] = x, p.t[1] = 0.4f * scale, p.t[2] = z;
            p.r[1] = std::sin(0.5f * ang), p.r[3] = std::cos(0.5f * ang);
            p.s[0] = p.s[1] = p.s[2] = scale;
            rocks[size_t(k)].push_back(p);
            total += doc.meshes[size_t(1 + k)].triangles();
        }
        // One node per rock prototype, placing it by EXT_mesh_gpu_instancing.
        for (int k = 0; k < 4; ++k) {
            if (rocks[size_t(k)].empty()) continue;
            doc.instance_sets.push_back(std::move(rocks[size_t(k)]));
            Node nd;
            nd.mesh = 1 + k;
            nd.instances = int(doc.instance_sets.size() - 1);
            doc.nodes.push_back(nd);
        }
    } else if (kind == "forest") {
        // A ground quad, and P tree prototypes of T triangles each placed I times in all,
        // I T >= triangles, P = min(256, I): T is 40 until I reaches 10^7 placements and
        // grows with the target beyond, so unique triangles are P / I of the instanced ones
        // (2.6e6 of 1e11 at the top).
        doc.materials.push_back({"ground", 0.35f, 0.3f, 0.2f});
        doc.materials.push_back({"bark", 0.3f, 0.22f, 0.15f});
        doc.materials.push_back({"leaf", 1.0f, 1.0f, 1.0f, 0, true, true});
        doc.images.push_back(leaf_png(128));
        constexpr uint64_t kMaxPlacements = 10'000'000, kPrototypes = 256;
        const uint64_t per_tree = std::max<uint64_t>(40, ceil_div(triangles, kMaxPlacements));
        const uint64_t placements = std::max<uint64_t>(1, ceil_div(triangles > 2 ? triangles - 2 : 1, per_tree));
        const uint64_t prototypes = std::min(kPrototypes, placements);
        // Trees about 5 apart on a square.
        const float side = 5.0f * std::sqrt(float(placements)), half = 0.5f * side;
        MeshData ground;
        ground.name = "ground";
        ground.positions = {{-half, 0, -half}, {half, 0, -half}, {half, 0, half}, {-half, 0, half}};
        ground.indices = {0, 2, 1, 0, 3, 2};
        doc.meshes.push_back(std::move(ground));
        doc.nodes.push_back({0});
        for (uint64_t k = 0; k < prototypes; ++k) {
            MeshData trunk, leaves;
            trunk.name = "tree" + std::to_string(k);
            leaves.name = "leaves" + std::to_string(k);
            tree(seed * 7919 + k, per_tree, trunk, leaves);
            trunk.parts.push_back(std::move(leaves));
            doc.meshes.push_back(std::move(trunk));
        }
        // Placements, each a prototype at random: a turn about y, a scale of 0.8-1.2
        // (a little taller or squatter).
        std::mt19937_64 rng(seed);
        std::uniform_real_distribution<float> u01(0.0f, 1.0f);
        std::vector<std::vector<Trs>> sets(prototypes);
        for (uint64_t i = 0; i < placements; ++i) {
            Trs p;
            p.t[0] = -half + side * u01(rng), p.t[2] = -half + side * u01(rng);
            const float ang = 6.2831853f * u01(rng), scale = 0.8f + 0.4f * u01(rng);
            p.r[1] = std::sin(0.5f * ang), p.r[3] = std::cos(0.5f * ang);
            p.s[0] = p.s[2] = scale, p.s[1] = scale * (0.9f + 0.2f * u01(rng));
            sets[rng() % prototypes].push_back(p);
        }
        // A camera a little above the trees, looking across the forest from its edge.
        doc.camera.eye = {0.0f, 9.0f, half + 20.0f};
        doc.camera.target = {0.0f, 4.0f, half - 25.0f};
        doc.camera.yfov = 0.7f;
        // One node per tree prototype, its mesh the trunk and the leaves (two primitives).
        for (uint64_t k = 0; k < prototypes; ++k) {
            if (sets[k].empty()) continue;
            doc.instance_sets.push_back(std::move(sets[k]));
            Node nd;
            nd.mesh = int(1 + k);
            nd.instances = int(doc.instance_sets.size() - 1);
            doc.nodes.push_back(nd);
        }
    } else {
        throw std::invalid_argument("unknown --kind '" + kind + "' (sphere, terrain, field, sliver, forest)");
    }
    return doc;
}

/// The same document with its alpha-masked materials written OPAQUE (the leaf cards then
/// stop rays as whole quads): the same trees and placements without the alpha test, to
/// measure what the test costs a backend (benchmarks/RESULTS.md, "Instances").
inline void opaque_cutouts(Document& doc) {
    for (MaterialData& m : doc.materials) m.mask = false;
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
    app.add_option("--kind", kind, "sphere | terrain | field | sliver | forest (default sphere)");
    app.add_option("--triangles,-n", triangles, "At least this many triangles after instancing (default 100000)");
    app.add_option("--seed", seed, "Random seed (default 1)");
    app.add_option("-o,--output", out, "Output .glb file")->required();
    bool opaque = false;
    app.add_flag("--opaque-cutouts", opaque,
                 "Write alpha-masked materials (the forest's leaf cards) OPAQUE: the same geometry without the alpha test");
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
        scenegen::Document doc = scenegen::generate(kind, triangles, seed);
        if (opaque) scenegen::opaque_cutouts(doc);
        tools::memory::set_stage("writing the file");
        scenegen::write_glb(out, doc);
        const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        std::printf("scenegen: wrote %s: %s, %llu triangles after instancing, %llu unique, %llu instances "
                    "(%zu meshes, %zu nodes), %.2f s\n",
                    out.c_str(), kind.c_str(), (unsigned long long)doc.instanced_triangles(),
                    (unsigned long long)doc.unique_triangles(), (unsigned long long)doc.instances(), doc.meshes.size(),
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
