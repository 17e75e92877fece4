// CS184 COLLADA loader. Reads the subset of COLLADA 1.4.1 that the course's Blender
// exports use (see ../shared/scenes/README.md) into scenes::Scene, in world space, and
// the profile_COMMON diffuse textures other exporters write (scenes/README.md).
//
// Robustness contract: every problem in the input becomes a SceneError naming the file
// and the element (tag, id, line); nothing is allocated from a count the file claims
// before checking it against the data that is actually present.
#include "scenes/collada/collada.h"

#include "scenes/image/image.h"

#include <fmt/format.h>

#include <pugixml.hpp>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <numbers>
#include <string_view>
#include <unordered_map>
#include <unordered_set>
#include <vector>

namespace scenes {
namespace {

using accel::cross;
using accel::dot;
using accel::length;

constexpr uint32_t kNone = 0xFFFFFFFFu;
constexpr size_t kMaxNotes = 200;

bool is_space(char c) {
    return c == ' ' || c == '\n' || c == '\r' || c == '\t' || c == '\f' || c == '\v';
}

/// Whitespace-separated tokens of an element's text.
class Tokens {
public:
    explicit Tokens(const char* s) : p_(s), end_(s + std::strlen(s)) {}
    bool next(std::string_view& tok) {
        while (p_ < end_ && is_space(*p_)) ++p_;
        if (p_ == end_) return false;
        const char* b = p_;
        while (p_ < end_ && !is_space(*p_)) ++p_;
        tok = std::string_view(b, size_t(p_ - b));
        return true;
    }
    size_t remaining_chars() const { return size_t(end_ - p_); }

private:
    const char* p_;
    const char* end_;
};

enum class NumStatus { Ok, Syntax, Range, NonFinite };

NumStatus parse_float(std::string_view t, float& out) {
    const char* b = t.data();
    const char* e = b + t.size();
    if (b < e && *b == '+') {  // from_chars rejects the '+' that strtod accepts
        ++b;
        if (b == e || *b == '+' || *b == '-') return NumStatus::Syntax;
    }
    auto r = std::from_chars(b, e, out);
    if (r.ec == std::errc::result_out_of_range) {
        // libstdc++ reports float underflow (e.g. 1e-40, a legitimate "almost zero" in
        // exported matrices) as out of range; re-read as double and narrow.
        double d = 0.0;
        auto rd = std::from_chars(b, e, d);
        if (rd.ec != std::errc() || rd.ptr != e || !std::isfinite(d) ||
            std::fabs(d) > double(std::numeric_limits<float>::max()))
            return NumStatus::Range;
        out = float(d);
        return NumStatus::Ok;
    }
    if (r.ec != std::errc() || r.ptr != e) return NumStatus::Syntax;
    if (!std::isfinite(out)) return NumStatus::NonFinite;
    return NumStatus::Ok;
}

bool parse_u32(std::string_view t, uint32_t& out) {
    const char* b = t.data();
    const char* e = b + t.size();
    if (b < e && *b == '+') ++b;
    auto r = std::from_chars(b, e, out);
    return r.ec == std::errc() && r.ptr == e && b != e;
}

std::string_view trimmed(std::string_view v) {
    while (!v.empty() && is_space(v.front())) v.remove_prefix(1);
    while (!v.empty() && is_space(v.back())) v.remove_suffix(1);
    return v;
}

/// An <image>'s file reference as a path: a file: URI's scheme dropped, %XX escapes
/// decoded, backslashes (Windows exporters) read as separators.
std::string uri_path(std::string_view uri) {
    if (uri.substr(0, 7) == "file://") {
        uri.remove_prefix(7);
        // file:///C:/x.png names a drive; file:///x.png keeps its root.
        if (uri.size() > 3 && uri[0] == '/' && uri[2] == ':') uri.remove_prefix(1);
    } else if (uri.substr(0, 5) == "file:") {
        uri.remove_prefix(5);
    }
    std::string out;
    for (size_t i = 0; i < uri.size(); ++i) {
        const auto hex = [](char c) {
            return c >= '0' && c <= '9' ? c - '0' : c >= 'a' && c <= 'f' ? c - 'a' + 10 : c >= 'A' && c <= 'F' ? c - 'A' + 10 : -1;
        };
        if (uri[i] == '%' && i + 2 < uri.size() && hex(uri[i + 1]) >= 0 && hex(uri[i + 2]) >= 0) {
            out += char(hex(uri[i + 1]) * 16 + hex(uri[i + 2]));
            i += 2;
        } else {
            out += uri[i] == '\\' ? '/' : uri[i];
        }
    }
    return out;
}

std::string clip(std::string_view s, size_t n = 64) {
    if (s.size() <= n) return std::string(s);
    return std::string(s.substr(0, n)) + "...";
}

/// Upper-left 3x3 determinant.
double det3(const Mat4f& m) {
    const double a = m.m[0][0], b = m.m[0][1], c = m.m[0][2];
    const double d = m.m[1][0], e = m.m[1][1], f = m.m[1][2];
    const double g = m.m[2][0], h = m.m[2][1], i = m.m[2][2];
    return a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g);
}

bool matrix_finite(const Mat4f& m) {
    for (const auto& row : m.m)
        for (float v : row)
            if (!std::isfinite(v)) return false;
    return true;
}

/// Triangles of a polygon with corners p[0..n), as corner triples appended to `out`, in
/// the polygon's winding. A convex polygon (every turn the same way about its Newell
/// normal) is fanned from its first corner, as the loader always did; a concave one, as
/// exporters write n-gons, is cut by ear clipping (Meisters 1975; Eberly, "Triangulation
/// by Ear Clipping", 2002) in the plane of its normal's dominant axis, so that no
/// triangle covers the notch a fan would fill. Ears are kept in flags and only a cut
/// corner's neighbours are tested again (every corner once more before giving up), each
/// against the reflex corners alone: O(n r) for r reflex corners, charged to `budget`.
/// A polygon with no ear left (self-intersecting, or folded in 3D), or past the budget,
/// has its remainder fanned: false then, for a note. Straight corners left on a line by the cuts are dropped, so a
/// clipped polygon may have fewer than n - 2 triangles, none of them without area.
bool triangulate_polygon(const Vec3f* p, uint32_t n, std::vector<uint32_t>& out, uint64_t& budget) {
    std::vector<uint32_t> prev(n), next(n);
    for (uint32_t k = 0; k < n; ++k) prev[k] = (k + n - 1) % n, next[k] = (k + 1) % n;
    const auto fan_from = [&](uint32_t first, uint32_t count) {
        for (uint32_t b = next[first], k = 2; k < count; ++k, b = next[b]) out.insert(out.end(), {first, b, next[b]});
    };
    if (n == 3) return fan_from(0, 3), true;
    // Newell's normal; the 2D projection drops its largest axis and keeps its sign, so
    // that the polygon's own winding turns counter-clockwise (positive cross products).
    Vec3f nn(0.0f);
    for (uint32_t k = 0; k < n; ++k) {
        const Vec3f& a = p[k];
        const Vec3f& b = p[next[k]];
        nn = nn + Vec3f((a.y - b.y) * (a.z + b.z), (a.z - b.z) * (a.x + b.x), (a.x - b.x) * (a.y + b.y));
    }
    const float ax = std::abs(nn.x), ay = std::abs(nn.y), az = std::abs(nn.z);
    if (!(std::max({ax, ay, az}) > 0.0f)) return fan_from(0, n), true;  // no area: as before
    const int drop = ax >= ay && ax >= az ? 0 : ay >= az ? 1 : 2;
    const float sign = nn[drop] > 0.0f ? 1.0f : -1.0f;
    const int u = (drop + 1) % 3, v = (drop + 2) % 3;
    std::vector<float> x(n), y(n);
    for (uint32_t k = 0; k < n; ++k) x[k] = p[k][u], y[k] = p[k][v] * sign;
    const auto cross = [&](uint32_t a, uint32_t b, uint32_t c) {
        return (x[b] - x[a]) * (y[c] - y[a]) - (y[b] - y[a]) * (x[c] - x[a]);
    };
    // Reflex (or straight) corners; a convex polygon has none and is fanned.
    std::vector<uint8_t> reflex(n), removed(n, 0), ear(n, 0);
    std::vector<uint32_t> reflexes;
    for (uint32_t k = 0; k < n; ++k)
        if ((reflex[k] = !(cross(prev[k], k, next[k]) > 0.0f))) reflexes.push_back(k);
    bool turns_back = false;
    for (uint32_t k : reflexes) turns_back |= cross(prev[k], k, next[k]) < 0.0f;
    if (!turns_back) return fan_from(0, n), true;
    const auto is_ear = [&](uint32_t b) {
        if (reflex[b]) return false;
        const uint32_t a = prev[b], c = next[b];
        budget -= std::min<uint64_t>(budget, reflexes.size() + 1);
        for (uint32_t q : reflexes) {
            // Only corners still reflex (a cut can turn one convex, never back), and never
            // the ear's own.
            if (removed[q] || !reflex[q] || q == a || q == b || q == c) continue;
            // A corner at the same place as the ear's (a polygon touching itself) does
            // not block it.
            if ((x[q] == x[a] && y[q] == y[a]) || (x[q] == x[c] && y[q] == y[c])) continue;
            if (cross(a, b, q) >= 0.0f && cross(b, c, q) >= 0.0f && cross(c, a, q) >= 0.0f) return false;
        }
        return true;
    };
    for (uint32_t k = 0; k < n; ++k) ear[k] = is_ear(k);
    uint32_t left = n, k = 0, misses = 0;
    bool fresh = true;  // every flag tested since the last cut
    const auto unlink = [&](uint32_t b) {
        const uint32_t a = prev[b], c = next[b];
        removed[b] = 1;
        next[a] = c;
        prev[c] = a;
        --left;
        for (uint32_t q : {a, c}) {
            reflex[q] = !(cross(prev[q], q, next[q]) > 0.0f);
            ear[q] = is_ear(q);
        }
        k = c;
        misses = 0;
        fresh = false;
    };
    while (left > 3) {
        if (misses > left && !fresh) {
            // A flag goes stale when a reflex corner that blocked it turns convex by a cut
            // that is not its neighbour's: test the ring once more before giving up.
            for (uint32_t q = next[k], c = 0; c < left; ++c, q = next[q]) ear[q] = is_ear(q);
            fresh = true;
            misses = 0;
        }
        if (budget == 0 || misses > left) return fan_from(k, left), false;
        // A straight corner (on the line of its neighbours, or a spike of no width) is
        // dropped without a triangle: the polygon's area is the same without it.
        if (cross(prev[k], k, next[k]) == 0.0f) {
            unlink(k);
            continue;
        }
        if (!ear[k]) {
            k = next[k];
            ++misses;
            continue;
        }
        out.insert(out.end(), {prev[k], k, next[k]});
        unlink(k);
    }
    if (cross(prev[k], k, next[k]) != 0.0f) fan_from(k, 3);
    return true;
}

/// A corner's position, normal and texture coordinate, each an index into its
/// geometry's sources numbered one after another (source_base); kNone where absent.
struct WeldKey {
    uint32_t p, n, t;
    bool operator==(const WeldKey&) const = default;
};
struct WeldHash {
    size_t operator()(const WeldKey& k) const {
        uint64_t h = (uint64_t(k.p) << 32 | k.n) * 0x9E3779B97F4A7C15ull;
        return size_t((h ^ (h >> 29)) + k.t * 0xBF58476D1CE4E5B9ull);
    }
};

/// Mesh data of one <geometry> in its own space, split by material symbol and welded.
struct LocalGroup {
    std::string symbol;
    std::vector<Vec3f> positions;
    std::vector<Vec3f> normals;
    /// Texture coordinates, flipped to the scene's convention (v = 0 at the image's top;
    /// COLLADA's, as OpenGL's, is at its bottom), read only when some effect of the
    /// document has a diffuse texture.
    std::vector<Vec2f> uvs;
    std::vector<uint32_t> indices;
    bool normals_seen = false, missing_normals = false;
    bool uvs_seen = false, missing_uvs = false;
    std::unordered_map<WeldKey, uint32_t, WeldHash> weld;
};

struct LocalGeometry {
    std::string name;
    bool is_sphere = false;
    float radius = 0.0f;
    std::vector<LocalGroup> groups;
};

struct Accessor {
    const float* data = nullptr;
    uint32_t count = 0, stride = 0;
    pugi::xml_node source;
    Vec3f get(uint32_t i) const {
        const float* p = data + size_t(i) * stride;
        return {p[0], p[1], p[2]};
    }
    Vec2f get2(uint32_t i) const {
        const float* p = data + size_t(i) * stride;
        return {p[0], p[1]};
    }
};

class Loader {
public:
    Loader(const char* data, size_t size, std::string name, const ColladaLimits& limits)
        : data_(data), size_(size), name_(std::move(name)), limits_(limits) {}

    Scene run();

private:
    // ---- errors and notes -------------------------------------------------------
    int line_of_offset(ptrdiff_t off) const {
        if (off < 0 || size_t(off) > size_) return 0;
        return 1 + int(std::count(data_, data_ + off, '\n'));
    }
    std::string describe(pugi::xml_node n) const {
        std::string s = fmt::format("<{}", clip(n.name()));
        if (pugi::xml_attribute id = n.attribute("id"))
            s += fmt::format(" id=\"{}\">", clip(id.value()));
        else {
            s += ">";
            for (pugi::xml_node a = n.parent(); a; a = a.parent())
                if (pugi::xml_attribute aid = a.attribute("id")) {
                    s += fmt::format(" in <{} id=\"{}\">", clip(a.name()), clip(aid.value()));
                    break;
                }
        }
        return s;
    }
    [[noreturn]] void fail(pugi::xml_node n, std::string_view what) const {
        const int line = line_of_offset(n.offset_debug());
        if (line > 0) throw SceneError(fmt::format("{}:{}: {}: {}", name_, line, describe(n), what));
        throw SceneError(fmt::format("{}: {}: {}", name_, describe(n), what));
    }
    void note(std::string s) {
        if (!note_set_.insert(s).second) return;
        if (scene_.notes.size() < kMaxNotes)
            scene_.notes.push_back(std::move(s));
        else
            ++dropped_notes_;
    }
    std::string label(pugi::xml_node n) const {
        const char* nm = n.attribute("name").value();
        if (*nm) return clip(nm);
        return clip(n.attribute("id").value());
    }

    // ---- numbers ----------------------------------------------------------------
    void number_error(pugi::xml_node n, std::string_view tok, NumStatus st) const {
        switch (st) {
            case NumStatus::Ok: return;
            case NumStatus::Syntax: fail(n, fmt::format("'{}' is not a number", clip(tok, 32)));
            case NumStatus::Range: fail(n, fmt::format("'{}' is out of range", clip(tok, 32)));
            case NumStatus::NonFinite: fail(n, fmt::format("'{}' is not a finite number", clip(tok, 32)));
        }
    }
    /// Up to `n` finite numbers from the element's text; more is an error. Returns how
    /// many were read.
    size_t read_floats_upto(pugi::xml_node el, float* out, size_t n) const {
        Tokens toks(el.child_value());
        std::string_view t;
        size_t got = 0;
        while (toks.next(t)) {
            float v;
            number_error(el, t, parse_float(t, v));
            if (got < n) out[got] = v;
            ++got;
        }
        if (got > n) fail(el, fmt::format("needs {} numbers, has {}", n, got));
        return got;
    }
    /// Exactly `n` finite numbers from the element's text.
    void read_floats(pugi::xml_node el, float* out, size_t n) const {
        const size_t got = read_floats_upto(el, out, n);
        if (got != n) fail(el, fmt::format("needs {} numbers, has {}", n, got));
    }
    float read_float(pugi::xml_node el) const {
        float v = 0.0f;
        read_floats(el, &v, 1);
        return v;
    }
    /// RGB, optionally followed by alpha (ignored). Colours must be finite and >= 0.
    Vec3f read_color(pugi::xml_node el) const {
        float c[4] = {0, 0, 0, 1};
        Tokens toks(el.child_value());
        std::string_view t;
        size_t got = 0;
        while (toks.next(t)) {
            float v;
            number_error(el, t, parse_float(t, v));
            if (got < 4) c[got] = v;
            ++got;
        }
        if (got != 3 && got != 4) fail(el, fmt::format("a colour needs 3 or 4 numbers, has {}", got));
        if (c[0] < 0 || c[1] < 0 || c[2] < 0) fail(el, "colour components must not be negative");
        return {c[0], c[1], c[2]};
    }
    void read_uints(pugi::xml_node el, std::vector<uint32_t>& out) const {
        out.clear();
        Tokens toks(el.child_value());
        // An index takes at least two characters with its separator: reserve from the
        // text length, which the file cannot lie about.
        out.reserve(toks.remaining_chars() / 2 + 1);
        std::string_view t;
        while (toks.next(t)) {
            uint32_t v;
            if (!parse_u32(t, v)) fail(el, fmt::format("'{}' is not a valid index", clip(t, 32)));
            out.push_back(v);
        }
    }
    /// Optional unsigned attribute; missing -> `def`.
    uint32_t uint_attr(pugi::xml_node el, const char* name, uint32_t def, bool required = false) const {
        pugi::xml_attribute a = el.attribute(name);
        if (!a) {
            if (required) fail(el, fmt::format("missing attribute {}", name));
            return def;
        }
        uint32_t v;
        if (!parse_u32(a.value(), v))
            fail(el, fmt::format("{}=\"{}\" is not a valid count", name, clip(a.value(), 32)));
        return v;
    }

    // ---- references -------------------------------------------------------------
    void index_ids() {
        pugi::xml_node cur = doc_.first_child();
        while (cur) {
            if (cur.type() == pugi::node_element)
                if (pugi::xml_attribute a = cur.attribute("id")) ids_.emplace(a.value(), cur);
            if (cur.first_child()) {
                cur = cur.first_child();
                continue;
            }
            while (cur && !cur.next_sibling()) cur = cur.parent();
            if (cur) cur = cur.next_sibling();
        }
    }
    pugi::xml_node resolve(pugi::xml_node from, const char* attr, const char* tag) const {
        const char* url = from.attribute(attr).value();
        if (!*url) fail(from, fmt::format("missing {} attribute", attr));
        if (url[0] != '#')
            fail(from, fmt::format("{}=\"{}\" points outside this document (only #id is supported)",
                                   attr, clip(url)));
        auto it = ids_.find(std::string_view(url + 1));
        if (it == ids_.end())
            fail(from, fmt::format("{}=\"{}\": no element with id \"{}\"", attr, clip(url), clip(url + 1)));
        if (tag && std::strcmp(it->second.name(), tag) != 0)
            fail(from, fmt::format("{}=\"{}\" refers to a <{}>, expected a <{}>", attr, clip(url),
                                   clip(it->second.name()), tag));
        return it->second;
    }

    // ---- data sources -----------------------------------------------------------
    const std::vector<float>& float_array(pugi::xml_node arr) {
        auto [it, inserted] = arrays_.try_emplace(arr.internal_object());
        std::vector<float>& v = it->second;
        if (!inserted) return v;
        Tokens toks(arr.child_value());
        v.reserve(toks.remaining_chars() / 2 + 1);
        std::string_view t;
        while (toks.next(t)) {
            float f;
            number_error(arr, t, parse_float(t, f));
            v.push_back(f);
        }
        if (pugi::xml_attribute c = arr.attribute("count")) {
            uint32_t declared = uint_attr(arr, "count", 0);
            if (declared != v.size())
                fail(arr, fmt::format("count=\"{}\" but it holds {} numbers", c.value(), v.size()));
        }
        return v;
    }
    Accessor accessor_of(pugi::xml_node source, uint32_t components) {
        pugi::xml_node acc = source.child("technique_common").child("accessor");
        if (!acc) fail(source, "has no <technique_common><accessor>");
        pugi::xml_node arr = resolve(acc, "source", "float_array");
        const uint32_t count = uint_attr(acc, "count", 0, true);
        const uint32_t stride = uint_attr(acc, "stride", 1);
        const uint32_t offset = uint_attr(acc, "offset", 0);
        if (stride < components)
            fail(acc, fmt::format("stride {} is smaller than the {} components needed", stride,
                                  components));
        const std::vector<float>& v = float_array(arr);
        Accessor a;
        a.source = source;
        a.stride = stride;
        a.count = count;
        a.data = v.data();
        if (count > 0) {
            const uint64_t needed = uint64_t(offset) + uint64_t(count - 1) * stride + components;
            if (needed > v.size())
                fail(acc, fmt::format("count={} stride={} offset={} needs {} numbers but "
                                      "<float_array id=\"{}\"> holds {}",
                                      count, stride, offset, needed,
                                      clip(arr.attribute("id").value()), v.size()));
            a.data = v.data() + offset;
        }
        return a;
    }

    // ---- geometry ---------------------------------------------------------------
    const LocalGeometry& geometry(pugi::xml_node geom);
    void parse_primitive(pugi::xml_node prim, LocalGeometry& g);
    uint32_t source_base(pugi::xml_node src, uint32_t count) {
        auto [it, inserted] = source_bases_.try_emplace(src.internal_object(), next_base_);
        if (inserted) {
            next_base_ += count;
            if (next_base_ >= kNone) fail(src, "too many vertices in one geometry");
        }
        return it->second;
    }

    // ---- materials --------------------------------------------------------------
    uint32_t material_index(pugi::xml_node mat);
    uint32_t diffuse_texture(pugi::xml_node effect, pugi::xml_node tex, const std::string& material);
    /// Does some effect's diffuse colour come from a texture? Only then are texture
    /// coordinates read, so a file without textures loads exactly as before.
    bool any_diffuse_texture() const {
        for (pugi::xml_node effect : doc_.document_element().child("library_effects").children("effect"))
            if (first_of(effect.child("profile_COMMON").child("technique"), {"phong", "lambert", "blinn", "constant"})
                    .child("diffuse")
                    .child("texture"))
                return true;
        return false;
    }
    pugi::xml_node element_by_id(std::string_view id) const {
        auto it = ids_.find(id);
        return it == ids_.end() ? pugi::xml_node() : it->second;
    }
    /// The material's uvs for a mesh of group `grp`: kept only where its material reads a
    /// texture.
    std::vector<Vec2f> uvs_for(const LocalGroup& grp, uint32_t material) const {
        return scene_.materials[material].albedo_texture != kNoTexture ? grp.uvs : std::vector<Vec2f>{};
    }
    bool read_cgl_bsdf(pugi::xml_node bsdf, Material& m) const;
    uint32_t default_material() {
        if (default_material_ == kNone) {
            Material m;
            m.name = "default";
            m.albedo = Vec3f(0.8f);
            default_material_ = uint32_t(scene_.materials.size());
            scene_.materials.push_back(std::move(m));
        }
        return default_material_;
    }
    /// The course's extras (spheres, BSDFs, lights) on `parent`: <extra><technique
    /// profile="CGL">, or "CMU462" as the course's CMU 15-462 predecessor writes the same
    /// elements. CGL wins when an element carries both.
    pugi::xml_node cgl_technique(pugi::xml_node parent) const {
        pugi::xml_node cmu;
        for (pugi::xml_node extra : parent.children("extra"))
            for (pugi::xml_node tech : extra.children("technique")) {
                const char* profile = tech.attribute("profile").value();
                if (std::strcmp(profile, "CGL") == 0) return tech;
                if (!cmu && std::strcmp(profile, "CMU462") == 0) cmu = tech;
            }
        return cmu;
    }
    static pugi::xml_node first_element(pugi::xml_node n) {
        for (pugi::xml_node c : n.children())
            if (c.type() == pugi::node_element) return c;
        return {};
    }
    static pugi::xml_node first_of(pugi::xml_node n, std::initializer_list<const char*> names) {
        for (const char* nm : names)
            if (pugi::xml_node c = n.child(nm)) return c;
        return {};
    }

    // ---- scene graph ------------------------------------------------------------
    Mat4f local_transform(pugi::xml_node node, bool camera_only);
    void visit(pugi::xml_node node, const Mat4f& parent, uint32_t depth);
    void count_placements(pugi::xml_node node, uint32_t depth);
    void enter_node(pugi::xml_node node, uint32_t depth);
    std::string placement_key(pugi::xml_node inst, pugi::xml_node geom);
    uint32_t prototype(const LocalGeometry& g, const std::vector<std::pair<std::string_view, uint32_t>>& binds,
                       pugi::xml_node inst, pugi::xml_node node);
    uint32_t bound_material(const LocalGroup& grp, const LocalGeometry& g,
                            const std::vector<std::pair<std::string_view, uint32_t>>& binds, pugi::xml_node node);
    void instance_geometry(pugi::xml_node inst, pugi::xml_node node, const Mat4f& world, pugi::xml_node geom = {});
    void instance_controller(pugi::xml_node inst, pugi::xml_node node, const Mat4f& world);
    void instance_camera(pugi::xml_node inst, pugi::xml_node node, const Mat4f& world);
    void instance_light(pugi::xml_node inst, pugi::xml_node node, const Mat4f& world);
    void count_triangles(pugi::xml_node where, uint64_t n) {
        triangles_ += n;
        if (triangles_ > limits_.max_triangles)
            fail(where, fmt::format("scene expands to more than {} triangles", limits_.max_triangles));
    }

    const char* data_;
    size_t size_;
    std::string name_;
    ColladaLimits limits_;
    pugi::xml_document doc_;
    Scene scene_;
    std::unordered_map<std::string_view, pugi::xml_node> ids_;
    std::unordered_map<const void*, std::vector<float>> arrays_;
    std::unordered_map<const void*, LocalGeometry> geometries_;
    std::unordered_map<const void*, uint32_t> materials_;
    std::string dir_;                // the document's folder: images are found from it
    bool textured_effects_ = false;  // any_diffuse_texture()
    // (image, wrap s, wrap t, NEAREST magnification) -> scene texture
    std::map<std::tuple<const void*, TextureWrap, TextureWrap, bool>, uint32_t> textures_;
    std::unordered_set<const void*> missing_images_;  // warned about once each
    std::unordered_map<const void*, uint32_t> source_bases_;  // per geometry, for welding keys
    uint64_t next_base_ = 0;
    // Work ear clipping may do in one document (triangulate_polygon): far more than any
    // real file's concave n-gons ask, far less than a hostile one's could.
    uint64_t clip_budget_ = uint64_t(1) << 31;
    uint32_t default_material_ = kNone;
    uint64_t triangles_ = 0, local_triangles_ = 0, node_visits_ = 0;
    // Instancing: how often the scene places each (geometry, material binding)
    // (count_placements), and the Prototype it became (kNone before, kEmpty for a geometry
    // without triangles); prototype_bounds_: each Prototype's object-space box.
    static constexpr uint32_t kEmpty = kNone - 1;
    struct Reuse {
        uint64_t placements = 0;
        uint32_t prototype = kNone;
    };
    std::unordered_map<std::string, Reuse> reuse_;
    std::vector<Bounds3f> prototype_bounds_;
    uint64_t expected_instances_ = 0;
    uint32_t instance_node_depth_ = 0;  // > 0 inside an <instance_node>'s subtree
    uint64_t copied_spheres_ = 0, copied_lights_ = 0;
    std::unordered_set<std::string> note_set_;
    size_t dropped_notes_ = 0;
};

const LocalGeometry& Loader::geometry(pugi::xml_node geom) {
    auto it = geometries_.find(geom.internal_object());
    if (it != geometries_.end()) return it->second;
    LocalGeometry g;
    g.name = label(geom);
    if (pugi::xml_node mesh = geom.child("mesh")) {
        source_bases_.clear();
        next_base_ = 0;
        for (pugi::xml_node prim : mesh.children()) {
            const std::string_view tag = prim.name();
            if (tag == "triangles" || tag == "polylist" || tag == "polygons" || tag == "trifans" ||
                tag == "tristrips")
                parse_primitive(prim, g);
            else if (tag == "lines" || tag == "linestrips")
                note(fmt::format("geometry '{}': <{}> skipped (only surfaces are rendered)", g.name, tag));
        }
        for (LocalGroup& grp : g.groups) {
            grp.weld = {};  // only needed while parsing
            if (grp.missing_normals && grp.normals_seen) {
                note(fmt::format("geometry '{}': only some primitives of material '{}' have "
                                 "normals; using geometric normals",
                                 g.name, grp.symbol));
            }
            if (grp.missing_normals) grp.normals = {};
            if (grp.missing_uvs && grp.uvs_seen)
                note(fmt::format("geometry '{}': only some primitives of material '{}' have texture "
                                 "coordinates; the others read the texture at uv (0, 0)",
                                 g.name, grp.symbol));
            if (!grp.uvs_seen) grp.uvs = {};
        }
    } else if (pugi::xml_node sphere = cgl_technique(geom).child("sphere")) {
        pugi::xml_node r = sphere.child("radius");
        if (!r) fail(sphere, "has no <radius>");
        g.radius = read_float(r);
        if (!(g.radius > 0.0f)) fail(r, fmt::format("sphere radius {} must be positive", g.radius));
        g.is_sphere = true;
    } else {
        note(fmt::format("geometry '{}' has neither <mesh> nor a CGL sphere; skipped", g.name));
    }
    return geometries_.emplace(geom.internal_object(), std::move(g)).first->second;
}

void Loader::parse_primitive(pugi::xml_node prim, LocalGeometry& g) {
    const std::string_view tag = prim.name();
    uint32_t stride = 0;
    int64_t vertex_off = -1, normal_off = -1, uv_off = -1;
    uint32_t uv_set = kNone;
    pugi::xml_node vertices, normal_src, uv_src;
    for (pugi::xml_node in : prim.children("input")) {
        const uint32_t off = uint_attr(in, "offset", 0, true);
        if (off > 1024) fail(in, fmt::format("offset {} is absurd", off));
        stride = std::max(stride, off + 1);
        const std::string_view sem = in.attribute("semantic").value();
        if (sem == "VERTEX") {
            if (vertex_off < 0) {
                vertices = resolve(in, "source", "vertices");
                vertex_off = off;
            }
        } else if (sem == "NORMAL") {
            if (normal_off < 0) {
                normal_src = resolve(in, "source", "source");
                normal_off = off;
            }
        } else if (sem == "TEXCOORD" && textured_effects_) {
            // The lowest set: the one a single diffuse texture is sampled with.
            pugi::xml_node src = resolve(in, "source", "source");
            const uint32_t set = uint_attr(in, "set", 0);
            if (set < uv_set) uv_set = set, uv_src = src, uv_off = off;
        } else {
            resolve(in, "source", nullptr);  // unused, but a dangling link is still an error
        }
    }
    if (vertex_off < 0) fail(prim, "has no VERTEX input");

    pugi::xml_node pos_src, vnormal_src;
    for (pugi::xml_node in : vertices.children("input")) {
        const std::string_view sem = in.attribute("semantic").value();
        if (sem == "POSITION" && !pos_src)
            pos_src = resolve(in, "source", "source");
        else if (sem == "NORMAL" && !vnormal_src)
            vnormal_src = resolve(in, "source", "source");
    }
    if (!pos_src) fail(vertices, "has no POSITION input");
    const Accessor pos = accessor_of(pos_src, 3);
    const uint32_t pbase = source_base(pos_src, pos.count);
    Accessor nrm;
    uint32_t nbase = 0;
    const bool has_normals = normal_off >= 0 || vnormal_src;
    if (has_normals) {
        pugi::xml_node ns = normal_off >= 0 ? normal_src : vnormal_src;
        nrm = accessor_of(ns, 3);
        nbase = source_base(ns, nrm.count);
    }

    Accessor uv;
    uint32_t tbase = 0;
    const bool has_uvs = uv_off >= 0;
    if (has_uvs) {
        uv = accessor_of(uv_src, 2);
        tbase = source_base(uv_src, uv.count);
    }

    const std::string symbol = prim.attribute("material").value();
    auto git = std::find_if(g.groups.begin(), g.groups.end(),
                            [&](const LocalGroup& x) { return x.symbol == symbol; });
    if (git == g.groups.end()) {
        g.groups.emplace_back();
        git = g.groups.end() - 1;
        git->symbol = symbol;
    }
    LocalGroup& grp = *git;
    (has_normals ? grp.normals_seen : grp.missing_normals) = true;
    (has_uvs ? grp.uvs_seen : grp.missing_uvs) = true;

    std::vector<uint32_t> corners;  // welded vertex of each corner of the current polygon
    std::vector<Vec3f> corner_pos;  // and its position, for triangulate_polygon
    std::vector<uint32_t> tri;
    uint64_t skipped = 0, unclipped = 0;
    // as_fan: <trifans>, whose corners name a fan whatever the polygon's shape.
    auto emit = [&](const uint32_t* c, uint32_t n, bool as_fan = false) {
        if (n < 3) {
            ++skipped;
            return;
        }
        corners.clear();
        for (uint32_t k = 0; k < n; ++k, c += stride) {
            const uint32_t pi = c[vertex_off];
            if (pi >= pos.count)
                fail(prim, fmt::format("position index {} out of range (<source id=\"{}\"> has {})",
                                       pi, clip(pos.source.attribute("id").value()), pos.count));
            uint32_t ni = kNone;
            if (has_normals) {
                ni = normal_off >= 0 ? c[normal_off] : pi;
                if (ni >= nrm.count)
                    fail(prim, fmt::format("normal index {} out of range (<source id=\"{}\"> has {})",
                                           ni, clip(nrm.source.attribute("id").value()), nrm.count));
            }
            uint32_t ti = kNone;
            if (has_uvs) {
                ti = c[uv_off];
                if (ti >= uv.count)
                    fail(prim, fmt::format("texcoord index {} out of range (<source id=\"{}\"> has {})", ti,
                                           clip(uv.source.attribute("id").value()), uv.count));
            }
            const WeldKey key{pbase + pi, has_normals ? nbase + ni : kNone, has_uvs ? tbase + ti : kNone};
            auto [it, inserted] = grp.weld.try_emplace(key, uint32_t(grp.positions.size()));
            if (inserted) {
                grp.positions.push_back(pos.get(pi));
                if (has_normals) grp.normals.push_back(nrm.get(ni));
                else grp.normals.push_back(Vec3f(0.0f));  // keeps indexing aligned; dropped later
                if (has_uvs) {
                    const Vec2f st = uv.get2(ti);
                    grp.uvs.push_back({st.x, 1.0f - st.y});
                } else if (textured_effects_) {
                    grp.uvs.push_back({0.0f, 0.0f});  // aligned with the positions
                }
            }
            corners.push_back(it->second);
        }
        local_triangles_ += n - 2;
        if (local_triangles_ > limits_.max_triangles)
            fail(prim, fmt::format("geometry holds more than {} triangles", limits_.max_triangles));
        if (n == 3) {
            grp.indices.insert(grp.indices.end(), corners.begin(), corners.end());
            return;
        }
        tri.clear();
        if (as_fan) {
            for (uint32_t k = 1; k + 1 < n; ++k) tri.insert(tri.end(), {0, k, k + 1});
        } else {
            corner_pos.clear();
            for (uint32_t k : corners) corner_pos.push_back(grp.positions[k]);
            if (!triangulate_polygon(corner_pos.data(), n, tri, clip_budget_)) ++unclipped;
        }
        for (uint32_t k : tri) grp.indices.push_back(corners[k]);
    };

    std::vector<uint32_t> p;
    const bool has_count = bool(prim.attribute("count"));
    const uint32_t count = uint_attr(prim, "count", 0);
    if (tag == "triangles") {
        if (pugi::xml_node pe = prim.child("p")) read_uints(pe, p);
        const uint64_t per = uint64_t(3) * stride;
        if (p.size() % per != 0)
            fail(prim, fmt::format("<p> holds {} indices, not a multiple of 3 corners x {} inputs",
                                   p.size(), stride));
        if (has_count && uint64_t(count) * per != p.size())
            fail(prim, fmt::format("count=\"{}\" needs {} indices in <p> but it holds {}", count,
                                   uint64_t(count) * per, p.size()));
        for (size_t i = 0; i < p.size(); i += per) emit(p.data() + i, 3);
    } else if (tag == "polylist") {
        std::vector<uint32_t> vcount;
        if (pugi::xml_node vc = prim.child("vcount")) read_uints(vc, vcount);
        if (pugi::xml_node pe = prim.child("p")) read_uints(pe, p);
        if (has_count && count != vcount.size())
            fail(prim, fmt::format("count=\"{}\" but <vcount> lists {} polygons", count, vcount.size()));
        uint64_t total = 0;
        for (uint32_t v : vcount) total += v;
        if (total * stride != p.size())
            fail(prim, fmt::format("<vcount> sums to {} corners x {} inputs = {} indices, but <p> "
                                   "holds {}",
                                   total, stride, total * stride, p.size()));
        size_t at = 0;
        for (uint32_t v : vcount) {
            emit(p.data() + at, v);
            at += size_t(v) * stride;
        }
    } else if (tag == "trifans" || tag == "tristrips") {
        // One <p> per fan or strip (COLLADA 1.4.1, 5-121 and 5-123). A fan is a polygon's
        // triangulation from its first corner, as emit makes; a strip's triangle k is
        // corners k, k+1, k+2, every other one reversed so that all keep the first's
        // winding. Triangles that repeat a position (a strip's restart) are dropped.
        std::vector<uint32_t> tri(size_t(3) * stride);
        for (pugi::xml_node pe : prim.children("p")) {
            read_uints(pe, p);
            if (p.size() % stride != 0)
                fail(pe, fmt::format("holds {} indices, not a multiple of {} inputs", p.size(), stride));
            const uint32_t n = uint32_t(p.size() / stride);
            if (tag == "trifans") {
                emit(p.data(), n, true);
                continue;
            }
            if (n < 3) {
                ++skipped;
                continue;
            }
            for (uint32_t k = 0; k + 2 < n; ++k) {
                const uint32_t order[3] = {k % 2 ? k + 1 : k, k % 2 ? k : k + 1, k + 2};
                for (int j = 0; j < 3; ++j)
                    std::copy_n(p.data() + size_t(order[j]) * stride, stride, tri.data() + size_t(j) * stride);
                const uint32_t a = tri[vertex_off], b = tri[stride + vertex_off], c2 = tri[2 * stride + vertex_off];
                if (a != b && b != c2 && a != c2) emit(tri.data(), 3);
            }
        }
    } else {  // polygons: one <p> per polygon
        for (pugi::xml_node pe : prim.children()) {
            const std::string_view t = pe.name();
            if (t == "ph") {
                note(fmt::format("geometry '{}': polygons with holes (<ph>) skipped", g.name));
                continue;
            }
            if (t != "p") continue;
            read_uints(pe, p);
            if (p.size() % stride != 0)
                fail(pe, fmt::format("holds {} indices, not a multiple of {} inputs", p.size(), stride));
            emit(p.data(), uint32_t(p.size() / stride));
        }
    }
    if (skipped)
        note(fmt::format("geometry '{}': skipped {} polygon(s) with fewer than 3 corners in <{}>",
                         g.name, skipped, tag));
    if (unclipped)
        note(fmt::format("geometry '{}': {} concave polygon(s) in <{}> self-intersecting, not planar or "
                         "past the triangulation budget; fanned where no ear was cut",
                         g.name, unclipped, tag));
}

uint32_t Loader::material_index(pugi::xml_node mat) {
    auto it = materials_.find(mat.internal_object());
    if (it != materials_.end()) return it->second;
    Material m;
    m.name = label(mat);
    pugi::xml_node ie = mat.child("instance_effect");
    if (!ie) {
        note(fmt::format("material '{}' has no <instance_effect>; using grey", m.name));
    } else {
        pugi::xml_node effect = resolve(ie, "url", "effect");
        bool have_diffuse = false;
        pugi::xml_node common = effect.child("profile_COMMON");
        pugi::xml_node technique = common.child("technique");
        if (pugi::xml_node shading = first_of(technique, {"phong", "lambert", "blinn", "constant"})) {
            pugi::xml_node diffuse = shading.child("diffuse");
            if (pugi::xml_node c = diffuse.child("color")) {
                m.albedo = read_color(c);
                have_diffuse = true;
            } else if (pugi::xml_node tex = diffuse.child("texture")) {
                // The texture is the diffuse colour (profile_COMMON has no factor beside it).
                const uint32_t t = diffuse_texture(effect, tex, m.name);
                if (t != kNoTexture) {
                    m.albedo = Vec3f(1.0f);
                    m.albedo_texture = t;
                    have_diffuse = true;
                }
            }
        }
        pugi::xml_node tech = cgl_technique(effect);
        if (!tech) tech = cgl_technique(common);
        if (!tech) tech = cgl_technique(technique);
        if (pugi::xml_node bsdf = first_element(tech)) {
            const std::string_view kind = bsdf.name();
            if (kind == "emission") {
                pugi::xml_node c = first_of(bsdf, {"radiance", "color", "emission"});
                if (!c) fail(bsdf, "CGL emission has no <radiance>");
                m.emission = read_color(c);
                m.albedo = Vec3f(0.0f);  // an emitter does not reflect
            } else if (kind == "diffuse") {
                if (pugi::xml_node c = first_of(bsdf, {"reflectance", "albedo", "color"}))
                    m.albedo = read_color(c);
            } else if (!read_cgl_bsdf(bsdf, m)) {
                if (!have_diffuse)
                    if (pugi::xml_node c =
                            first_of(bsdf, {"reflectance", "albedo", "color", "transmittance"}))
                        m.albedo = read_color(c);
                m.replaced = std::string(clip(kind));
                note(fmt::format("material '{}': unknown CGL {} BSDF rendered as diffuse, albedo ({:g}, {:g}, {:g})",
                                 m.name, m.replaced, m.albedo.x, m.albedo.y, m.albedo.z));
            }
        }
    }
    const uint32_t idx = uint32_t(scene_.materials.size());
    scene_.materials.push_back(std::move(m));
    materials_.emplace(mat.internal_object(), idx);
    return idx;
}

/// The image a diffuse <texture texture="..."> names: through the effect's <newparam>s
/// (COLLADA 1.4.1, 8-24: a <sampler2D> whose <source> is the sid of a <surface> whose
/// <init_from> is an <image> id; 1.5: the sampler's <instance_image>), or directly by the
/// image's id, as some exporters write it. The sampler's wrap_s, wrap_t and a NEAREST
/// magfilter reach the texture as glTF's do. Decoded once per image and sampler
/// settings, at its source's precision; a missing file is a warning and the material
/// keeps its colour (as a missing glTF texture), an undecodable one an error.
uint32_t Loader::diffuse_texture(pugi::xml_node effect, pugi::xml_node tex, const std::string& material) {
    const std::string_view ref = tex.attribute("texture").value();
    const auto newparam = [&](std::string_view sid) -> pugi::xml_node {
        for (pugi::xml_node scope : {effect, effect.child("profile_COMMON")})
            for (pugi::xml_node np : scope.children("newparam"))
                if (sid == np.attribute("sid").value()) return np;
        return {};
    };
    pugi::xml_node sampler = newparam(ref).child("sampler2D"), image;
    if (sampler) {
        if (pugi::xml_node ii = sampler.child("instance_image"))
            image = resolve(ii, "url", "image");
        else
            image = element_by_id(trimmed(newparam(trimmed(sampler.child_value("source"))).child("surface").child_value("init_from")));
    } else {
        image = element_by_id(ref);
    }
    if (!image || std::strcmp(image.name(), "image") != 0) {
        note(fmt::format("material '{}': diffuse texture '{}' names no <image>; texture ignored", material, clip(ref)));
        return kNoTexture;
    }
    TextureWrap ws = TextureWrap::Repeat, wt = TextureWrap::Repeat;
    bool nearest = false;
    if (sampler) {
        const auto wrap = [&](const char* tag) {
            const std::string_view v = trimmed(sampler.child_value(tag));
            if (v.empty() || v == "WRAP") return TextureWrap::Repeat;
            if (v == "MIRROR" || v == "MIRROR_ONCE") return TextureWrap::MirroredRepeat;
            if (v == "CLAMP") return TextureWrap::ClampToEdge;
            note(fmt::format("material '{}': sampler {} {} read as CLAMP", material, tag, clip(v)));
            return TextureWrap::ClampToEdge;  // BORDER, NONE: no border colour is modelled
        };
        ws = wrap("wrap_s");
        wt = wrap("wrap_t");
        nearest = trimmed(sampler.child_value("magfilter")) == "NEAREST";
    }
    const auto key = std::make_tuple(image.internal_object(), ws, wt, nearest);
    if (auto it = textures_.find(key); it != textures_.end()) return it->second;
    pugi::xml_node from = image.child("init_from");
    std::string_view uri = trimmed(from.child("ref") ? from.child("ref").child_value() : from.child_value());
    if (uri.empty()) {
        note(fmt::format("material '{}': {} has no file reference (embedded image data is not read); texture ignored",
                         material, describe(image)));
        return textures_[key] = kNoTexture;
    }
    std::filesystem::path path(uri_path(uri));
    if (path.is_relative() && !dir_.empty()) path = std::filesystem::path(dir_) / path;
    std::vector<unsigned char> bytes;
    std::string why;
    if (!scenes::image::read_regular_file(path.string(), uint64_t(1) << 30, bytes, why) || bytes.empty()) {
        if (missing_images_.insert(image.internal_object()).second)
            scene_.warnings.push_back(fmt::format("{}: material '{}': image '{}' ({}): file not found or unreadable; "
                                                  "rendered without it",
                                                  name_, material, clip(uri), path.string()));
        return textures_[key] = kNoTexture;
    }
    Texture t;
    if (!scenes::image::decode_texture(bytes.data(), bytes.size(), "RGB", true, t, why))
        fail(image, fmt::format("{}: {}", path.string(), why));
    t.name = clip(uri);
    t.wrap_s = ws;
    t.wrap_t = wt;
    t.magnify_nearest = nearest;
    const uint32_t idx = uint32_t(scene_.textures.size());
    scene_.textures.push_back(std::move(t));
    return textures_[key] = idx;
}

/// The CS184 3-2 BSDF elements (CGL collada parser): <mirror><reflectance>,
/// <glass>/<refraction> with <reflectance> <transmittance> <roughness> <ior>, and
/// <microfacet> with <alpha> and per-channel <eta> <k>. Absent children keep the
/// defaults in scenes/scene.h. False for an element name we do not model.
bool Loader::read_cgl_bsdf(pugi::xml_node bsdf, Material& m) const {
    const std::string_view kind = bsdf.name();
    // A spectrum is "r g b" (alpha ignored) or one number for all three channels.
    auto color = [&](const char* name, Vec3f& out) {
        pugi::xml_node c = bsdf.child(name);
        if (!c) return;
        float v[4] = {0, 0, 0, 0};
        const size_t got = read_floats_upto(c, v, 4);
        if (got == 1) v[1] = v[2] = v[0];
        else if (got != 3 && got != 4) fail(c, fmt::format("needs 1 or 3 numbers, has {}", got));
        if (v[0] < 0 || v[1] < 0 || v[2] < 0) fail(c, "must not be negative");
        out = Vec3f(v[0], v[1], v[2]);
    };
    auto positive = [&](const char* name, float& out) {
        if (pugi::xml_node c = bsdf.child(name)) {
            out = read_float(c);
            if (!(out > 0.0f)) fail(c, "must be positive");
        }
    };
    if (kind == "mirror") {
        m.bsdf = BsdfKind::Mirror;
        color("reflectance", m.reflectance);
    } else if (kind == "glass" || kind == "refraction") {
        m.bsdf = BsdfKind::Glass;
        if (kind == "glass") color("reflectance", m.reflectance);
        else m.reflectance = Vec3f(0.0f);  // the course's refraction BSDF only transmits
        color("transmittance", m.transmittance);
        positive("ior", m.ior);
    } else if (kind == "microfacet") {
        m.bsdf = BsdfKind::Microfacet;
        positive("alpha", m.alpha);
        color("eta", m.eta);
        color("k", m.k);
    } else {
        return false;
    }
    return true;
}

Mat4f Loader::local_transform(pugi::xml_node node, bool camera_only) {
    Mat4f m;
    for (pugi::xml_node el : node.children()) {
        const std::string_view t = el.name();
        if (t == "matrix") {
            float v[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
            const size_t got = read_floats_upto(el, v, 16);
            if (got != 16) {
                // CBgems.dae, a course file, has a 15-number camera matrix. A camera can
                // be repaired (instance_camera rebuilds a singular basis) or replaced by
                // default framing, so only a camera-only node is read the way the course's
                // stream parser reads it: missing entries keep their identity value.
                // Anywhere else a short matrix would silently corrupt geometry.
                if (!camera_only) fail(el, fmt::format("needs 16 numbers, has {}", got));
                note(fmt::format("node '{}': <matrix> has {} of 16 numbers; missing entries "
                                 "taken from the identity",
                                 label(node), got));
            }
            Mat4f x;
            for (int i = 0; i < 16; ++i) x.m[i / 4][i % 4] = v[i];  // row-major in the file
            m = m * x;
        } else if (t == "translate") {
            float v[3];
            read_floats(el, v, 3);
            m = m * Mat4f::translate({v[0], v[1], v[2]});
        } else if (t == "scale") {
            float v[3];
            read_floats(el, v, 3);
            m = m * Mat4f::scale({v[0], v[1], v[2]});
        } else if (t == "rotate") {
            float v[4];
            read_floats(el, v, 4);
            const Vec3f axis{v[0], v[1], v[2]};
            if (!(length(axis) > 0.0f)) fail(el, "rotation axis is zero");
            m = m * Mat4f::rotate(axis, v[3]);
        } else if (t == "lookat") {
            float v[9];
            read_floats(el, v, 9);
            const Vec3f eye{v[0], v[1], v[2]}, at{v[3], v[4], v[5]}, up{v[6], v[7], v[8]};
            const Vec3f z = eye - at;
            const Vec3f x = cross(up, z);
            if (!(length(z) > 0.0f) || !(length(x) > 0.0f)) fail(el, "degenerate lookat");
            const Vec3f zn = z / length(z), xn = x / length(x), yn = cross(zn, xn);
            Mat4f l;
            for (int r = 0; r < 3; ++r) {
                l.m[r][0] = xn[r];
                l.m[r][1] = yn[r];
                l.m[r][2] = zn[r];
                l.m[r][3] = eye[r];
            }
            m = m * l;
        } else if (t == "skew") {
            note(fmt::format("node '{}': <skew> ignored", label(node)));
        }
    }
    if (!matrix_finite(m)) fail(node, "transform is not finite");
    return m;
}

void Loader::enter_node(pugi::xml_node node, uint32_t depth) {
    if (depth > limits_.max_node_depth)
        fail(node, fmt::format("nodes nested deeper than {} (instance_node cycle?)",
                               limits_.max_node_depth));
    if (++node_visits_ > limits_.max_node_visits)
        fail(node, fmt::format("more than {} node instances", limits_.max_node_visits));
}

/// What identifies a prototype: the geometry and its material binding (symbol -> material
/// of each <instance_material>, COLLADA 1.4.1 spec, <bind_material> and
/// <instance_material>). One geometry bound to two sets of materials is two prototypes,
/// since a Prototype's meshes carry their materials.
std::string Loader::placement_key(pugi::xml_node inst, pugi::xml_node geom) {
    std::string key;
    auto put = [&](const void* p) { key.append(reinterpret_cast<const char*>(&p), sizeof p); };
    put(geom.internal_object());
    for (pugi::xml_node im :
         inst.child("bind_material").child("technique_common").children("instance_material")) {
        key += im.attribute("symbol").value();
        key += '\0';
        put(resolve(im, "target", "material").internal_object());
    }
    return key;
}

/// Pass 1 of the instancing: how often the scene places each (geometry, binding), through
/// the same walk as visit (the same limits on depth and visits), so that visit knows at a
/// geometry's first placement whether to flatten it (placed once: the scene is what it
/// was before instancing) or to make it a prototype. COLLADA 1.4.1 spec, <instance_node>
/// and <instance_geometry>: both instantiate a library element in the parent's frame.
void Loader::count_placements(pugi::xml_node node, uint32_t depth) {
    enter_node(node, depth);
    for (pugi::xml_node c : node.children()) {
        const std::string_view t = c.name();
        if (t == "node") {
            count_placements(c, depth + 1);
        } else if (t == "instance_node") {
            count_placements(resolve(c, "url", "node"), depth + 1);
        } else if (t == "instance_geometry") {
            Reuse& r = reuse_[placement_key(c, resolve(c, "url", "geometry"))];
            if (++r.placements == 2) expected_instances_ += 2;
            else if (r.placements > 2) ++expected_instances_;
        }
    }
}

void Loader::visit(pugi::xml_node node, const Mat4f& parent, uint32_t depth) {
    enter_node(node, depth);
    bool camera_only = false;
    for (pugi::xml_node c : node.children()) {
        const std::string_view t = c.name();
        if (t == "instance_camera") camera_only = true;
        if (t == "node" || t == "instance_node" || t == "instance_geometry" ||
            t == "instance_light" || t == "instance_controller") {
            camera_only = false;
            break;
        }
    }
    const Mat4f world = parent * local_transform(node, camera_only);
    if (!matrix_finite(world)) fail(node, "world transform is not finite");
    for (pugi::xml_node c : node.children()) {
        const std::string_view t = c.name();
        if (t == "node")
            visit(c, world, depth + 1);
        else if (t == "instance_node") {
            ++instance_node_depth_;
            visit(resolve(c, "url", "node"), world, depth + 1);
            --instance_node_depth_;
        }
        else if (t == "instance_geometry")
            instance_geometry(c, node, world);
        else if (t == "instance_camera")
            instance_camera(c, node, world);
        else if (t == "instance_light")
            instance_light(c, node, world);
        else if (t == "instance_controller")
            instance_controller(c, node, world);
    }
}

/// A skinned or morphed mesh (<instance_controller>), placed as its geometry stands
/// before the controller acts, as the glTF loader places skins and morph targets: a
/// <skin> in its bind pose, the source geometry times the skin's bind_shape_matrix in
/// world space (linear blend skinning with every joint at its bind transform, its world
/// matrix times its inverse bind matrix the identity, leaves the vertices there,
/// whatever node holds the controller); a <morph> as its base geometry under the node's
/// transform. A note names each: the skeleton's pose and the morph weights are not applied.
void Loader::instance_controller(pugi::xml_node inst, pugi::xml_node node, const Mat4f& world) {
    pugi::xml_node ctrl = resolve(inst, "url", "controller");
    Mat4f place = world;
    // A skin's source may be a morph controller; a chain longer than that is refused.
    for (int depth = 0;; ++depth) {
        if (depth == 4) fail(ctrl, "controllers nested more than 4 deep");
        if (pugi::xml_node skin = ctrl.child("skin")) {
            place = Mat4f{};
            if (pugi::xml_node bsm = skin.child("bind_shape_matrix")) {
                float v[16];
                read_floats(bsm, v, 16);
                for (int i = 0; i < 16; ++i) place.m[i / 4][i % 4] = v[i];  // row-major in the file
                if (!matrix_finite(place)) fail(bsm, "is not finite");
            }
            pugi::xml_node src = resolve(skin, "source", nullptr);
            if (std::strcmp(src.name(), "geometry") == 0) {
                note(fmt::format("node '{}': skinned geometry '{}' placed in its bind pose (the skeleton's pose "
                                 "is not applied)",
                                 label(node), label(src)));
                return instance_geometry(inst, node, place, src);
            }
            if (std::strcmp(src.name(), "controller") != 0)
                fail(skin, fmt::format("source refers to a <{}>, expected a <geometry> or <controller>", clip(src.name())));
            ctrl = src;
        } else if (pugi::xml_node morph = ctrl.child("morph")) {
            pugi::xml_node src = resolve(morph, "source", "geometry");
            note(fmt::format("node '{}': morphed geometry '{}' placed in its base shape (the morph weights are "
                             "not applied)",
                             label(node), label(src)));
            return instance_geometry(inst, node, place, src);
        } else {
            fail(ctrl, "has neither <skin> nor <morph>");
        }
    }
}

/// One placement of a <geometry> (`geom`; by default the one `inst` names) by `world`.
void Loader::instance_geometry(pugi::xml_node inst, pugi::xml_node node, const Mat4f& world, pugi::xml_node geom) {
    if (!geom) geom = resolve(inst, "url", "geometry");
    const LocalGeometry& g = geometry(geom);

    std::vector<std::pair<std::string_view, uint32_t>> binds;
    for (pugi::xml_node im :
         inst.child("bind_material").child("technique_common").children("instance_material"))
        binds.emplace_back(im.attribute("symbol").value(),
                           material_index(resolve(im, "target", "material")));

    Reuse& reuse = reuse_[placement_key(inst, geom)];
    if (g.is_sphere) {
        // A Sphere has no object space in the scene model: a reused one is copied.
        if (reuse.placements > 1) ++copied_spheres_;
        const double det = det3(world);
        if (!std::isfinite(det) || det == 0.0) fail(node, "sphere instance has a singular transform");
        const float scale = float(std::cbrt(std::fabs(det)));
        const float sx = length(world.transform_vector({1, 0, 0}));
        const float sy = length(world.transform_vector({0, 1, 0}));
        const float sz = length(world.transform_vector({0, 0, 1}));
        if (std::max({sx, sy, sz}) > 1.001f * std::min({sx, sy, sz}))
            note(fmt::format("node '{}': sphere under non-uniform scale ({:g}, {:g}, {:g}) uses "
                             "radius scale {:g}",
                             label(node), sx, sy, sz, scale));
        Sphere s;
        s.center = world.transform_point({0, 0, 0});
        s.radius = g.radius * scale;
        if (!accel::is_finite(s.center) || !std::isfinite(s.radius) || !(s.radius > 0.0f))
            fail(node, "sphere centre or radius is not finite");
        s.material = binds.empty() ? default_material() : binds.front().second;
        scene_.spheres.push_back(s);
        return;
    }

    // Placed more than once: an Instance of the geometry's Prototype. A projective world
    // matrix (a <matrix> whose bottom row is not 0 0 0 1) has no Affine3f, so that
    // placement is flattened below, as before.
    const bool affine = world.m[3][0] == 0.0f && world.m[3][1] == 0.0f && world.m[3][2] == 0.0f &&
                        world.m[3][3] == 1.0f;
    if (reuse.placements > 1 && affine) {
        Reuse& r = reuse;
        if (r.prototype == kNone) r.prototype = prototype(g, binds, inst, node);
        if (r.prototype == kEmpty) return;  // no triangles: nothing to place, as before
        const Affine3f x = Affine3f::from(world);
        // No inverse, no instance: tracing one carries the ray into object space. A mirror
        // (det < 0) is kept; the renderer flips the normal, flatten_instances the winding.
        if (!x.finite() || !x.inverse().finite()) {
            note(fmt::format("node '{}': singular or non-finite transform; its instance of geometry '{}' dropped",
                             label(node), g.name));
            return;
        }
        // As a flattened copy would be refused: every placed corner of the box is finite.
        const Bounds3f& b = prototype_bounds_[r.prototype];
        for (int c = 0; c < 8; ++c)
            if (!accel::is_finite(
                    x.point({c & 1 ? b.hi.x : b.lo.x, c & 2 ? b.hi.y : b.lo.y, c & 4 ? b.hi.z : b.lo.z})))
                fail(node, "transformed vertex position is not finite");
        if (scene_.instances.size() >= limits_.max_instances)
            fail(inst, fmt::format("scene places more than {} instances", limits_.max_instances));
        // One allocation of pass 1's count instead of a doubling vector's copies.
        if (scene_.instances.empty())
            scene_.instances.reserve(size_t(std::min(expected_instances_, limits_.max_instances)));
        scene_.instances.push_back(Instance{r.prototype, x});
        return;
    }

    // Normals go through the inverse transpose; compute it once per instance.
    const Mat4f inv = world.inverse();
    const bool invertible = matrix_finite(inv);
    for (const LocalGroup& grp : g.groups) {
        if (grp.indices.empty()) continue;
        count_triangles(inst, grp.indices.size() / 3);
        const uint32_t mat = bound_material(grp, g, binds, node);
        Mesh mesh;
        mesh.name = g.groups.size() > 1 ? fmt::format("{}/{}", label(node), clip(grp.symbol))
                                        : label(node);
        mesh.material = mat;
        mesh.positions.reserve(grp.positions.size() + 1);
        for (const Vec3f& p : grp.positions) {
            const Vec3f w = world.transform_point(p);
            if (!accel::is_finite(w)) fail(node, "transformed vertex position is not finite");
            mesh.positions.push_back(w);
        }
        mesh.pad_positions();
        mesh.indices = grp.indices;
        mesh.uvs = uvs_for(grp, mat);
        if (!grp.normals.empty()) {
            bool ok = invertible;
            if (ok) {
                mesh.normals.reserve(grp.normals.size());
                for (const Vec3f& n : grp.normals) {
                    const Vec3f w{inv.m[0][0] * n.x + inv.m[1][0] * n.y + inv.m[2][0] * n.z,
                                  inv.m[0][1] * n.x + inv.m[1][1] * n.y + inv.m[2][1] * n.z,
                                  inv.m[0][2] * n.x + inv.m[1][2] * n.y + inv.m[2][2] * n.z};
                    const float len = length(w);
                    if (!(len > 0.0f) || !std::isfinite(len)) {
                        ok = false;
                        break;
                    }
                    mesh.normals.push_back(w / len);
                }
            }
            if (!ok) {
                mesh.normals = {};
                note(fmt::format("node '{}': zero-length normals or singular transform; using "
                                 "geometric normals",
                                 label(node)));
            }
        }
        scene_.meshes.push_back(std::move(mesh));
    }
}

/// The material `binds` gives a group's symbol, or the default grey (noted).
uint32_t Loader::bound_material(const LocalGroup& grp, const LocalGeometry& g,
                                const std::vector<std::pair<std::string_view, uint32_t>>& binds,
                                pugi::xml_node node) {
    for (const auto& [sym, idx] : binds)
        if (sym == grp.symbol) return idx;
    if (!grp.symbol.empty())
        note(fmt::format("node '{}': material symbol '{}' of geometry '{}' is not bound; "
                         "using default grey",
                         label(node), clip(grp.symbol), g.name));
    return default_material();
}

/// The Prototype of a geometry under one material binding, built at its first
/// placement: one object-space mesh per material group, appended contiguously to
/// Scene::meshes, named after the geometry (a flattened copy is named after its node).
/// Its triangles count once against max_triangles however often it is placed.
uint32_t Loader::prototype(const LocalGeometry& g, const std::vector<std::pair<std::string_view, uint32_t>>& binds,
                           pugi::xml_node inst, pugi::xml_node node) {
    const uint32_t first = uint32_t(scene_.meshes.size());
    Bounds3f box;
    for (const LocalGroup& grp : g.groups) {
        if (grp.indices.empty()) continue;
        count_triangles(inst, grp.indices.size() / 3);
        Mesh mesh;
        mesh.name = g.groups.size() > 1 ? fmt::format("{}/{}", g.name, clip(grp.symbol)) : g.name;
        mesh.material = bound_material(grp, g, binds, node);
        mesh.positions.reserve(grp.positions.size() + 1);
        mesh.positions.assign(grp.positions.begin(), grp.positions.end());
        for (const Vec3f& p : grp.positions) box.extend(p);
        mesh.pad_positions();
        mesh.indices = grp.indices;
        mesh.uvs = uvs_for(grp, mesh.material);
        // Unit normals, as a flattened copy under the identity gets them.
        mesh.normals.reserve(grp.normals.size());
        for (const Vec3f& n : grp.normals) {
            const float len = length(n);
            if (!(len > 0.0f) || !std::isfinite(len)) {
                mesh.normals = {};
                note(fmt::format("geometry '{}': zero-length normals; using geometric normals", g.name));
                break;
            }
            mesh.normals.push_back(n / len);
        }
        scene_.meshes.push_back(std::move(mesh));
    }
    if (scene_.meshes.size() == first) return kEmpty;
    scene_.prototypes.push_back(Prototype{g.name, first, uint32_t(scene_.meshes.size() - first)});
    prototype_bounds_.push_back(box);
    return uint32_t(scene_.prototypes.size() - 1);
}

void Loader::instance_camera(pugi::xml_node inst, pugi::xml_node node, const Mat4f& world) {
    pugi::xml_node cam = resolve(inst, "url", "camera");
    if (scene_.camera) {
        note(fmt::format("node '{}': extra camera ignored (the first one is used)", label(node)));
        return;
    }
    pugi::xml_node persp = cam.child("optics").child("technique_common").child("perspective");
    pugi::xml_node ortho = cam.child("optics").child("technique_common").child("orthographic");
    if (!persp && !ortho) {
        note(fmt::format("camera '{}' is neither perspective nor orthographic; ignored", label(cam)));
        return;
    }
    Camera c;
    c.name = label(node);
    c.camera_to_world = world;
    if (!persp) {
        // COLLADA 1.4.1, 5-92: xmag, ymag (half extents) and aspect_ratio, any two of them.
        c.orthographic = true;
        const auto mag = [&](const char* tag, float& out) {
            if (pugi::xml_node e = ortho.child(tag)) {
                out = std::abs(read_float(e));
                if (!(out > 0.0f)) fail(e, "must not be zero");
            }
        };
        mag("xmag", c.xmag);
        mag("ymag", c.ymag);
        if (pugi::xml_node a = ortho.child("aspect_ratio")) {
            const float r = read_float(a);
            if (!(r > 0.0f)) fail(a, "must be positive");
            if (c.ymag == 0.0f && c.xmag > 0.0f) c.ymag = c.xmag / r;
            if (c.xmag == 0.0f && c.ymag > 0.0f) c.xmag = c.ymag * r;
        }
        if (c.xmag == 0.0f && c.ymag == 0.0f) fail(ortho, "has neither <xmag> nor <ymag>");
    }
    const bool affine = world.m[3][0] == 0.0f && world.m[3][1] == 0.0f &&
                        world.m[3][2] == 0.0f && world.m[3][3] == 1.0f;
    if (!affine || std::fabs(det3(world)) < 1e-9) {
        // A broken camera matrix (see local_transform) still says where the camera is
        // and, through its Z column, where it looks; rebuild a right-handed basis around
        // that with the file's up axis, which is what the course's framing relies on.
        const Vec3f z{world.m[0][2], world.m[1][2], world.m[2][2]};
        Vec3f x = cross(scene_.up, z);
        if (!(length(z) > 0.0f) || !(length(x) > 0.0f) || !accel::is_finite(x)) {
            note(fmt::format("camera node '{}' has a degenerate transform; camera ignored",
                             c.name));
            return;
        }
        const Vec3f zn = z / length(z), xn = x / length(x), yn = cross(zn, xn);
        Mat4f r;
        for (int i = 0; i < 3; ++i) {
            r.m[i][0] = xn[i];
            r.m[i][1] = yn[i];
            r.m[i][2] = zn[i];
            r.m[i][3] = world.m[i][3];
        }
        c.camera_to_world = r;
        note(fmt::format("camera node '{}': singular or projective transform; rebuilt from its "
                         "view direction and the up axis",
                         c.name));
    }
    if (c.orthographic) {
        scene_.camera = c;
        return;
    }
    auto fov = [&](const char* tag, float& out) {
        pugi::xml_node e = persp.child(tag);
        if (!e) return false;
        out = read_float(e);
        if (!(out > 0.0f && out < 180.0f)) fail(e, fmt::format("{} {} is not in (0, 180) degrees", tag, out));
        return true;
    };
    float xfov = 0, yfov = 0;
    const bool hx = fov("xfov", xfov), hy = fov("yfov", yfov);
    if (pugi::xml_node a = persp.child("aspect_ratio")) {
        c.aspect = read_float(a);
        if (!(c.aspect > 0.0f)) fail(a, "aspect_ratio must be positive");
    }
    if (hy) c.yfov_deg = yfov;
    if (hx) {
        c.xfov_deg = xfov;
    } else if (hy && c.aspect > 0.0f) {
        const double t = std::tan(double(yfov) * std::numbers::pi / 360.0) * c.aspect;
        c.xfov_deg = float(2.0 * std::atan(t) * 180.0 / std::numbers::pi);
    } else {
        note(fmt::format("camera '{}': no xfov; using {:g} degrees", c.name, c.xfov_deg));
    }
    if (pugi::xml_node z = persp.child("znear")) c.znear = read_float(z);
    if (pugi::xml_node z = persp.child("zfar")) c.zfar = read_float(z);
    if (!(c.znear >= 0.0f) || !(c.zfar > c.znear))
        fail(persp, fmt::format("znear {:g} / zfar {:g} are not a valid range", c.znear, c.zfar));
    scene_.camera = c;
}

void Loader::instance_light(pugi::xml_node inst, pugi::xml_node node, const Mat4f& world) {
    pugi::xml_node light = resolve(inst, "url", "light");
    if (instance_node_depth_ > 0) ++copied_lights_;  // lights are not instanced
    // The CGL technique is the course's own description and wins over technique_common.
    pugi::xml_node kind = first_element(cgl_technique(light));
    if (!kind) kind = first_element(light.child("technique_common"));
    if (!kind) {
        note(fmt::format("light '{}' has no type; ignored", label(light)));
        return;
    }
    const std::string_view t = kind.name();
    Light l;
    l.name = label(light);
    if (pugi::xml_node c = first_of(kind, {"color", "radiance", "intensity"})) l.radiance = read_color(c);
    const Vec3f origin = world.transform_point({0, 0, 0});
    const Vec3f fwd = world.transform_vector({0, 0, -1});
    auto unit = [&](Vec3f v) {
        const float len = length(v);
        if (!(len > 0.0f) || !std::isfinite(len)) fail(node, fmt::format("{} light has a degenerate direction", t));
        return v / len;
    };
    if (t == "area") {
        l.type = LightType::Area;
        l.position = origin;
        l.direction = unit(fwd);
        l.edge_v = world.transform_vector({0, 1, 0});
        l.edge_u = world.transform_vector(cross(Vec3f{0, 1, 0}, Vec3f{0, 0, -1}));
        if (!(length(cross(l.edge_u, l.edge_v)) > 0.0f) || !accel::is_finite(l.edge_u) ||
            !accel::is_finite(l.edge_v))
            fail(node, "area light rectangle is degenerate (zero scale?)");
    } else if (t == "point") {
        l.type = LightType::Point;
        l.position = origin;
    } else if (t == "directional") {
        l.type = LightType::Directional;
        l.direction = unit(fwd);
    } else if (t == "spot") {
        l.type = LightType::Spot;
        l.position = origin;
        l.direction = unit(fwd);
        // falloff_angle is the full cone angle (as Blender writes spot_size); the inner
        // cone is not described, so the edge is softened over the outer 20%.
        if (pugi::xml_node f = first_of(kind, {"falloff_angle", "falloff_deg", "falloff"})) {
            const float deg = read_float(f);
            if (!(deg > 0.0f && deg <= 360.0f)) fail(f, fmt::format("spot angle {:g} is absurd", deg));
            const double half = std::min(double(deg), 180.0) * std::numbers::pi / 360.0;
            l.spot_cos_outer = float(std::cos(half));
            l.spot_cos_inner = float(std::cos(0.8 * half));
        }
    } else if (t == "ambient") {
        l.type = LightType::Environment;
    } else {
        note(fmt::format("light '{}': unknown type <{}> ignored", l.name, clip(t)));
        return;
    }
    scene_.lights.push_back(l);
}

Scene Loader::run() {
    scene_.source = name_;
    scene_.format = SceneFormat::Collada;
    const pugi::xml_parse_result r = doc_.load_buffer(data_, size_, pugi::parse_default);
    if (!r) {
        const int line = line_of_offset(r.offset);
        throw SceneError(fmt::format("{}:{}: malformed XML: {} (byte {})", name_, line,
                                     r.description(), r.offset));
    }
    pugi::xml_node root = doc_.document_element();
    if (std::strcmp(root.name(), "COLLADA") != 0)
        fail(root, "not a COLLADA document (root element is not <COLLADA>)");
    index_ids();
    textured_effects_ = any_diffuse_texture();
    dir_ = std::filesystem::path(name_).parent_path().string();

    if (pugi::xml_node ua = root.child("asset").child("up_axis")) {
        const std::string_view v = trimmed(ua.child_value());
        if (v == "Z_UP") scene_.up = {0, 0, 1};
        else if (v == "Y_UP") scene_.up = {0, 1, 0};
        else if (v == "X_UP") scene_.up = {1, 0, 0};
        else note(fmt::format("unknown up_axis '{}'; using Y_UP", clip(v)));
    }

    pugi::xml_node vs;
    if (pugi::xml_node ivs = root.child("scene").child("instance_visual_scene"))
        vs = resolve(ivs, "url", "visual_scene");
    else
        vs = root.child("library_visual_scenes").child("visual_scene");
    if (!vs) throw SceneError(fmt::format("{}: empty scene: no <visual_scene>", name_));

    for (pugi::xml_node n : vs.children("node")) count_placements(n, 1);
    node_visits_ = 0;
    for (pugi::xml_node n : vs.children("node")) visit(n, Mat4f{}, 1);
    if (!scene_.instances.empty())
        note(fmt::format("instancing: {} instances of {} geometries placed more than once (by several "
                         "<instance_geometry> or through <instance_node>), each stored once, in object space",
                         scene_.instances.size(), scene_.prototypes.size()));
    if (copied_spheres_)
        note(fmt::format("{} placements of reused sphere geometries copied into world space (spheres are "
                         "not instanced)",
                         copied_spheres_));
    if (copied_lights_)
        note(fmt::format("{} lights under <instance_node> copied into world space (lights are not instanced)",
                         copied_lights_));

    if (scene_.world_triangles() + scene_.instanced_triangles() == 0 && scene_.spheres.empty())
        throw SceneError(fmt::format("{}: empty scene: <visual_scene id=\"{}\"> instances no "
                                     "triangles or spheres",
                                     name_, clip(vs.attribute("id").value())));
    if (dropped_notes_)
        scene_.notes.push_back(fmt::format("... and {} more notes", dropped_notes_));
    return std::move(scene_);
}

}  // namespace

Scene load_collada_memory(const void* data, size_t size, const std::string& name,
                          const ColladaLimits& limits) {
    Loader loader(static_cast<const char*>(data), size, name, limits);
    return loader.run();
}

Scene load_collada_memory(const void* data, size_t size, const std::string& name) {
    return load_collada_memory(data, size, name, ColladaLimits{});
}

Scene load_collada(const std::string& path) {
    std::error_code ec;
    if (std::filesystem::is_directory(path, ec))
        throw SceneError(fmt::format("{}: is a directory, not a .dae file", path));
    std::ifstream in(path, std::ios::binary);
    if (!in) throw SceneError(fmt::format("{}: cannot open file: {}", path, std::strerror(errno)));
    in.seekg(0, std::ios::end);
    const std::streamoff len = in.tellg();
    if (len < 0) throw SceneError(fmt::format("{}: cannot read file", path));
    if (uint64_t(len) > (uint64_t(1) << 31))
        throw SceneError(fmt::format("{}: file is larger than 2 GiB", path));
    in.seekg(0, std::ios::beg);
    std::string buf(size_t(len), '\0');
    if (len > 0 && !in.read(buf.data(), len)) throw SceneError(fmt::format("{}: read error", path));
    return load_collada_memory(buf.data(), buf.size(), path);
}

}  // namespace scenes
