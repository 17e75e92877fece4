// glTF 2.0 loader on top of tinygltf (parsing only). tinygltf trusts the file: it does
// not check buffer ranges, indices or node graphs, and its GLB chunk check is off by the
// chunk header. So every reference and byte range is validated here before it is read,
// and the raw bytes are pre-checked (GLB header, JSON nesting) before tinygltf sees them.
#include "scenes/gltf/gltf.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <tuple>
#include <utility>

#include <tiny_gltf.h>

#include "scenes/gltf/gltf_draco.h"
#include "scenes/image/image.h"

namespace scenes {
namespace {

using image::decode_texture;

// The bounds on unique geometry elements and on instances are GltfLimits (gltf.h):
// instancing lets a small file describe a huge scene, so what it may make us build is
// capped, unique geometry and placements apart.
/// Accessors without a bufferView (all zeros, possibly patched by sparse) are not
/// bounded by any buffer, so their count needs its own limit; real files use them only
/// for small sparse patches.
constexpr uint64_t kMaxUnbackedCount = uint64_t(1) << 20;
/// glTF needs about 8 levels; tinygltf converts extras/extensions recursively, so deeply
/// nested JSON would overflow the stack inside tinygltf.
constexpr int kMaxJsonDepth = 64;
constexpr uint64_t kMaxExternalFileBytes = uint64_t(1) << 31;

constexpr double kRadToDeg = 57.295779513082320876798;

const std::set<std::string>& supported_extensions() {
    static const std::set<std::string> s = {"EXT_mesh_gpu_instancing",
                                            "KHR_draco_mesh_compression",
                                            "KHR_lights_punctual",
                                            "KHR_materials_emissive_strength",
                                            "KHR_materials_ior",
                                            "KHR_materials_transmission",
                                            "KHR_materials_unlit",
                                            "KHR_mesh_quantization",
                                            "KHR_texture_transform"};
    return s;
}

std::string squote(const std::string& s) { return "'" + s + "'"; }

/// tinygltf messages for a user: one line, embedded base64 payloads elided (tinygltf
/// quotes whole data URIs, which can be megabytes), bounded length.
std::string one_line(std::string s) {
    for (size_t at = s.find("base64,"); at != std::string::npos; at = s.find("base64,", at + 7)) {
        size_t begin = at + 7, end = begin;
        while (end < s.size() && (std::isalnum(static_cast<unsigned char>(s[end])) || s[end] == '+' ||
                                  s[end] == '/' || s[end] == '='))
            ++end;
        if (end - begin > 16) s.replace(begin + 16, end - begin - 16, "...");
    }
    while (!s.empty() && (s.back() == '\n' || s.back() == '\r' || s.back() == ' ')) s.pop_back();
    for (char& c : s)
        if (c == '\n' || c == '\r') c = ';';
    if (s.size() > 400) s = s.substr(0, 400) + "...";
    return s;
}

uint32_t le32(const unsigned char* p) {
    return uint32_t(p[0]) | (uint32_t(p[1]) << 8) | (uint32_t(p[2]) << 16) | (uint32_t(p[3]) << 24);
}

// ---------------------------------------------------------------------------------------
// Byte-level pre-checks

/// Returns the GLB length to hand to tinygltf after checking the header and chunk table
/// against the real byte count.
uint32_t check_glb(const unsigned char* b, size_t n, const std::string& name) {
    auto fail = [&](const std::string& what) -> void { throw SceneError(name + ": " + what); };
    if (n < 12) fail("truncated GLB: " + std::to_string(n) + " bytes, the header alone needs 12");
    if (std::memcmp(b, "glTF", 4) != 0) fail("not a GLB file (bad magic)");
    uint32_t version = le32(b + 4), length = le32(b + 8);
    if (version != 2) fail("GLB container version " + std::to_string(version) + " not supported");
    if (length > n)
        fail("truncated GLB: header says " + std::to_string(length) + " bytes, got " +
             std::to_string(n));
    if (length < 20) fail("truncated GLB: no room for the JSON chunk header (length " +
                          std::to_string(length) + ")");
    uint64_t json_len = le32(b + 12);
    if (le32(b + 16) != 0x4E4F534Au) fail("GLB chunk 0 is not a JSON chunk");
    if (json_len == 0) fail("GLB JSON chunk is empty");
    uint64_t end = 20 + json_len;
    if (end > length)
        fail("truncated GLB: JSON chunk of " + std::to_string(json_len) +
             " bytes runs past the GLB length " + std::to_string(length));
    if (end < length) {
        if (length - end < 8)
            fail("truncated GLB: incomplete chunk header at byte " + std::to_string(end));
        uint64_t bin_len = le32(b + end);
        if (le32(b + end + 4) != 0x004E4942u) fail("GLB chunk 1 is not a BIN chunk");
        if (end + 8 + bin_len > length)
            fail("truncated GLB: BIN chunk of " + std::to_string(bin_len) +
                 " bytes runs past the GLB length " + std::to_string(length));
        if (bin_len < 4 || bin_len % 4 != 0)
            fail("GLB BIN chunk length " + std::to_string(bin_len) +
                 " is not a positive multiple of 4");
    }
    return length;
}

bool json_too_deep(const unsigned char* s, size_t n) {
    int depth = 0;
    bool in_string = false;
    for (size_t i = 0; i < n; ++i) {
        unsigned char c = s[i];
        if (in_string) {
            if (c == '\\') ++i;
            else if (c == '"') in_string = false;
        } else if (c == '"') {
            in_string = true;
        } else if (c == '[' || c == '{') {
            if (++depth > kMaxJsonDepth) return true;
        } else if ((c == ']' || c == '}') && depth > 0) {
            --depth;
        }
    }
    return false;
}

// ---------------------------------------------------------------------------------------
// tinygltf callbacks

struct FsContext {
    std::string base_dir;
};

bool fs_exists(const std::string& path, void* user) {
    // tinygltf also looks in the current directory; a file beside the process is not
    // part of the asset and must not silently stand in for a missing one.
    const auto* ctx = static_cast<const FsContext*>(user);
    if (!ctx->base_dir.empty() && path.compare(0, ctx->base_dir.size(), ctx->base_dir) != 0)
        return false;
    std::error_code ec;
    return std::filesystem::is_regular_file(path, ec);
}

std::string fs_expand(const std::string& path, void*) { return path; }  // no wordexp

bool fs_read(std::vector<unsigned char>* out, std::string* err, const std::string& path, void*) {
    std::string why;
    if (image::read_regular_file(path, kMaxExternalFileBytes, *out, why)) return true;
    if (err) *err = why;
    return false;
}

bool fs_write(std::string*, const std::string&, const std::vector<unsigned char>&, void*) {
    return false;
}

/// Keeps the encoded bytes instead of decoding: images are decoded later, only if a
/// material we model uses them. bufferView images get an unchecked pointer from
/// tinygltf, so those bytes are not touched here; they are read after validation.
bool defer_image(tinygltf::Image* image, const int, std::string*, std::string*, int, int,
                 const unsigned char* bytes, int size, void*) {
    if (image->bufferView < 0 && bytes != nullptr && size > 0) {
        image->image.assign(bytes, bytes + size);
        image->as_is = true;
    }
    return true;
}

// ---------------------------------------------------------------------------------------

int component_size(int ct) {
    switch (ct) {
        case TINYGLTF_COMPONENT_TYPE_BYTE:
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return 1;
        case TINYGLTF_COMPONENT_TYPE_SHORT:
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return 2;
        case TINYGLTF_COMPONENT_TYPE_INT:
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
        case TINYGLTF_COMPONENT_TYPE_FLOAT: return 4;
        default: return 0;
    }
}

int type_components(int type) {
    switch (type) {
        case TINYGLTF_TYPE_SCALAR: return 1;
        case TINYGLTF_TYPE_VEC2: return 2;
        case TINYGLTF_TYPE_VEC3: return 3;
        case TINYGLTF_TYPE_VEC4: return 4;
        case TINYGLTF_TYPE_MAT2: return 4;
        case TINYGLTF_TYPE_MAT3: return 9;
        case TINYGLTF_TYPE_MAT4: return 16;
        default: return 0;
    }
}

const char* type_name(int type) {
    switch (type) {
        case TINYGLTF_TYPE_SCALAR: return "SCALAR";
        case TINYGLTF_TYPE_VEC2: return "VEC2";
        case TINYGLTF_TYPE_VEC3: return "VEC3";
        case TINYGLTF_TYPE_VEC4: return "VEC4";
        case TINYGLTF_TYPE_MAT2: return "MAT2";
        case TINYGLTF_TYPE_MAT3: return "MAT3";
        case TINYGLTF_TYPE_MAT4: return "MAT4";
        default: return "unknown";
    }
}

const char* component_name(int ct) {
    switch (ct) {
        case TINYGLTF_COMPONENT_TYPE_BYTE: return "BYTE";
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return "UNSIGNED_BYTE";
        case TINYGLTF_COMPONENT_TYPE_SHORT: return "SHORT";
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return "UNSIGNED_SHORT";
        case TINYGLTF_COMPONENT_TYPE_INT: return "INT";
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: return "UNSIGNED_INT";
        case TINYGLTF_COMPONENT_TYPE_FLOAT: return "FLOAT";
        default: return "unknown";
    }
}

/// One component as float; normalized integers map to [0,1] / [-1,1] as the spec says.
float read_component(const unsigned char* p, int ct, bool normalized) {
    switch (ct) {
        case TINYGLTF_COMPONENT_TYPE_FLOAT: {
            float v;
            std::memcpy(&v, p, 4);
            return v;
        }
        case TINYGLTF_COMPONENT_TYPE_BYTE: {
            float v = float(int8_t(p[0]));
            return normalized ? std::max(v / 127.0f, -1.0f) : v;
        }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: {
            float v = float(p[0]);
            return normalized ? v / 255.0f : v;
        }
        case TINYGLTF_COMPONENT_TYPE_SHORT: {
            int16_t s;
            std::memcpy(&s, p, 2);
            return normalized ? std::max(float(s) / 32767.0f, -1.0f) : float(s);
        }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
            uint16_t s;
            std::memcpy(&s, p, 2);
            return normalized ? float(s) / 65535.0f : float(s);
        }
        default: return 0.0f;
    }
}

uint32_t read_index(const unsigned char* p, int ct) {
    switch (ct) {
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return p[0];
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
            uint16_t s;
            std::memcpy(&s, p, 2);
            return s;
        }
        default: {
            uint32_t v;
            std::memcpy(&v, p, 4);
            return v;
        }
    }
}

constexpr uint32_t ct_bit(int ct) { return 1u << (ct - TINYGLTF_COMPONENT_TYPE_BYTE); }
constexpr uint32_t kCtFloat = ct_bit(TINYGLTF_COMPONENT_TYPE_FLOAT);
constexpr uint32_t kCtByte = ct_bit(TINYGLTF_COMPONENT_TYPE_BYTE);
constexpr uint32_t kCtUByte = ct_bit(TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE);
constexpr uint32_t kCtShort = ct_bit(TINYGLTF_COMPONENT_TYPE_SHORT);
constexpr uint32_t kCtUShort = ct_bit(TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT);

/// Which component types an attribute may use (core spec + KHR_mesh_quantization) and
/// whether integer components must be normalized.
struct AttributeRule {
    const char* semantic;
    int type;
    uint32_t allowed;
    bool ints_must_be_normalized;
};
constexpr AttributeRule kPositionRule{"POSITION", TINYGLTF_TYPE_VEC3,
                                      kCtFloat | kCtByte | kCtUByte | kCtShort | kCtUShort, false};
constexpr AttributeRule kNormalRule{"NORMAL", TINYGLTF_TYPE_VEC3, kCtFloat | kCtByte | kCtShort,
                                    true};
constexpr AttributeRule kTexcoordRule{"TEXCOORD", TINYGLTF_TYPE_VEC2,
                                      kCtFloat | kCtByte | kCtUByte | kCtShort | kCtUShort, false};
/// COLOR_n: VEC3 or VEC4 (the type is the accessor's), float or normalized unsigned.
constexpr AttributeRule kColorRule3{"COLOR", TINYGLTF_TYPE_VEC3, kCtFloat | kCtUByte | kCtUShort, true};
constexpr AttributeRule kColorRule4{"COLOR", TINYGLTF_TYPE_VEC4, kCtFloat | kCtUByte | kCtUShort, true};

/// EXT_mesh_gpu_instancing's per-instance attributes: float, or with KHR_mesh_quantization
/// (which the extension's specification allows) 8- and 16-bit integers; a rotation's
/// integers must be normalized.
constexpr AttributeRule kInstanceTranslationRule{"TRANSLATION", TINYGLTF_TYPE_VEC3,
                                                 kCtFloat | kCtByte | kCtUByte | kCtShort | kCtUShort, false};
constexpr AttributeRule kInstanceRotationRule{"ROTATION", TINYGLTF_TYPE_VEC4, kCtFloat | kCtByte | kCtShort, true};
constexpr AttributeRule kInstanceScaleRule{"SCALE", TINYGLTF_TYPE_VEC3,
                                           kCtFloat | kCtByte | kCtUByte | kCtShort | kCtUShort, false};

/// KHR_texture_transform as an affine map of uv: u' = a*u + b*v + c, v' = d*u + e*v + f.
struct UvTransform {
    float a = 1, b = 0, c = 0, d = 0, e = 1, f = 0;
    bool identity() const { return a == 1 && b == 0 && c == 0 && d == 0 && e == 1 && f == 0; }
    bool operator!=(const UvTransform& o) const {
        return a != o.a || b != o.b || c != o.c || d != o.d || e != o.e || f != o.f;
    }
};

/// A material's one uv set and transform: those of the first texture it reads (base
/// colour, emissive, then the data maps). A later texture whose set or transform differs
/// is sampled with them, and `share` says so in a note naming the first.
struct MaterialUv {
    int set = -1;  ///< -1: no texture yet
    UvTransform xform;
    std::string owner;  ///< the slot that set them
    template <class Note>
    void share(const std::string& mdesc, const std::string& slot, int tc, const UvTransform& xf, Note&& note) {
        if (set < 0) {
            set = tc, xform = xf, owner = slot;
        } else if (set != tc) {
            note(mdesc + ": " + slot + " uses TEXCOORD_" + std::to_string(tc) + " but " + owner + " TEXCOORD_" +
                 std::to_string(set) + "; both sampled with the latter");
        } else if (xf != xform) {
            note(mdesc + ": " + slot + " has another KHR_texture_transform than " + owner +
                 "; both sampled with the latter");
        }
    }
};

struct DecodedPrimitive {
    bool skip = false;
    std::vector<Vec3f> positions;
    std::vector<Vec3f> normals;
    std::vector<Vec2f> uvs;
    std::vector<Vec3f> colors;  // COLOR_0, only when some vertex is not white
    std::vector<float> alphas;  // its alpha, only for MASK and BLEND, when some is below 1
    std::vector<uint32_t> triangles;
    uint32_t material = 0;
};

/// One EXT_mesh_gpu_instancing attribute, validated, read one instance at a time. A
/// plain accessor (a bufferView, no sparse) is read in place: at 10^7 instances, copying
/// the three attributes into floats first would take 400 MB beside the instances' own
/// 520 MB. A sparse or bufferView-less accessor is expanded by read_attribute (its size
/// is bounded by its bufferViews' bytes or by kMaxUnbackedCount).
struct InstanceAttribute {
    const unsigned char* data = nullptr;  // in place; null when `dense` holds the values
    size_t stride = 0, component_bytes = 0, components = 0, count = 0;
    int component_type = 0;
    bool normalized = false;
    std::vector<float> dense;
    std::string what;  // "accessor N (SEMANTIC of node ...)", for messages
    float get(size_t i, size_t c) const {
        return data ? read_component(data + i * stride + c * component_bytes, component_type, normalized)
                    : dense[i * components + c];
    }
};

class Loader {
public:
    Loader(const std::string& name, const tinygltf::Model& model, Scene& scene, const GltfLimits& limits)
        : name_(name), m_(model), scene_(scene), limits_(limits) {}

    void run();

private:
    [[noreturn]] void fail(const std::string& what) const {
        throw SceneError(name_ + ": " + what);
    }
    void note(const std::string& s) { scene_.notes.push_back(s); }

    std::string node_desc(int i) const {
        const std::string& n = m_.nodes[size_t(i)].name;
        return "node " + std::to_string(i) + (n.empty() ? "" : " (" + squote(n) + ")");
    }
    std::string mesh_desc(int mi) const {
        const std::string& n = m_.meshes[size_t(mi)].name;
        return n.empty() ? "mesh " + std::to_string(mi) : "mesh " + squote(n);
    }
    std::string material_desc(int mi) const {
        const std::string& n = m_.materials[size_t(mi)].name;
        return n.empty() ? "material " + std::to_string(mi) : "material " + squote(n);
    }
    std::string image_desc(int ii) const {
        const tinygltf::Image& im = m_.images[size_t(ii)];
        std::string s = "image " + std::to_string(ii);
        if (!im.uri.empty()) s += " (uri " + squote(im.uri) + ")";
        else if (!im.name.empty()) s += " (" + squote(im.name) + ")";
        return s;
    }

    void check_extensions();
    std::vector<int> root_nodes();
    void traverse(const std::vector<int>& roots);
    Mat4f local_matrix(int ni) const;
    void add_light(int ni, const Mat4f& world);
    void add_camera(int ni, const Mat4f& world);
    void add_mesh_instance(int ni, const Mat4f& world);
    void add_gpu_instances(int ni, const Mat4f& world, const tinygltf::Value& ext);
    // Instancing (see count_placements).
    void count_placements(const std::vector<int>& roots);
    uint64_t ext_placements(const tinygltf::Value& ext) const;
    uint64_t backed_count(double ai) const;
    bool placed_more_than_once(int mesh) const {
        return mesh >= 0 && size_t(mesh) < placements_.size() && placements_[size_t(mesh)] > 1;
    }
    uint32_t prototype(int mi, int ni);
    enum class Placed { Instance, Flattened, Dropped };
    Placed add_instance(int ni, const Mat4f& world);
    InstanceAttribute instance_attribute(int ai, const AttributeRule& rule, const std::string& user);
    void decode_draco_primitive(const tinygltf::Primitive& p, const std::string& pdesc,
                                const std::string& uv_semantic,
                                gltf_detail::DracoPrimitive& out);
    const DecodedPrimitive& decode_primitive(int mi, int pi);

    struct ViewBytes {
        const unsigned char* data;
        size_t size;
        size_t stride;
    };
    ViewBytes buffer_view(int bv, const std::string& user) const;
    const unsigned char* accessor_elements(const tinygltf::Accessor& a, const std::string& adesc, size_t elem_size,
                                           size_t& stride) const;
    template <class Store>
    void visit_accessor(int ai, const std::string& user, size_t& count, size_t elem_size,
                        Store&& store);
    const tinygltf::Accessor& accessor(int ai, const std::string& user) const;
    void check_attribute(const tinygltf::Accessor& a, int ai, const AttributeRule& rule,
                         const std::string& user) const;
    std::vector<float> read_attribute(int ai, const AttributeRule& rule, const std::string& user);
    std::vector<uint32_t> read_indices(int ai, const std::string& user);
    void read_colors(const tinygltf::Primitive& p, const std::string& pdesc, gltf_detail::DracoPrimitive* draco,
                     size_t nv, DecodedPrimitive& d);

    uint32_t material_index(int mi, const std::string& user);
    UvTransform texture_transform(const tinygltf::TextureInfo& ti, const std::string& desc,
                                  int& texcoord) const;
    int texture_image(int ti, const std::string& user) const;
    /// How texture `ti`'s sampler wraps and magnifies (scenes::Texture::wrap_s, wrap_t,
    /// magnify_nearest); glTF's default sampler repeats and filters.
    struct Sampling {
        TextureWrap s = TextureWrap::Repeat, t = TextureWrap::Repeat;
        bool magnify_nearest = false;
        auto key() const { return std::make_tuple(s, t, magnify_nearest); }
    };
    Sampling sampling(int ti, const std::string& user);
    /// Texture `ti` (its image and sampler) decoded for a slot that reads `channels` (see
    /// decode_texture); sRGB colour for base colour and emissive, linear data otherwise.
    uint32_t decoded_texture(int ti, const std::string& user, const char* channels = "RGBA", bool srgb = true);
    void read_pbr(const tinygltf::Material& g, const std::string& mdesc, Material& out, MaterialUv& uv);

    std::string name_;
    const tinygltf::Model& m_;
    Scene& scene_;
    GltfLimits limits_;

    std::map<std::pair<int, int>, DecodedPrimitive> primitives_;
    std::map<int, uint32_t> materials_;  // glTF material (-1 = default) -> scene material
    std::vector<int> material_uv_set_;   // per scene material, -1 = no texture used
    std::vector<UvTransform> material_uv_xform_;  // per scene material
    // (glTF image, channels read, sRGB, sampling) -> scene texture: an image two slots
    // read the same way through the same kind of sampler is decoded once.
    std::map<std::tuple<int, std::string, bool, std::tuple<TextureWrap, TextureWrap, bool>>, uint32_t> textures_;
    std::set<int> missing_data_images_;  // data maps whose file is missing (noted once)
    std::set<int> used_images_;          // images a modelled slot asked for
    std::set<std::string> ignored_material_features_;
    std::set<int> morphed_meshes_;  // meshes with morph targets, loaded in their base shape
    uint64_t elements_ = 0;
    uint64_t decoded_elements_ = 0;
    // Instancing. placements_[mesh]: how often the traversed scene places each glTF mesh
    // (pass 1); prototypes_[mesh]: its Prototype once built, kUnbuilt before, kEmpty when
    // it has no triangles; prototype_bounds_: each Prototype's object-space box.
    static constexpr uint32_t kUnbuilt = 0xFFFFFFFFu, kEmpty = 0xFFFFFFFEu;
    std::vector<uint64_t> placements_;
    std::vector<uint32_t> prototypes_;
    std::vector<Bounds3f> prototype_bounds_;
    uint64_t expected_instances_ = 0;  // pass 1's count, for one reserve
    uint64_t instancing_nodes_ = 0;    // nodes that placed at least one instance
    uint64_t ext_nodes_ = 0, ext_flattened_nodes_ = 0;  // EXT_mesh_gpu_instancing
    int cameras_seen_ = 0;
};

// ---------------------------------------------------------------------------------------

void Loader::check_extensions() {
    for (const std::string& e : m_.extensionsRequired)
        if (!supported_extensions().count(e))
            fail("required extension " + squote(e) + " is not supported");
    std::string ignored;
    for (const std::string& e : m_.extensionsUsed)
        if (!supported_extensions().count(e)) ignored += (ignored.empty() ? "" : ", ") + e;
    if (!ignored.empty()) note("glTF extensions ignored: " + ignored);
    const std::string& v = m_.asset.version;
    if (!v.empty() && v[0] != '2') fail("asset version " + squote(v) + " is not glTF 2.x");
}

std::vector<int> Loader::root_nodes() {
    const int nnodes = int(m_.nodes.size());
    for (int i = 0; i < nnodes; ++i)
        for (int c : m_.nodes[size_t(i)].children)
            if (c < 0 || c >= nnodes)
                fail(node_desc(i) + ": child " + std::to_string(c) + " does not exist");
    int si = m_.defaultScene;
    if (si >= 0 && size_t(si) >= m_.scenes.size())
        fail("default scene " + std::to_string(si) + " does not exist (" +
             std::to_string(m_.scenes.size()) + " scenes)");
    if (si < 0 && !m_.scenes.empty()) si = 0;
    if (si >= 0) {
        for (int n : m_.scenes[size_t(si)].nodes)
            if (n < 0 || n >= nnodes)
                fail("scene " + std::to_string(si) + ": node " + std::to_string(n) +
                     " does not exist");
        return m_.scenes[size_t(si)].nodes;
    }
    std::vector<bool> is_child(size_t(nnodes), false);
    for (const tinygltf::Node& n : m_.nodes)
        for (int c : n.children) is_child[size_t(c)] = true;
    std::vector<int> roots;
    for (int i = 0; i < nnodes; ++i)
        if (!is_child[size_t(i)]) roots.push_back(i);
    note("no scenes in the file: loaded all " + std::to_string(roots.size()) + " root nodes");
    return roots;
}

namespace {
/// The rotation of the quaternion (x, y, z, w), normalised first; false for a zero one.
bool rotation_matrix(double x, double y, double z, double w, Mat4f& rot) {
    const double len = std::sqrt(x * x + y * y + z * z + w * w);
    if (!(len > 0.0) || !std::isfinite(len)) return false;
    x /= len; y /= len; z /= len; w /= len;
    rot = Mat4f();
    rot.m[0][0] = float(1 - 2 * (y * y + z * z));
    rot.m[0][1] = float(2 * (x * y - z * w));
    rot.m[0][2] = float(2 * (x * z + y * w));
    rot.m[1][0] = float(2 * (x * y + z * w));
    rot.m[1][1] = float(1 - 2 * (x * x + z * z));
    rot.m[1][2] = float(2 * (y * z - x * w));
    rot.m[2][0] = float(2 * (x * z - y * w));
    rot.m[2][1] = float(2 * (y * z + x * w));
    rot.m[2][2] = float(1 - 2 * (x * x + y * y));
    return true;
}
}  // namespace

Mat4f Loader::local_matrix(int ni) const {
    const tinygltf::Node& n = m_.nodes[size_t(ni)];
    auto finite = [](const std::vector<double>& v) {
        return std::all_of(v.begin(), v.end(), [](double d) { return std::isfinite(d); });
    };
    Mat4f r;
    if (!n.matrix.empty()) {
        if (n.matrix.size() != 16) fail(node_desc(ni) + ": matrix must have 16 numbers");
        if (!finite(n.matrix)) fail(node_desc(ni) + ": matrix is not finite");
        // glTF stores column-major; Mat4f is m[row][col].
        for (int col = 0; col < 4; ++col)
            for (int row = 0; row < 4; ++row) r.m[row][col] = float(n.matrix[size_t(col * 4 + row)]);
        return r;
    }
    if (!n.translation.empty() && n.translation.size() != 3)
        fail(node_desc(ni) + ": translation must have 3 numbers");
    if (!n.rotation.empty() && n.rotation.size() != 4)
        fail(node_desc(ni) + ": rotation must have 4 numbers");
    if (!n.scale.empty() && n.scale.size() != 3) fail(node_desc(ni) + ": scale must have 3 numbers");
    if (!finite(n.translation) || !finite(n.rotation) || !finite(n.scale))
        fail(node_desc(ni) + ": translation/rotation/scale is not finite");
    Mat4f rot;
    if (!n.rotation.empty() &&
        !rotation_matrix(n.rotation[0], n.rotation[1], n.rotation[2], n.rotation[3], rot))
        fail(node_desc(ni) + ": rotation quaternion is zero");
    Mat4f t, s;
    if (!n.translation.empty())
        t = Mat4f::translate({float(n.translation[0]), float(n.translation[1]), float(n.translation[2])});
    if (!n.scale.empty()) s = Mat4f::scale({float(n.scale[0]), float(n.scale[1]), float(n.scale[2])});
    return t * rot * s;
}

/// Pass 1 of the instancing: how often the scene places each mesh, so that pass 2
/// (traverse) knows at a mesh's first placement whether to flatten it into world space
/// (placed once: the scene is what it was before instancing, bit for bit) or to make it a
/// prototype (placed more than once: glTF 2.0 spec 3.5, "Nodes and Hierarchy": several
/// nodes may reference one mesh; EXT_mesh_gpu_instancing places a node's mesh once per
/// instance). Nothing here fails: a node reached twice, or a bad extension, is refused by
/// traverse with its usual message; the counts only have to be right for a valid file.
void Loader::count_placements(const std::vector<int>& roots) {
    placements_.assign(m_.meshes.size(), 0);
    prototypes_.assign(m_.meshes.size(), kUnbuilt);
    std::vector<bool> seen(m_.nodes.size(), false);
    std::vector<int> stack(roots.rbegin(), roots.rend());  // child indices checked by root_nodes
    while (!stack.empty()) {
        const int ni = stack.back();
        stack.pop_back();
        if (seen[size_t(ni)]) continue;
        seen[size_t(ni)] = true;
        const tinygltf::Node& n = m_.nodes[size_t(ni)];
        if (n.mesh >= 0 && size_t(n.mesh) < m_.meshes.size()) {
            const auto ext = n.extensions.find("EXT_mesh_gpu_instancing");
            const uint64_t k = ext == n.extensions.end() ? 1 : ext_placements(ext->second);
            uint64_t& p = placements_[size_t(n.mesh)];
            p = std::min(p + k, uint64_t(1) << 62);  // saturating: every k is below 2^61
        }
        for (int c : n.children) stack.push_back(c);
    }
    for (uint64_t p : placements_)
        if (p > 1) expected_instances_ += p;
}

/// The instances an EXT_mesh_gpu_instancing object places, as far as its accessors'
/// bytes allow (the smallest of its attributes' counts); 1 when it names no usable
/// accessor, which traverse then refuses.
uint64_t Loader::ext_placements(const tinygltf::Value& ext) const {
    if (!ext.IsObject() || !ext.Has("attributes") || !ext.Get("attributes").IsObject()) return 1;
    const tinygltf::Value& attrs = ext.Get("attributes");
    uint64_t k = std::numeric_limits<uint64_t>::max();
    for (const char* sem : {"TRANSLATION", "ROTATION", "SCALE"})
        if (attrs.Has(sem) && attrs.Get(sem).IsNumber())
            k = std::min(k, backed_count(attrs.Get(sem).GetNumberAsDouble()));
    return k == std::numeric_limits<uint64_t>::max() ? 1 : k;
}

/// An accessor's count, bounded by the bytes that back it (the range check of
/// visit_accessor, without failing): a count the file claims but cannot hold does not
/// reserve memory. Accessors without a bufferView are bounded by kMaxUnbackedCount.
uint64_t Loader::backed_count(double ad) const {
    if (!(ad >= 0.0) || ad != std::floor(ad) || ad >= double(m_.accessors.size())) return 0;
    const tinygltf::Accessor& a = m_.accessors[size_t(ad)];
    const size_t elem = size_t(type_components(a.type)) * size_t(component_size(a.componentType));
    if (elem == 0) return 0;
    if (a.bufferView < 0) return std::min<uint64_t>(a.count, kMaxUnbackedCount);
    if (size_t(a.bufferView) >= m_.bufferViews.size()) return 0;
    const tinygltf::BufferView& bv = m_.bufferViews[size_t(a.bufferView)];
    if (bv.buffer < 0 || size_t(bv.buffer) >= m_.buffers.size()) return 0;
    const size_t bytes = m_.buffers[size_t(bv.buffer)].data.size();
    if (bv.byteOffset > bytes || bv.byteLength > bytes - bv.byteOffset) return 0;
    const size_t stride = bv.byteStride ? bv.byteStride : elem;
    if (stride < elem || a.byteOffset > bv.byteLength || elem > bv.byteLength - a.byteOffset) return 0;
    return std::min<uint64_t>(a.count, (bv.byteLength - a.byteOffset - elem) / stride + 1);
}

void Loader::traverse(const std::vector<int>& roots) {
    // Iterative DFS: a hostile hierarchy can be deep enough to overflow a recursive walk.
    // Each node may be reached once; a second visit is a cycle or a node with two
    // parents, both invalid glTF (and the latter could multiply instances exponentially).
    std::vector<bool> visited(m_.nodes.size(), false);
    struct Item {
        int node;
        Mat4f parent;
    };
    std::vector<Item> stack;
    for (auto it = roots.rbegin(); it != roots.rend(); ++it) stack.push_back({*it, Mat4f()});
    while (!stack.empty()) {
        Item item = stack.back();
        stack.pop_back();
        const int ni = item.node;
        if (visited[size_t(ni)])
            fail(node_desc(ni) + " is reached twice in the node hierarchy (cycle or two parents)");
        visited[size_t(ni)] = true;
        Mat4f world = item.parent * local_matrix(ni);
        for (int r = 0; r < 4; ++r)
            for (int c = 0; c < 4; ++c)
                if (!std::isfinite(world.m[r][c]))
                    fail(node_desc(ni) + ": world transform is not finite");
        const tinygltf::Node& n = m_.nodes[size_t(ni)];
        if (n.mesh != -1) {
            const auto inst = n.extensions.find("EXT_mesh_gpu_instancing");
            if (inst != n.extensions.end()) {
                add_gpu_instances(ni, world, inst->second);
            } else if (placed_more_than_once(n.mesh)) {
                const Placed p = add_instance(ni, world);
                if (p == Placed::Instance) ++instancing_nodes_;
                if (p == Placed::Dropped)
                    note(node_desc(ni) + ": singular or non-finite transform; its instance of " + mesh_desc(n.mesh) +
                         " dropped");
            } else {
                add_mesh_instance(ni, world);
            }
        }
        if (n.camera != -1) add_camera(ni, world);
        add_light(ni, world);
        if (n.skin != -1 && n.mesh != -1)
            note(node_desc(ni) + ": skin ignored, mesh loaded in its bind pose");
        const auto& ch = n.children;
        for (auto it = ch.rbegin(); it != ch.rend(); ++it) stack.push_back({*it, world});
    }
}

void Loader::add_camera(int ni, const Mat4f& world) {
    const tinygltf::Node& n = m_.nodes[size_t(ni)];
    if (n.camera < 0 || size_t(n.camera) >= m_.cameras.size())
        fail(node_desc(ni) + ": camera " + std::to_string(n.camera) + " does not exist");
    const tinygltf::Camera& c = m_.cameras[size_t(n.camera)];
    std::string cdesc = "camera " + std::to_string(n.camera) + (c.name.empty() ? "" : " (" + squote(c.name) + ")");
    if (c.type != "perspective" && c.type != "orthographic") {
        note(cdesc + ": " + (c.type.empty() ? std::string("untyped") : c.type) +
             " camera skipped (only perspective and orthographic cameras are supported)");
        return;
    }
    ++cameras_seen_;
    if (scene_.camera) {
        if (cameras_seen_ == 2) note("several cameras in the scene: using the first, " + squote(scene_.camera->name));
        return;
    }
    if (c.type == "orthographic") {
        // xmag and ymag are the view's half extents; the specification asks for them
        // non-zero (a negative one mirrors nothing we model: its size is what counts).
        const tinygltf::OrthographicCamera& o = c.orthographic;
        if (!std::isfinite(o.xmag) || !std::isfinite(o.ymag) || o.xmag == 0.0 || o.ymag == 0.0)
            fail(cdesc + ": orthographic xmag and ymag must be finite and non-zero");
        Camera cam;
        cam.name = !c.name.empty() ? c.name : (!n.name.empty() ? n.name : "camera " + std::to_string(n.camera));
        cam.camera_to_world = world;
        cam.orthographic = true;
        cam.xmag = float(std::abs(o.xmag));
        cam.ymag = float(std::abs(o.ymag));
        cam.aspect = cam.xmag / cam.ymag;
        scene_.camera = cam;
        return;
    }
    const tinygltf::PerspectiveCamera& p = c.perspective;
    if (!std::isfinite(p.yfov) || !(p.yfov > 0.0) || !(p.yfov < 3.14159265358979))
        fail(cdesc + ": yfov " + std::to_string(p.yfov) + " is not in (0, pi)");
    if (!std::isfinite(p.aspectRatio) || p.aspectRatio < 0.0)
        fail(cdesc + ": aspectRatio is invalid");
    Camera cam;
    cam.name = !c.name.empty() ? c.name : (!n.name.empty() ? n.name : "camera " + std::to_string(n.camera));
    cam.camera_to_world = world;
    cam.yfov_deg = float(p.yfov * kRadToDeg);
    cam.aspect = float(p.aspectRatio);
    cam.xfov_deg = p.aspectRatio > 0.0
                       ? float(2.0 * std::atan(std::tan(p.yfov / 2.0) * p.aspectRatio) * kRadToDeg)
                       : 0.0f;
    if (std::isfinite(p.znear) && p.znear > 0.0) cam.znear = float(p.znear);
    if (std::isfinite(p.zfar) && p.zfar > cam.znear) cam.zfar = float(p.zfar);
    scene_.camera = cam;
}

void Loader::add_light(int ni, const Mat4f& world) {
    const tinygltf::Node& n = m_.nodes[size_t(ni)];
    auto ext = n.extensions.find("KHR_lights_punctual");
    if (ext == n.extensions.end()) return;
    const tinygltf::Value& v = ext->second;
    if (!v.IsObject() || !v.Has("light") || !v.Get("light").IsNumber())
        fail(node_desc(ni) + ": KHR_lights_punctual has no light index");
    double ld = v.Get("light").GetNumberAsDouble();
    if (!(ld >= 0.0) || ld >= double(m_.lights.size()) || ld != std::floor(ld))
        fail(node_desc(ni) + ": light " + std::to_string(ld) + " does not exist (" +
             std::to_string(m_.lights.size()) + " lights)");
    const int li = int(ld);
    const tinygltf::Light& l = m_.lights[size_t(li)];
    std::string ldesc = "light " + std::to_string(li) + (l.name.empty() ? "" : " (" + squote(l.name) + ")");
    Vec3f color{1.0f, 1.0f, 1.0f};
    if (!l.color.empty()) {
        if (l.color.size() != 3) fail(ldesc + ": color must have 3 numbers");
        color = Vec3f{float(l.color[0]), float(l.color[1]), float(l.color[2])};
    }
    if (!is_finite(color) || color.x < 0 || color.y < 0 || color.z < 0 ||
        !std::isfinite(l.intensity) || l.intensity < 0)
        fail(ldesc + ": color/intensity must be finite and non-negative");
    Light out;
    out.name = !l.name.empty() ? l.name : (!n.name.empty() ? n.name : "light " + std::to_string(li));
    out.radiance = color * float(l.intensity);
    out.position = world.transform_point(Vec3f{0, 0, 0});
    Vec3f dir = world.transform_vector(Vec3f{0, 0, -1});
    float len = length(dir);
    if (l.type == "point") {
        out.type = LightType::Point;
    } else if (l.type == "directional" || l.type == "spot") {
        if (!(len > 0.0f) || !std::isfinite(len)) fail(node_desc(ni) + ": light direction is degenerate");
        out.direction = dir / len;
        out.type = l.type == "spot" ? LightType::Spot : LightType::Directional;
        if (out.type == LightType::Spot) {
            double inner = l.spot.innerConeAngle, outer = l.spot.outerConeAngle;
            if (!std::isfinite(inner) || !std::isfinite(outer))
                fail(ldesc + ": spot cone angles are not finite");
            double cl_outer = std::clamp(outer, 0.0, 1.5707963267948966);
            double cl_inner = std::clamp(inner, 0.0, cl_outer);
            if (cl_outer != outer || cl_inner != inner)
                note(ldesc + ": spot cone angles clamped to 0 <= inner <= outer <= pi/2");
            out.spot_cos_inner = float(std::cos(cl_inner));
            out.spot_cos_outer = float(std::cos(cl_outer));
        }
    } else {
        note(ldesc + ": unknown light type " + squote(l.type) + " skipped");
        return;
    }
    if (l.range > 0.0) note(ldesc + ": range " + std::to_string(l.range) + " ignored (lights fall off as 1/r^2 without cut-off)");
    scene_.lights.push_back(out);
}

// ---------------------------------------------------------------------------------------
// Accessors

Loader::ViewBytes Loader::buffer_view(int bvi, const std::string& user) const {
    if (bvi < 0 || size_t(bvi) >= m_.bufferViews.size())
        fail(user + ": bufferView " + std::to_string(bvi) + " does not exist");
    const tinygltf::BufferView& bv = m_.bufferViews[size_t(bvi)];
    std::string bdesc = "bufferView " + std::to_string(bvi);
    if (bv.buffer < 0 || size_t(bv.buffer) >= m_.buffers.size())
        fail(bdesc + ": buffer " + std::to_string(bv.buffer) + " does not exist");
    const tinygltf::Buffer& b = m_.buffers[size_t(bv.buffer)];
    if (bv.byteOffset > b.data.size() || bv.byteLength > b.data.size() - bv.byteOffset)
        fail(bdesc + ": bytes [" + std::to_string(bv.byteOffset) + ", +" +
             std::to_string(bv.byteLength) + ") exceed buffer " + std::to_string(bv.buffer) +
             (b.uri.empty() || tinygltf::IsDataURI(b.uri) ? "" : " (uri " + squote(b.uri) + ")") +
             " of " + std::to_string(b.data.size()) + " bytes");
    return {b.data.data() + bv.byteOffset, bv.byteLength, bv.byteStride};
}

const tinygltf::Accessor& Loader::accessor(int ai, const std::string& user) const {
    if (ai < 0 || size_t(ai) >= m_.accessors.size())
        fail(user + ": accessor " + std::to_string(ai) + " does not exist");
    return m_.accessors[size_t(ai)];
}

/// The first element of an accessor with a bufferView, and the stride, once all of its
/// `a.count` elements of `elem_size` bytes are known to fit in the bufferView.
const unsigned char* Loader::accessor_elements(const tinygltf::Accessor& a, const std::string& adesc,
                                               size_t elem_size, size_t& stride) const {
    ViewBytes v = buffer_view(a.bufferView, adesc);
    stride = v.stride ? v.stride : elem_size;
    if (stride < elem_size)
        fail("bufferView " + std::to_string(a.bufferView) + ": byteStride " + std::to_string(stride) +
             " is smaller than an element of " + adesc);
    const size_t count = a.count;
    if (count > 0) {
        if (a.byteOffset > v.size || elem_size > v.size - a.byteOffset ||
            (count - 1) > (v.size - a.byteOffset - elem_size) / stride)
            fail(adesc + ": " + std::to_string(count) + " elements (stride " + std::to_string(stride) +
                 ", offset " + std::to_string(a.byteOffset) + ") do not fit in bufferView " +
                 std::to_string(a.bufferView) + " of " + std::to_string(v.size) + " bytes");
        return v.data + a.byteOffset;
    }
    return v.data;
}

/// Calls store(i, bytes) for every element in order, then again for each sparse
/// substitution. All ranges are checked before the first byte is read.
template <class Store>
void Loader::visit_accessor(int ai, const std::string& user, size_t& count, size_t elem_size,
                            Store&& store) {
    const tinygltf::Accessor& a = accessor(ai, user);
    const std::string adesc = "accessor " + std::to_string(ai);
    count = a.count;
    if (a.bufferView >= 0) {
        size_t stride = 0;
        const unsigned char* first = accessor_elements(a, adesc, elem_size, stride);
        for (size_t i = 0; i < count; ++i) store(i, first + i * stride);
    } else {
        if (count > kMaxUnbackedCount)
            fail(adesc + ": count " + std::to_string(count) + " without a bufferView is too large");
        static const unsigned char zeros[64] = {};
        for (size_t i = 0; i < count; ++i) store(i, zeros);
    }
    if (!a.sparse.isSparse) return;
    const auto& sp = a.sparse;
    if (sp.count < 1 || size_t(sp.count) > count)
        fail(adesc + ": sparse count " + std::to_string(sp.count) + " not in [1, " +
             std::to_string(count) + "]");
    const int ict = sp.indices.componentType;
    if (ict != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE && ict != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
        ict != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)
        fail(adesc + ": sparse indices component type " + std::to_string(ict) + " not allowed");
    if (sp.indices.byteOffset < 0 || sp.values.byteOffset < 0)
        fail(adesc + ": negative sparse byteOffset");
    const size_t n = size_t(sp.count), isz = size_t(component_size(ict));
    ViewBytes iv = buffer_view(sp.indices.bufferView, adesc + " sparse indices");
    ViewBytes vv = buffer_view(sp.values.bufferView, adesc + " sparse values");
    if (size_t(sp.indices.byteOffset) > iv.size || n > (iv.size - size_t(sp.indices.byteOffset)) / isz)
        fail(adesc + ": sparse indices do not fit in bufferView " + std::to_string(sp.indices.bufferView));
    if (size_t(sp.values.byteOffset) > vv.size || n > (vv.size - size_t(sp.values.byteOffset)) / elem_size)
        fail(adesc + ": sparse values do not fit in bufferView " + std::to_string(sp.values.bufferView));
    for (size_t k = 0; k < n; ++k) {
        uint32_t idx = read_index(iv.data + size_t(sp.indices.byteOffset) + k * isz, ict);
        if (idx >= count)
            fail(adesc + ": sparse index " + std::to_string(idx) + " out of range (count " +
                 std::to_string(count) + ")");
        store(idx, vv.data + size_t(sp.values.byteOffset) + k * elem_size);
    }
}

void Loader::check_attribute(const tinygltf::Accessor& a, int ai, const AttributeRule& rule,
                             const std::string& user) const {
    const std::string adesc = "accessor " + std::to_string(ai);
    if (a.type != rule.type)
        fail(adesc + " (" + rule.semantic + " of " + user + "): type " + type_name(a.type) +
             ", expected " + type_name(rule.type));
    const int ct = a.componentType;
    if (component_size(ct) == 0 || ct == TINYGLTF_COMPONENT_TYPE_INT || !(rule.allowed & ct_bit(ct)))
        fail(adesc + " (" + rule.semantic + " of " + user + "): component type " +
             component_name(ct) + " not allowed");
    if (ct != TINYGLTF_COMPONENT_TYPE_FLOAT && rule.ints_must_be_normalized && !a.normalized)
        fail(adesc + " (" + rule.semantic + " of " + user + "): integer components must be normalized");
}

std::vector<float> Loader::read_attribute(int ai, const AttributeRule& rule, const std::string& user) {
    const tinygltf::Accessor& a = accessor(ai, user);
    const std::string adesc = "accessor " + std::to_string(ai);
    check_attribute(a, ai, rule, user);
    const int ct = a.componentType;
    const size_t nc = size_t(type_components(rule.type)), cs = size_t(component_size(ct));
    std::vector<float> out;
    size_t count = 0;
    bool sized = false;
    visit_accessor(ai, user, count, nc * cs, [&](size_t i, const unsigned char* p) {
        if (!sized) {  // allocate only once the ranges have been validated
            out.resize(count * nc);
            sized = true;
        }
        for (size_t c = 0; c < nc; ++c) {
            float v = read_component(p + c * cs, ct, a.normalized);
            if (!std::isfinite(v))
                fail(adesc + " (" + rule.semantic + " of " + user + "): element " +
                     std::to_string(i) + " is not finite");
            out[i * nc + c] = v;
        }
    });
    return out;
}

InstanceAttribute Loader::instance_attribute(int ai, const AttributeRule& rule, const std::string& user) {
    const tinygltf::Accessor& a = accessor(ai, user);
    InstanceAttribute r;
    r.what = "accessor " + std::to_string(ai) + " (" + rule.semantic + " of " + user + ")";
    r.components = size_t(type_components(rule.type));
    if (a.bufferView < 0 || a.sparse.isSparse) {
        r.dense = read_attribute(ai, rule, user);
        r.count = r.dense.size() / r.components;
        return r;
    }
    check_attribute(a, ai, rule, user);
    r.component_type = a.componentType;
    r.normalized = a.normalized;
    r.component_bytes = size_t(component_size(a.componentType));
    r.data = accessor_elements(a, "accessor " + std::to_string(ai), r.components * r.component_bytes, r.stride);
    r.count = a.count;
    return r;
}

std::vector<uint32_t> Loader::read_indices(int ai, const std::string& user) {
    const tinygltf::Accessor& a = accessor(ai, user);
    const std::string adesc = "accessor " + std::to_string(ai);
    if (a.type != TINYGLTF_TYPE_SCALAR)
        fail(adesc + " (indices of " + user + "): type " + type_name(a.type) + ", expected SCALAR");
    const int ct = a.componentType;
    if (ct != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE && ct != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
        ct != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)
        fail(adesc + " (indices of " + user + "): component type " + component_name(ct) + " not allowed");
    std::vector<uint32_t> out;
    size_t count = 0;
    bool sized = false;
    visit_accessor(ai, user, count, size_t(component_size(ct)), [&](size_t i, const unsigned char* p) {
        if (!sized) {
            out.resize(count);
            sized = true;
        }
        out[i] = read_index(p, ct);
    });
    return out;
}

// ---------------------------------------------------------------------------------------
// Materials and textures

int Loader::texture_image(int ti, const std::string& user) const {
    if (ti < 0 || size_t(ti) >= m_.textures.size())
        fail(user + ": texture " + std::to_string(ti) + " does not exist");
    const tinygltf::Texture& t = m_.textures[size_t(ti)];
    if (t.source < 0)
        fail(user + ": texture " + std::to_string(ti) +
             " has no source image (extension-only image formats are not supported)");
    if (size_t(t.source) >= m_.images.size())
        fail(user + ": texture " + std::to_string(ti) + ": image " + std::to_string(t.source) +
             " does not exist");
    return t.source;
}

/// The sampler's wraps and magnification filter, which the lookups follow
/// (renderer/texture.h). minFilter is not read: every lookup is filtered by its footprint
/// on the MIP pyramid, which is what its mipmapped values ask for and better than what
/// the others (a level-0 read, aliasing when minified) would give.
Loader::Sampling Loader::sampling(int ti, const std::string& user) {
    Sampling out;
    const int si = m_.textures[size_t(ti)].sampler;
    if (si < 0) return out;
    if (size_t(si) >= m_.samplers.size())
        fail(user + ": texture " + std::to_string(ti) + ": sampler " + std::to_string(si) + " does not exist");
    const tinygltf::Sampler& s = m_.samplers[size_t(si)];
    const auto wrap = [&](int w, const char* axis) {
        switch (w) {
            case TINYGLTF_TEXTURE_WRAP_REPEAT: return TextureWrap::Repeat;
            case TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE: return TextureWrap::ClampToEdge;
            case TINYGLTF_TEXTURE_WRAP_MIRRORED_REPEAT: return TextureWrap::MirroredRepeat;
        }
        note(user + ": sampler " + std::to_string(si) + ": " + axis + " " + std::to_string(w) +
             " is not a glTF wrap mode; the texture repeats");
        return TextureWrap::Repeat;
    };
    out.s = wrap(s.wrapS, "wrapS");
    out.t = wrap(s.wrapT, "wrapT");
    out.magnify_nearest = s.magFilter == TINYGLTF_TEXTURE_FILTER_NEAREST;
    return out;
}

uint32_t Loader::decoded_texture(int ti, const std::string& user, const char* channels, bool srgb) {
    const int ii = texture_image(ti, user);
    const Sampling smp = sampling(ti, user);
    used_images_.insert(ii);
    const auto key = std::make_tuple(ii, std::string(channels), srgb, smp.key());
    auto found = textures_.find(key);
    if (found != textures_.end()) return found->second;
    const tinygltf::Image& im = m_.images[size_t(ii)];
    const unsigned char* bytes = nullptr;
    size_t size = 0;
    if (im.bufferView >= 0) {
        ViewBytes v = buffer_view(im.bufferView, user + ": " + image_desc(ii));
        bytes = v.data;
        size = v.size;
    } else {
        bytes = im.image.data();
        size = im.image.size();
    }
    if (size == 0) {
        if (!im.uri.empty() && !tinygltf::IsDataURI(im.uri)) {
            // As Blender and glTF viewers do: the material keeps its factor alone.
            scene_.warnings.push_back(name_ + ": " + user + ": " + image_desc(ii) +
                                      ": file not found or unreadable; rendered without it");
            return textures_[key] = kNoTexture;
        }
        fail(user + ": " + image_desc(ii) + " has no data");
    }
    Texture tex;
    std::string why;
    if (!decode_texture(bytes, size, channels, srgb, tex, why)) fail(user + ": " + image_desc(ii) + ": " + why);
    tex.name = !im.name.empty() ? im.name : (!im.uri.empty() && !tinygltf::IsDataURI(im.uri) ? im.uri : "image " + std::to_string(ii));
    tex.wrap_s = smp.s;
    tex.wrap_t = smp.t;
    tex.magnify_nearest = smp.magnify_nearest;
    uint32_t idx = uint32_t(scene_.textures.size());
    scene_.textures.push_back(std::move(tex));
    textures_[key] = idx;
    return idx;
}

uint32_t Loader::material_index(int mi, const std::string& user) {
    if (mi != -1 && (mi < 0 || size_t(mi) >= m_.materials.size()))
        fail(user + ": material " + std::to_string(mi) + " does not exist");
    auto found = materials_.find(mi);
    if (found != materials_.end()) return found->second;
    Material out;
    MaterialUv uv;
    const auto say = [&](const std::string& s) { note(s); };
    if (mi == -1) {
        out.name = "default";  // glTF default material is white; the project default is grey 0.8
    } else {
        const tinygltf::Material& g = m_.materials[size_t(mi)];
        const std::string mdesc = material_desc(mi);
        out.name = g.name.empty() ? "material " + std::to_string(mi) : g.name;
        const auto& pbr = g.pbrMetallicRoughness;
        if (pbr.baseColorFactor.size() != 4) fail(mdesc + ": baseColorFactor must have 4 numbers");
        Vec3f base{float(pbr.baseColorFactor[0]), float(pbr.baseColorFactor[1]), float(pbr.baseColorFactor[2])};
        if (!is_finite(base)) fail(mdesc + ": baseColorFactor is not finite");
        out.albedo = vmin(vmax(base, Vec3f(0.0f)), Vec3f(1.0f));
        Vec3f emissive;
        if (!g.emissiveFactor.empty()) {
            if (g.emissiveFactor.size() != 3) fail(mdesc + ": emissiveFactor must have 3 numbers");
            emissive = {float(g.emissiveFactor[0]), float(g.emissiveFactor[1]), float(g.emissiveFactor[2])};
        }
        double strength = 1.0;
        auto es = g.extensions.find("KHR_materials_emissive_strength");
        if (es != g.extensions.end() && es->second.IsObject() && es->second.Has("emissiveStrength") &&
            es->second.Get("emissiveStrength").IsNumber())
            strength = es->second.Get("emissiveStrength").GetNumberAsDouble();
        emissive = emissive * float(strength);
        if (!is_finite(emissive) || emissive.x < 0 || emissive.y < 0 || emissive.z < 0)
            fail(mdesc + ": emission (emissiveFactor x emissiveStrength) must be finite and non-negative");
        // An unlit material shows its base colour and nothing else (emission included).
        const bool unlit = g.extensions.count("KHR_materials_unlit") > 0;
        out.emission = unlit ? Vec3f(0.0f) : emissive;
        out.double_sided = g.doubleSided;
        // glTF adds emission on top of the reflected light (glTF 2.0 spec, 3.9.3), unlike
        // the CS184 panels, which only emit.
        out.emitter_reflects = true;

        if (pbr.baseColorTexture.texCoord < 0 || g.emissiveTexture.texCoord < 0)
            fail(mdesc + ": negative texCoord");
        // One uv set and transform per material (MaterialUv): the base colour's, else the
        // emissive texture's.
        int base_uv = pbr.baseColorTexture.texCoord, emissive_uv = g.emissiveTexture.texCoord;
        const UvTransform base_xf = texture_transform(pbr.baseColorTexture, mdesc + " baseColorTexture", base_uv);
        const UvTransform emissive_xf = texture_transform(g.emissiveTexture, mdesc + " emissiveTexture", emissive_uv);
        if (pbr.baseColorTexture.index >= 0) {
            out.albedo_texture = decoded_texture(pbr.baseColorTexture.index, mdesc + " baseColorTexture");
            uv.share(mdesc, "baseColorTexture", base_uv, base_xf, say);
        }
        if (g.emissiveTexture.index >= 0) {
            texture_image(g.emissiveTexture.index, mdesc + " emissiveTexture");
            // A texture multiplying zero emission changes nothing: do not decode it.
            if (out.is_emissive()) {
                out.emission_texture = decoded_texture(g.emissiveTexture.index, mdesc + " emissiveTexture");
                uv.share(mdesc, "emissiveTexture", emissive_uv, emissive_xf, say);
            }
        }
        if (out.albedo_texture != kNoTexture && out.is_emissive())
            note(mdesc + ": emissive and textured: it both emits and reflects its base colour");
        // Unneeded textures are never decoded, but a dangling reference is still an error.
        if (g.occlusionTexture.index >= 0) {
            texture_image(g.occlusionTexture.index, mdesc + " occlusionTexture");
            ignored_material_features_.insert("occlusionTexture");
        }
        if (unlit) {
            // KHR_materials_unlit: colour = the base colour term; every other PBR property
            // is only a fallback for viewers without the extension, so none is read.
            out.unlit = true;
        } else {
            read_pbr(g, mdesc, out, uv);
        }
        // glTF 2.0 spec 3.9.4 (Alpha Coverage): alpha is baseColorFactor's times the base
        // colour texture's; alphaCutoff counts for MASK alone.
        if (g.alphaMode == "MASK") {
            if (!std::isfinite(g.alphaCutoff) || g.alphaCutoff < 0)
                fail(mdesc + ": alphaCutoff must be a finite number >= 0");
            out.alpha_mode = AlphaMode::Mask;
            out.alpha_cutoff = float(g.alphaCutoff);
        } else if (g.alphaMode == "BLEND") {
            out.alpha_mode = AlphaMode::Blend;
        } else if (g.alphaMode != "OPAQUE" && !g.alphaMode.empty()) {
            fail(mdesc + ": alphaMode \"" + g.alphaMode + "\" is not OPAQUE, MASK or BLEND");
        }
        if (!std::isfinite(pbr.baseColorFactor[3])) fail(mdesc + ": baseColorFactor is not finite");
        out.base_alpha = std::clamp(float(pbr.baseColorFactor[3]), 0.0f, 1.0f);
        for (const auto& [ext, v] : g.extensions)
            if (ext != "KHR_materials_emissive_strength" && ext != "KHR_materials_transmission" &&
                ext != "KHR_materials_ior" && ext != "KHR_materials_unlit")
                ignored_material_features_.insert(ext);
    }
    uint32_t idx = uint32_t(scene_.materials.size());
    scene_.materials.push_back(out);
    const bool textured = out.albedo_texture != kNoTexture || out.emission_texture != kNoTexture ||
                          out.metallic_roughness_texture != kNoTexture || out.normal_texture != kNoTexture ||
                          out.transmission_texture != kNoTexture;
    material_uv_set_.push_back(textured ? uv.set : -1);
    material_uv_xform_.push_back(uv.xform);
    materials_[mi] = idx;
    return idx;
}

/// glTF 2.0 metallic-roughness (pbrMetallicRoughness factors and textures, normalTexture)
/// with KHR_materials_transmission and KHR_materials_ior. A material whose metallic and
/// transmission are zero, untextured, stays Diffuse (Lambert), so a plain diffuse file
/// keeps the diffuse integrator's speed; anything else is BsdfKind::MetallicRoughness.
void Loader::read_pbr(const tinygltf::Material& g, const std::string& mdesc, Material& out, MaterialUv& uv) {
    const auto& pbr = g.pbrMetallicRoughness;
    auto factor = [&](double v, const char* what) {
        if (!std::isfinite(v) || v < 0 || v > 1) fail(mdesc + ": " + what + " must be in [0, 1]");
        return float(v);
    };
    out.metallic = factor(pbr.metallicFactor, "metallicFactor");
    out.roughness = factor(pbr.roughnessFactor, "roughnessFactor");
    // A data map shares the material's uv set and transform (MaterialUv) with its own
    // KHR_texture_transform and texCoord override.
    auto data_texture = [&](const tinygltf::TextureInfo& ti, const char* slot, const char* channels) {
        if (ti.texCoord < 0) fail(mdesc + ": negative texCoord");
        const int img = texture_image(ti.index, mdesc + " " + slot);
        int tc = ti.texCoord;
        const UvTransform xf = texture_transform(ti, mdesc + " " + slot, tc);
        // A missing data map degrades to the factors (BoomBox in the shared corpus lacks its
        // occlusion-roughness-metallic image); a missing base colour stays an error.
        const tinygltf::Image& im = m_.images[size_t(img)];
        if (im.bufferView < 0 && im.image.empty() && !im.uri.empty() && !tinygltf::IsDataURI(im.uri)) {
            used_images_.insert(img);
            if (missing_data_images_.insert(img).second)
                note(mdesc + ": " + slot + " " + image_desc(img) + " not found; using the factors alone");
            return kNoTexture;
        }
        uv.share(mdesc, slot, tc, xf, [&](const std::string& s) { note(s); });
        return decoded_texture(ti.index, mdesc + " " + slot, channels, false);
    };
    if (pbr.metallicRoughnessTexture.index >= 0)
        out.metallic_roughness_texture = data_texture(pbr.metallicRoughnessTexture, "metallicRoughnessTexture", "GB");
    if (g.normalTexture.index >= 0) {
        if (g.normalTexture.texCoord < 0) fail(mdesc + ": negative texCoord");
        tinygltf::TextureInfo ti;
        ti.index = g.normalTexture.index;
        ti.texCoord = g.normalTexture.texCoord;
        ti.extensions = g.normalTexture.extensions;
        out.normal_texture = data_texture(ti, "normalTexture", "RG");
        if (!std::isfinite(g.normalTexture.scale)) fail(mdesc + ": normalTexture.scale is not finite");
        out.normal_scale = float(g.normalTexture.scale);
    }
    auto ext = g.extensions.find("KHR_materials_transmission");
    if (ext != g.extensions.end() && ext->second.IsObject()) {
        const tinygltf::Value& v = ext->second;
        if (v.Has("transmissionFactor") && v.Get("transmissionFactor").IsNumber())
            out.transmission = factor(v.Get("transmissionFactor").GetNumberAsDouble(), "transmissionFactor");
        if (v.Has("transmissionTexture") && v.Get("transmissionTexture").IsObject()) {
            const tinygltf::Value& t = v.Get("transmissionTexture");
            tinygltf::TextureInfo ti;
            ti.index = t.Has("index") && t.Get("index").IsInt() ? t.Get("index").GetNumberAsInt() : -1;
            ti.texCoord = t.Has("texCoord") && t.Get("texCoord").IsInt() ? t.Get("texCoord").GetNumberAsInt() : 0;
            if (ti.index < 0) fail(mdesc + ": transmissionTexture has no index");
            if (t.Has("extensions") && t.Get("extensions").IsObject()) {
                const tinygltf::Value& e = t.Get("extensions");
                for (const std::string& key : e.Keys()) ti.extensions[key] = e.Get(key);
            }
            out.transmission_texture = data_texture(ti, "transmissionTexture", "R");
        }
    }
    ext = g.extensions.find("KHR_materials_ior");
    if (ext != g.extensions.end() && ext->second.IsObject() && ext->second.Has("ior") &&
        ext->second.Get("ior").IsNumber()) {
        const double ior = ext->second.Get("ior").GetNumberAsDouble();
        // The extension allows 0 (a thin, non-refracting surface); we model ior >= 1.
        if (!std::isfinite(ior) || ior < 1.0 || ior > 10.0) fail(mdesc + ": KHR_materials_ior ior must be in [1, 10]");
        out.ior = std::max(1.0f, float(ior));
    }
    const bool plain = out.metallic == 0.0f && out.transmission == 0.0f &&
                       out.metallic_roughness_texture == kNoTexture && out.normal_texture == kNoTexture &&
                       out.transmission_texture == kNoTexture;
    // A perfectly rough dielectric is still glossy at grazing angles in glTF; only
    // metallic 0, roughness 1 and no other maps is close enough to Lambert to keep its speed.
    if (!(plain && out.roughness >= 1.0f)) out.bsdf = BsdfKind::MetallicRoughness;
}

// ---------------------------------------------------------------------------------------
// Meshes

/// KHR_draco_mesh_compression: the extension names a bufferView holding the Draco
/// stream and maps glTF semantics to Draco attribute ids; the primitive's accessors
/// only describe the decoded result, so they are not read.
void Loader::decode_draco_primitive(const tinygltf::Primitive& p, const std::string& pdesc,
                                    const std::string& uv_semantic,
                                    gltf_detail::DracoPrimitive& out) {
    const std::string edesc = pdesc + ": KHR_draco_mesh_compression";
    const tinygltf::Value& ext = p.extensions.at("KHR_draco_mesh_compression");
    if (!ext.IsObject()) fail(edesc + " is not an object");
    const tinygltf::Value& bv = ext.Get("bufferView");
    const tinygltf::Value& attrs = ext.Get("attributes");
    if (!bv.IsInt()) fail(edesc + ": bufferView missing or not an integer");
    if (!attrs.IsObject()) fail(edesc + ": attributes missing or not an object");
    const int mode = p.mode < 0 ? TINYGLTF_MODE_TRIANGLES : p.mode;
    if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP)
        fail(edesc + ": mode " + std::to_string(mode) + " (only triangles and strips may be compressed)");
    std::map<std::string, std::pair<int, int>> wanted;
    auto want = [&](const std::string& sem, int components) {
        if (sem.empty() || !p.attributes.count(sem)) return;
        const tinygltf::Value& id = attrs.Get(sem);
        if (!id.IsInt()) fail(edesc + ": no Draco attribute id for " + sem);
        wanted[sem] = {id.GetNumberAsInt(), components};
    };
    want("POSITION", 3);
    want("NORMAL", 3);
    want(uv_semantic, 2);
    if (p.attributes.count("COLOR_0")) {
        const int ai = p.attributes.at("COLOR_0");
        want("COLOR_0", ai >= 0 && size_t(ai) < m_.accessors.size() && m_.accessors[size_t(ai)].type == TINYGLTF_TYPE_VEC4 ? 4 : 3);
    }
    ViewBytes v = buffer_view(bv.GetNumberAsInt(), edesc);
    const uint64_t budget = limits_.max_elements - std::min(limits_.max_elements, decoded_elements_);
    std::string why = gltf_detail::decode_draco(v.data, v.size, wanted, budget, out);
    if (!why.empty())
        fail(edesc + " (bufferView " + std::to_string(bv.GetNumberAsInt()) + "): " + why);
}

/// KHR_texture_transform on one textureInfo: uv' = T(offset) R(rotation) S(scale) uv,
/// rotation counter-clockwise in uv (the extension's README; its example maps the unit
/// square to the lower-left quadrant turned 90 degrees). `texcoord` takes its override.
UvTransform Loader::texture_transform(const tinygltf::TextureInfo& ti, const std::string& desc,
                                      int& texcoord) const {
    UvTransform t;
    auto it = ti.extensions.find("KHR_texture_transform");
    if (ti.index < 0 || it == ti.extensions.end()) return t;
    const std::string edesc = desc + ": KHR_texture_transform";
    const tinygltf::Value& x = it->second;
    if (!x.IsObject()) fail(edesc + " is not an object");
    auto pair = [&](const char* key, double dx, double dy) {
        if (!x.Has(key)) return std::make_pair(dx, dy);
        const tinygltf::Value& v = x.Get(key);
        if (!v.IsArray() || v.ArrayLen() != 2 || !v.Get(0).IsNumber() || !v.Get(1).IsNumber())
            fail(edesc + ": " + key + " must be 2 numbers");
        return std::make_pair(v.Get(0).GetNumberAsDouble(), v.Get(1).GetNumberAsDouble());
    };
    const auto [ox, oy] = pair("offset", 0.0, 0.0);
    const auto [sx, sy] = pair("scale", 1.0, 1.0);
    double r = 0.0;
    if (x.Has("rotation")) {
        if (!x.Get("rotation").IsNumber()) fail(edesc + ": rotation must be a number");
        r = x.Get("rotation").GetNumberAsDouble();
    }
    if (!std::isfinite(ox) || !std::isfinite(oy) || !std::isfinite(sx) || !std::isfinite(sy) || !std::isfinite(r))
        fail(edesc + ": values must be finite");
    if (x.Has("texCoord")) {
        const tinygltf::Value& tc = x.Get("texCoord");
        if (!tc.IsInt() || tc.GetNumberAsInt() < 0) fail(edesc + ": texCoord must be a non-negative integer");
        texcoord = tc.GetNumberAsInt();
    }
    const double c = std::cos(r), s = std::sin(r);
    t = {float(sx * c), float(sy * s), float(ox), float(-sx * s), float(sy * c), float(oy)};
    return t;
}

/// COLOR_0 (glTF 2.0, 3.7.2.1): linear RGB or RGBA that multiplies the base colour and
/// its alpha. Kept only where it changes the image: the colours when some vertex is not
/// white, the alpha when the material is MASK or BLEND and some vertex is below 1, so a
/// file whose exporter wrote white vertex colours pays nothing for them. Components are
/// clamped to [0, 1], the range of the normalized integer forms.
void Loader::read_colors(const tinygltf::Primitive& p, const std::string& pdesc, gltf_detail::DracoPrimitive* draco,
                         size_t nv, DecodedPrimitive& d) {
    const int ai = p.attributes.at("COLOR_0");
    const tinygltf::Accessor& a = accessor(ai, pdesc);
    const size_t nc = a.type == TINYGLTF_TYPE_VEC4 ? 4 : 3;
    std::vector<float> c = draco ? std::move(draco->attributes.at("COLOR_0"))
                                 : read_attribute(ai, nc == 4 ? kColorRule4 : kColorRule3, pdesc);
    if (c.size() != nv * nc)
        fail(pdesc + ": COLOR_0 has " + std::to_string(c.size() / nc) + " elements, POSITION " + std::to_string(nv));
    for (float& x : c) x = std::clamp(x, 0.0f, 1.0f);
    bool white = true, opaque = true;
    for (size_t i = 0; i < nv; ++i) {
        white = white && c[i * nc] == 1.0f && c[i * nc + 1] == 1.0f && c[i * nc + 2] == 1.0f;
        opaque = opaque && (nc == 3 || c[i * nc + 3] == 1.0f);
    }
    if (!white) {
        d.colors.resize(nv);
        for (size_t i = 0; i < nv; ++i) d.colors[i] = {c[i * nc], c[i * nc + 1], c[i * nc + 2]};
    }
    if (!opaque && scene_.materials[d.material].alpha_mode != AlphaMode::Opaque) {
        d.alphas.resize(nv);
        for (size_t i = 0; i < nv; ++i) d.alphas[i] = c[i * nc + 3];
    }
}

const DecodedPrimitive& Loader::decode_primitive(int mi, int pi) {
    auto key = std::make_pair(mi, pi);
    auto found = primitives_.find(key);
    if (found != primitives_.end()) return found->second;
    DecodedPrimitive d;
    const tinygltf::Primitive& p = m_.meshes[size_t(mi)].primitives[size_t(pi)];
    const std::string pdesc = mesh_desc(mi) + " primitive " + std::to_string(pi);
    int mode = p.mode < 0 ? TINYGLTF_MODE_TRIANGLES : p.mode;
    static const char* kModeNames[] = {"POINTS", "LINES", "LINE_LOOP", "LINE_STRIP"};
    if (mode >= 0 && mode <= 3) {
        note(pdesc + ": " + kModeNames[mode] + " primitive skipped (only triangles are rendered)");
        d.skip = true;
    } else if (mode > TINYGLTF_MODE_TRIANGLE_FAN) {
        fail(pdesc + ": unknown mode " + std::to_string(mode));
    } else if (p.attributes.find("POSITION") == p.attributes.end()) {
        note(pdesc + ": no POSITION attribute, skipped");
        d.skip = true;
    }
    if (d.skip) return primitives_.emplace(key, std::move(d)).first->second;

    d.material = material_index(p.material, pdesc);
    if (!p.targets.empty()) morphed_meshes_.insert(mi);
    const int uv_set = material_uv_set_[d.material];
    const std::string uv_sem = uv_set >= 0 ? "TEXCOORD_" + std::to_string(uv_set) : "";
    gltf_detail::DracoPrimitive draco;
    const bool compressed = p.extensions.count("KHR_draco_mesh_compression") > 0;
    if (compressed) {
        decode_draco_primitive(p, pdesc, uv_sem, draco);
        mode = TINYGLTF_MODE_TRIANGLES;  // Draco decodes strips into a triangle list
    }
    // Attributes come from the Draco data when compressed, else from their accessors.
    auto attribute = [&](const std::string& sem, const AttributeRule& rule) {
        if (!compressed) return read_attribute(p.attributes.at(sem), rule, pdesc);
        return std::move(draco.attributes.at(sem));
    };
    std::vector<float> pos = attribute("POSITION", kPositionRule);
    const size_t nv = pos.size() / 3;
    if (nv >= size_t(std::numeric_limits<uint32_t>::max()))
        fail(pdesc + ": too many vertices");
    // Decoded primitives are cached, so they count against the budget on their own,
    // before any instance does.
    decoded_elements_ += nv;
    if (decoded_elements_ > limits_.max_elements) fail(pdesc + ": scene too large");
    d.positions.resize(nv);
    for (size_t i = 0; i < nv; ++i) d.positions[i] = {pos[i * 3], pos[i * 3 + 1], pos[i * 3 + 2]};

    auto nrm_it = p.attributes.find("NORMAL");
    if (nrm_it != p.attributes.end()) {
        std::vector<float> nrm = attribute("NORMAL", kNormalRule);
        if (nrm.size() != pos.size())
            fail(pdesc + ": NORMAL has " + std::to_string(nrm.size() / 3) + " elements, POSITION " +
                 std::to_string(nv));
        d.normals.resize(nv);
        for (size_t i = 0; i < nv; ++i) d.normals[i] = {nrm[i * 3], nrm[i * 3 + 1], nrm[i * 3 + 2]};
    }
    if (uv_set >= 0) {
        const std::string& sem = uv_sem;
        auto uv_it = p.attributes.find(sem);
        if (uv_it == p.attributes.end()) {
            note(pdesc + ": material " + squote(scene_.materials[d.material].name) + " is textured but the primitive has no " + sem + "; texture sampled at uv (0,0)");
        } else {
            std::vector<float> uv = attribute(sem, kTexcoordRule);
            if (uv.size() / 2 != nv)
                fail(pdesc + ": " + sem + " has " + std::to_string(uv.size() / 2) + " elements, POSITION " +
                     std::to_string(nv));
            d.uvs.resize(nv);
            const UvTransform& t = material_uv_xform_[d.material];
            for (size_t i = 0; i < nv; ++i) {
                const float u = uv[i * 2], v = uv[i * 2 + 1];
                d.uvs[i] = {t.a * u + t.b * v + t.c, t.d * u + t.e * v + t.f};
            }
        }
    }
    if (p.attributes.count("COLOR_0")) read_colors(p, pdesc, compressed ? &draco : nullptr, nv, d);

    std::vector<uint32_t> idx;
    if (compressed) {
        idx = std::move(draco.triangles);
    } else if (p.indices >= 0) {
        idx = read_indices(p.indices, pdesc);
        for (size_t i = 0; i < idx.size(); ++i)
            if (idx[i] >= nv)
                fail(pdesc + ": index " + std::to_string(idx[i]) + " at position " + std::to_string(i) +
                     " of accessor " + std::to_string(p.indices) + " is out of range (" +
                     std::to_string(nv) + " vertices)");
    } else {
        idx.resize(nv);
        for (size_t i = 0; i < nv; ++i) idx[i] = uint32_t(i);
    }
    const size_t n = idx.size();
    decoded_elements_ += 3 * n;  // strips and fans triple their index count
    if (decoded_elements_ > limits_.max_elements) fail(pdesc + ": scene too large");
    if (mode == TINYGLTF_MODE_TRIANGLES) {
        if (n % 3 != 0)
            note(pdesc + ": " + std::to_string(n) + " vertices is not a multiple of 3; last " +
                 std::to_string(n % 3) + " ignored");
        d.triangles.assign(idx.begin(), idx.begin() + ptrdiff_t(n - n % 3));
    } else if (n >= 3) {
        d.triangles.reserve((n - 2) * 3);
        for (size_t i = 0; i + 2 < n; ++i) {
            if (mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
                // Odd triangles swap their last two vertices to keep a consistent winding.
                bool odd = i % 2 == 1;
                d.triangles.insert(d.triangles.end(),
                                   {idx[i], idx[odd ? i + 2 : i + 1], idx[odd ? i + 1 : i + 2]});
            } else {
                d.triangles.insert(d.triangles.end(), {idx[i + 1], idx[i + 2], idx[0]});
            }
        }
    }
    return primitives_.emplace(key, std::move(d)).first->second;
}

void Loader::add_gpu_instances(int ni, const Mat4f& world, const tinygltf::Value& ext) {
    // EXT_mesh_gpu_instancing (its README, "Extending Nodes"): the node's mesh once per
    // instance, each placed by its own translation, rotation and scale (identity where an
    // attribute is absent) inside the node's frame: world * T * R * S. When the scene
    // places the mesh more than once (pass 1, count_placements) each becomes an Instance of
    // the mesh's one Prototype; a lone instance is flattened into world space as before.
    const std::string desc = node_desc(ni) + ": EXT_mesh_gpu_instancing";
    if (!ext.IsObject() || !ext.Has("attributes") || !ext.Get("attributes").IsObject())
        fail(desc + " has no attributes object");
    const tinygltf::Value& attrs = ext.Get("attributes");
    InstanceAttribute t, r, sc;
    size_t count = 0;
    bool counted = false;
    const std::pair<const AttributeRule*, InstanceAttribute*> wanted[] = {
        {&kInstanceTranslationRule, &t}, {&kInstanceRotationRule, &r}, {&kInstanceScaleRule, &sc}};
    for (const auto& [rule, out] : wanted) {
        if (!attrs.Has(rule->semantic)) continue;
        const tinygltf::Value& a = attrs.Get(rule->semantic);
        const double ai = a.IsNumber() ? a.GetNumberAsDouble() : -1.0;
        if (!(ai >= 0.0) || ai != std::floor(ai) || ai >= double(m_.accessors.size()))
            fail(desc + ": " + rule->semantic + " is not an accessor index");
        *out = instance_attribute(int(ai), *rule, desc);
        const size_t n = out->count;
        if (counted && n != count)
            fail(desc + ": " + rule->semantic + " has " + std::to_string(n) + " instances, " +
                 std::to_string(count) + " elsewhere (all attributes must have the same count)");
        count = n;
        counted = true;
    }
    if (!counted) fail(desc + " names none of TRANSLATION, ROTATION, SCALE");
    const tinygltf::Node& n = m_.nodes[size_t(ni)];
    const bool instanced = placed_more_than_once(n.mesh);
    // Read as read_attribute would have: every value finite, or the file is refused.
    auto value = [&](const InstanceAttribute& a, size_t k, size_t c) {
        const float v = a.get(k, c);
        if (!std::isfinite(v)) fail(a.what + ": element " + std::to_string(k) + " is not finite");
        return v;
    };
    uint64_t dropped = 0, first_dropped = 0, placed = 0;
    for (size_t k = 0; k < count; ++k) {
        Mat4f tm, rm, sm;
        if (t.count) tm = Mat4f::translate({value(t, k, 0), value(t, k, 1), value(t, k, 2)});
        if (r.count && !rotation_matrix(value(r, k, 0), value(r, k, 1), value(r, k, 2), value(r, k, 3), rm))
            fail(desc + ": instance " + std::to_string(k) + " has a zero rotation quaternion");
        if (sc.count) sm = Mat4f::scale({value(sc, k, 0), value(sc, k, 1), value(sc, k, 2)});
        const Mat4f composed = world * tm * rm * sm;
        if (!instanced) {
            add_mesh_instance(ni, composed);
            continue;
        }
        const Placed p = add_instance(ni, composed);
        if (p == Placed::Instance) ++placed;
        if (p == Placed::Dropped && dropped++ == 0) first_dropped = k;
    }
    if (dropped)
        note(desc + ": " + std::to_string(dropped) + " of " + std::to_string(count) +
             " instances have a singular or non-finite transform (the first is instance " +
             std::to_string(first_dropped) + "); dropped");
    if (placed) {
        ++instancing_nodes_;
        ++ext_nodes_;
    } else if (!instanced && count > 0) {
        ++ext_flattened_nodes_;
    }
}

/// The Prototype of glTF mesh `mi`, built at its first placement: its primitives decoded
/// once (decode_primitive's cache, shared with flattened placements) into object-space
/// meshes appended contiguously to Scene::meshes, with the materials, uvs and names a
/// flattened copy gets. Counted once against max_elements however often it is placed.
uint32_t Loader::prototype(int mi, int ni) {
    uint32_t& slot = prototypes_[size_t(mi)];
    if (slot != kUnbuilt) return slot;
    const tinygltf::Mesh& gm = m_.meshes[size_t(mi)];
    const uint32_t first = uint32_t(scene_.meshes.size());
    Bounds3f box;
    for (size_t pi = 0; pi < gm.primitives.size(); ++pi) {
        const DecodedPrimitive& d = decode_primitive(mi, int(pi));
        if (d.skip || d.triangles.empty()) continue;
        elements_ += d.positions.size() + d.triangles.size() + d.normals.size() + d.uvs.size() + d.colors.size() +
                     d.alphas.size();
        if (elements_ > limits_.max_elements)
            fail(node_desc(ni) + ": " + mesh_desc(mi) + ": scene too large (more than " +
                 std::to_string(limits_.max_elements) + " unique vertex/index elements)");
        Mesh out;
        out.name = gm.name.empty() ? "mesh " + std::to_string(mi) : gm.name;
        if (gm.primitives.size() > 1) out.name += "/" + std::to_string(pi);
        out.material = d.material;
        out.positions.reserve(d.positions.size() + 1);
        out.positions = d.positions;  // read_attribute refused non-finite values
        out.pad_positions();
        out.indices = d.triangles;
        // Unit normals, as a flattened copy under the identity gets them; a zero-length
        // one drops the primitive's normals (the renderer then uses geometric normals).
        out.normals.reserve(d.normals.size());
        for (const Vec3f& nn : d.normals) {
            const float len = length(nn);
            if (!(len > 0.0f) || !std::isfinite(len)) {
                out.normals.clear();
                note(mesh_desc(mi) + " primitive " + std::to_string(pi) +
                     " has zero-length normals; shading normals dropped");
                break;
            }
            out.normals.push_back(nn / len);
        }
        out.uvs = d.uvs;
        out.colors = d.colors;
        out.alphas = d.alphas;
        for (const Vec3f& p : d.positions) box.extend(p);
        scene_.meshes.push_back(std::move(out));
    }
    if (scene_.meshes.size() == first) return slot = kEmpty;
    slot = uint32_t(scene_.prototypes.size());
    scene_.prototypes.push_back(
        Prototype{gm.name.empty() ? "mesh " + std::to_string(mi) : gm.name, first, uint32_t(scene_.meshes.size() - first)});
    prototype_bounds_.push_back(box);
    return slot;
}

/// One placement of node `ni`'s mesh, which the scene places more than once, by the
/// composed transform `world` (node hierarchy, and for EXT_mesh_gpu_instancing the
/// instance's T * R * S): one Instance of the mesh's Prototype. Dropped when the transform
/// is singular or not finite: such an instance is dropped (it has no inverse, which
/// tracing an instance needs, and it would place only a degenerate copy). A transform
/// that mirrors (det < 0) is kept: glTF 2.0 spec 3.7.4 makes the winding follow the
/// determinant; the renderer flips the normal, flatten_instances the winding.
Loader::Placed Loader::add_instance(int ni, const Mat4f& world) {
    const int mi = m_.nodes[size_t(ni)].mesh;
    // A projective bottom row (glTF 2.0 spec 5.25 wants matrices decomposable to TRS, but
    // a file may lie) has no Affine3f: that placement is flattened as before.
    if (world.m[3][0] != 0.0f || world.m[3][1] != 0.0f || world.m[3][2] != 0.0f || world.m[3][3] != 1.0f) {
        add_mesh_instance(ni, world);
        return Placed::Flattened;
    }
    const uint32_t p = prototype(mi, ni);
    if (p == kEmpty) return Placed::Flattened;  // no triangles: nothing to place, as before
    const Affine3f x = Affine3f::from(world);
    if (!x.finite() || !x.inverse().finite()) {
        return Placed::Dropped;
    }
    // As a flattened copy would be refused: every placed corner of the box must be finite.
    const Bounds3f& b = prototype_bounds_[p];
    for (int c = 0; c < 8; ++c)
        if (!is_finite(x.point({c & 1 ? b.hi.x : b.lo.x, c & 2 ? b.hi.y : b.lo.y, c & 4 ? b.hi.z : b.lo.z})))
            fail(node_desc(ni) + ": " + mesh_desc(mi) + " has non-finite world positions");
    if (scene_.instances.size() >= limits_.max_instances)
        fail(node_desc(ni) + ": scene too large (more than " + std::to_string(limits_.max_instances) +
             " instances)");
    // One allocation of the size pass 1 counted (bounded by the accessors' bytes and by
    // the limit), instead of doubling: at 10^7 instances a doubling vector would copy and
    // briefly hold 1.5 times the array's 520 MB.
    if (scene_.instances.empty())
        scene_.instances.reserve(size_t(std::min(expected_instances_, limits_.max_instances)));
    scene_.instances.push_back(Instance{p, x});
    return Placed::Instance;
}

void Loader::add_mesh_instance(int ni, const Mat4f& world) {
    const tinygltf::Node& n = m_.nodes[size_t(ni)];
    if (n.mesh < 0 || size_t(n.mesh) >= m_.meshes.size())
        fail(node_desc(ni) + ": mesh " + std::to_string(n.mesh) + " does not exist");
    const tinygltf::Mesh& gm = m_.meshes[size_t(n.mesh)];
    // The normal matrix is the inverse transpose; a singular world matrix has none.
    Mat4f inv = world.inverse();
    bool normals_ok = std::isfinite(inv.m[0][0]);
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) normals_ok = normals_ok && std::isfinite(inv.m[r][c]);
    double det = double(world.m[0][0]) * (double(world.m[1][1]) * world.m[2][2] - double(world.m[1][2]) * world.m[2][1]) -
                 double(world.m[0][1]) * (double(world.m[1][0]) * world.m[2][2] - double(world.m[1][2]) * world.m[2][0]) +
                 double(world.m[0][2]) * (double(world.m[1][0]) * world.m[2][1] - double(world.m[1][1]) * world.m[2][0]);
    const bool mirrored = det < 0.0;
    for (size_t pi = 0; pi < gm.primitives.size(); ++pi) {
        const DecodedPrimitive& d = decode_primitive(n.mesh, int(pi));
        if (d.skip) continue;
        elements_ += d.positions.size() + d.triangles.size() + d.normals.size() + d.uvs.size() + d.colors.size() +
                     d.alphas.size();
        if (elements_ > limits_.max_elements)
            fail(node_desc(ni) + ": scene too large (more than " + std::to_string(limits_.max_elements) +
                 " unique vertex/index elements)");
        Mesh out;
        out.name = gm.name.empty() ? "mesh " + std::to_string(n.mesh) : gm.name;
        if (gm.primitives.size() > 1) out.name += "/" + std::to_string(pi);
        out.material = d.material;
        out.positions.reserve(d.positions.size() + 1);
        for (const Vec3f& p : d.positions) {
            Vec3f w = world.transform_point(p);
            if (!is_finite(w))
                fail(node_desc(ni) + ": " + mesh_desc(n.mesh) + " has non-finite world positions");
            out.positions.push_back(w);
        }
        out.pad_positions();
        out.indices = d.triangles;
        if (mirrored)
            for (size_t t = 0; t + 2 < out.indices.size(); t += 3) std::swap(out.indices[t + 1], out.indices[t + 2]);
        if (!d.normals.empty()) {
            if (!normals_ok) {
                note(node_desc(ni) + ": singular transform, shading normals dropped");
            } else {
                out.normals.reserve(d.normals.size());
                bool degenerate = false;
                for (const Vec3f& nn : d.normals) {
                    Vec3f t{inv.m[0][0] * nn.x + inv.m[1][0] * nn.y + inv.m[2][0] * nn.z,
                            inv.m[0][1] * nn.x + inv.m[1][1] * nn.y + inv.m[2][1] * nn.z,
                            inv.m[0][2] * nn.x + inv.m[1][2] * nn.y + inv.m[2][2] * nn.z};
                    float len = length(t);
                    if (!(len > 0.0f) || !std::isfinite(len)) {
                        degenerate = true;
                        break;
                    }
                    out.normals.push_back(t / len);
                }
                if (degenerate) {
                    // Either every normal is unit or the mesh has none: the renderer
                    // then falls back to geometric normals instead of shading with NaNs.
                    out.normals.clear();
                    note(node_desc(ni) + ": " + mesh_desc(n.mesh) + " primitive " + std::to_string(pi) +
                         " has zero-length normals; shading normals dropped");
                }
            }
        }
        out.uvs = d.uvs;
        out.colors = d.colors;
        out.alphas = d.alphas;
        if (out.indices.empty()) continue;
        scene_.meshes.push_back(std::move(out));
    }
}

// ---------------------------------------------------------------------------------------

void Loader::run() {
    scene_.format = SceneFormat::Gltf;
    scene_.up = Vec3f{0.0f, 1.0f, 0.0f};
    check_extensions();
    const std::vector<int> roots = root_nodes();
    count_placements(roots);
    traverse(roots);
    auto plural = [](uint64_t n, const char* one, const char* many) {
        return std::to_string(n) + " " + (n == 1 ? one : many);
    };
    if (instancing_nodes_)
        note("instancing: " + plural(instancing_nodes_, "node places ", "nodes place ") +
             plural(scene_.instances.size(), "instance", "instances") + " of " +
             plural(scene_.prototypes.size(), "mesh", "meshes") +
             (ext_nodes_ ? " (" + plural(ext_nodes_, "node", "nodes") + " by EXT_mesh_gpu_instancing)" : "") +
             ", each mesh stored once, in object space");
    if (ext_flattened_nodes_)
        note("EXT_mesh_gpu_instancing: " + plural(ext_flattened_nodes_, "node places", "nodes place") +
             " the only instance of its mesh; loaded in world space");
    if (scene_.world_triangles() + scene_.instanced_triangles() == 0)
        fail("the scene has no triangles to render");

    // Images nobody needed and that could not be read: say so, once each.
    for (size_t i = 0; i < m_.images.size(); ++i) {
        const tinygltf::Image& im = m_.images[i];
        if (im.bufferView < 0 && im.image.empty() && !im.uri.empty() && !used_images_.count(int(i)))
            note(image_desc(int(i)) + " not found; not needed (we do not model the texture slots that use it), ignored");
    }
    if (!ignored_material_features_.empty()) {
        std::string s;
        for (const std::string& f : ignored_material_features_) s += (s.empty() ? "" : ", ") + f;
        note("glTF material features ignored: " + s);
    }
    if (!morphed_meshes_.empty()) {
        // The file's default weights (a mesh's, or a node's in its stead) may pose a mesh
        // away from its base shape; viewers show that pose, we do not.
        bool weighted = false;
        for (int mi : morphed_meshes_)
            for (double w : m_.meshes[size_t(mi)].weights) weighted |= w != 0.0;
        for (const tinygltf::Node& n : m_.nodes)
            for (double w : n.weights) weighted |= n.mesh >= 0 && morphed_meshes_.count(n.mesh) && w != 0.0;
        note("morph targets ignored: " + plural(morphed_meshes_.size(), "mesh", "meshes") +
             " loaded in their base shape" + (weighted ? ", not in the pose the file's default weights give" : ""));
    }
    if (!m_.animations.empty()) note("animations ignored (" + std::to_string(m_.animations.size()) + ")");
}

Scene load_impl(const unsigned char* data, size_t size, const std::string& name,
                const std::string& base_dir, bool binary, const GltfLimits& limits) {
    if (size > std::numeric_limits<uint32_t>::max()) throw SceneError(name + ": file larger than 4 GiB");
    uint32_t length = uint32_t(size);
    if (binary) {
        length = check_glb(data, size, name);
        if (json_too_deep(data + 20, le32(data + 12)))
            throw SceneError(name + ": JSON nested deeper than " + std::to_string(kMaxJsonDepth) + " levels");
    } else if (json_too_deep(data, size)) {
        throw SceneError(name + ": JSON nested deeper than " + std::to_string(kMaxJsonDepth) + " levels");
    }

    // Draco primitives need their indices key hidden from tinygltf (see gltf_draco.h);
    // files without the extension are not copied.
    std::vector<unsigned char> patched;
    if (gltf_detail::mentions_draco(data, length)) {
        patched.assign(data, data + length);
        if (binary)
            gltf_detail::hide_draco_indices(patched.data() + 20, le32(data + 12));
        else
            gltf_detail::hide_draco_indices(patched.data(), patched.size());
        data = patched.data();
    }

    FsContext fs_ctx{base_dir};
    tinygltf::TinyGLTF ctx;
    ctx.SetImageLoader(&defer_image, nullptr);
    ctx.SetFsCallbacks(tinygltf::FsCallbacks{&fs_exists, &fs_expand, &fs_read, &fs_write, &fs_ctx});
    tinygltf::Model model;
    std::string err, warn;
    bool ok = false;
    try {
        ok = binary ? ctx.LoadBinaryFromMemory(&model, &err, &warn, data, length, base_dir)
                    : ctx.LoadASCIIFromString(&model, &err, &warn, reinterpret_cast<const char*>(data),
                                              length, base_dir);
    } catch (const std::exception& e) {
        throw SceneError(name + ": invalid glTF: " + e.what());
    }
    if (!ok) {
        std::string why = one_line(err.empty() ? warn : err);
        if (why.find("parse_error") != std::string::npos)
            throw SceneError(name + ": JSON parse error: " + why);
        // tinygltf stops at the first failing buffer, so the buffers parsed so far tell
        // which one it was.
        if (why.find("File ") != std::string::npos || why.find("Buffer") != std::string::npos ||
            why.find("buffer") != std::string::npos)
            if (model.bufferViews.empty() && model.accessors.empty())
                throw SceneError(name + ": buffer " + std::to_string(model.buffers.size()) + ": " + why);
        throw SceneError(name + ": invalid glTF: " + why);
    }
    Scene scene;
    scene.source = name;
    // tinygltf's image warnings are superseded by our own notes on missing images.
    std::istringstream ws(warn + "\n" + err);
    for (std::string line; std::getline(ws, line);)
        if (!line.empty() && line.find("image[") == std::string::npos &&
            line.find("File not found") == std::string::npos)
            scene.notes.push_back("tinygltf: " + one_line(line));
    Loader(name, model, scene, limits).run();
    return scene;
}

}  // namespace

Scene load_gltf(const std::string& path) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec)) throw SceneError(path + ": cannot open file");
    uint64_t size = std::filesystem::file_size(path, ec);
    if (ec) throw SceneError(path + ": cannot open file");
    if (size > std::numeric_limits<uint32_t>::max()) throw SceneError(path + ": file larger than 4 GiB");
    std::vector<unsigned char> bytes(static_cast<size_t>(size));
    std::ifstream f(path, std::ios::binary);
    if (!f || (size > 0 && !f.read(reinterpret_cast<char*>(bytes.data()), std::streamsize(size))))
        throw SceneError(path + ": cannot read file");
    // The magic decides, not the extension: a .gltf holding GLB bytes still loads.
    bool binary = bytes.size() >= 4 && std::memcmp(bytes.data(), "glTF", 4) == 0;
    std::string ext = std::filesystem::path(path).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    if (ext == ".glb" && !binary) binary = true;  // let the GLB check name the problem
    std::string base = std::filesystem::path(path).parent_path().string();
    return load_impl(bytes.data(), bytes.size(), path, base, binary, GltfLimits{});
}

Scene load_gltf_memory(const void* data, size_t size, const std::string& name,
                       const std::string& base_dir, bool binary, const GltfLimits& limits) {
    static const unsigned char empty = 0;
    return load_impl(size ? static_cast<const unsigned char*>(data) : &empty, size, name, base_dir, binary, limits);
}

Scene load_gltf_memory(const void* data, size_t size, const std::string& name,
                       const std::string& base_dir, bool binary) {
    return load_gltf_memory(data, size, name, base_dir, binary, GltfLimits{});
}

}  // namespace scenes
