#include "renderer/ray_record.h"

#include <cmath>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <type_traits>

#include <fmt/format.h>

#include "renderer/whole_file.h"

namespace renderer {

namespace {

constexpr char kMagic[8] = {'P', 'T', 'R', 'A', 'Y', 'R', 'E', 'C'};
constexpr uint32_t kVersion = 1;

/// The file's first 40 bytes; the closest-hit rays follow, then the any-hit rays, each a
/// Ray as laid out in memory (little-endian, the only byte order this renderer builds for).
struct Header {
    char magic[8];
    uint32_t version, ray_bytes;
    uint64_t scene_primitives, closest, any_hit;
};
static_assert(sizeof(Header) == 40);
static_assert(std::is_trivially_copyable_v<accel::Ray> && sizeof(accel::Ray) == 32);

bool finite(const accel::Ray& r) {
    for (int a = 0; a < 3; ++a)
        if (!std::isfinite(r.org[a]) || !std::isfinite(r.dir[a])) return false;
    return !std::isnan(r.t_min) && !std::isnan(r.t_max);
}

}  // namespace

RayRecord read_ray_record(const std::string& path) {
    std::ifstream in(path, std::ios::binary | std::ios::ate);
    if (!in) throw std::invalid_argument(fmt::format("{}: cannot open ray record", path));
    const uint64_t size = uint64_t(in.tellg());
    in.seekg(0);
    Header h{};
    if (size < sizeof h || !in.read(reinterpret_cast<char*>(&h), sizeof h) ||
        std::memcmp(h.magic, kMagic, sizeof kMagic) != 0)
        throw std::invalid_argument(fmt::format("{}: not a ray record (pathtracer --record-rays)", path));
    if (h.version != kVersion || h.ray_bytes != sizeof(accel::Ray))
        throw std::invalid_argument(fmt::format("{}: ray record version {} with {}-byte rays, this build reads "
                                                "version {} with {}-byte rays",
                                                path, h.version, h.ray_bytes, kVersion, sizeof(accel::Ray)));
    // Counts first checked against the file's size, so a damaged header cannot ask for
    // more memory than the file could hold.
    const uint64_t body = size - sizeof h;
    if (h.closest > body / sizeof(accel::Ray) || h.any_hit > body / sizeof(accel::Ray) ||
        (h.closest + h.any_hit) * sizeof(accel::Ray) != body)
        throw std::invalid_argument(fmt::format("{}: {} bytes of rays, the header counts {} + {} rays of {} bytes",
                                                path, body, h.closest, h.any_hit, sizeof(accel::Ray)));
    RayRecord r;
    r.scene_primitives = h.scene_primitives;
    r.closest.resize(h.closest);
    r.any_hit.resize(h.any_hit);
    in.read(reinterpret_cast<char*>(r.closest.data()), std::streamsize(h.closest * sizeof(accel::Ray)));
    in.read(reinterpret_cast<char*>(r.any_hit.data()), std::streamsize(h.any_hit * sizeof(accel::Ray)));
    if (!in) throw std::invalid_argument(fmt::format("{}: read failed", path));
    for (const auto* rays : {&r.closest, &r.any_hit})
        for (size_t i = 0; i < rays->size(); ++i)
            if (!finite((*rays)[i]))
                throw std::invalid_argument(fmt::format("{}: {} ray {} is not finite", path,
                                                        rays == &r.closest ? "closest-hit" : "any-hit", i));
    return r;
}

RayRecord read_ray_record_for(const std::string& path, const scenes::Scene& scene) {
    RayRecord r = read_ray_record(path);
    if (r.scene_primitives != scene_primitives(scene))
        throw std::invalid_argument(fmt::format("{}: recorded in a scene of {} primitives, this one has {}", path,
                                                r.scene_primitives, scene_primitives(scene)));
    return r;
}

void write_ray_record(const std::string& path, const RayRecord& r) {
    Header h{};
    std::memcpy(h.magic, kMagic, sizeof kMagic);
    h.version = kVersion;
    h.ray_bytes = sizeof(accel::Ray);
    h.scene_primitives = r.scene_primitives;
    h.closest = r.closest.size();
    h.any_hit = r.any_hit.size();
    const std::string error = write_file_whole(path, "ray record",
                                               {std::as_bytes(std::span(&h, 1)), std::as_bytes(std::span(r.closest)),
                                                std::as_bytes(std::span(r.any_hit))});
    if (!error.empty()) throw std::runtime_error(error);
}

RayRecorder::RayRecorder(const accel::Accelerator& inner, uint64_t max_per_kind)
    : inner_(inner), max_(max_per_kind) {}

void RayRecorder::keep(std::atomic<uint64_t>& taken, std::vector<accel::Ray>& into, const accel::Ray& ray) const {
    if (taken.load(std::memory_order_relaxed) >= max_) return;
    if (taken.fetch_add(1, std::memory_order_relaxed) < max_) into.push_back(ray);
}

bool RayRecorder::intersect(const accel::Ray& ray, accel::Hit& hit, accel::TraceStats& stats) const {
    keep(closest_taken_, buffers_.local().closest, ray);
    return inner_.intersect(ray, hit, stats);
}

bool RayRecorder::occluded(const accel::Ray& ray, accel::TraceStats& stats) const {
    keep(any_hit_taken_, buffers_.local().any_hit, ray);
    return inner_.occluded(ray, stats);
}

RayRecord RayRecorder::record(uint64_t scene_primitives) const {
    RayRecord r;
    r.scene_primitives = scene_primitives;
    for (const Buffers& b : buffers_) {
        r.closest.insert(r.closest.end(), b.closest.begin(), b.closest.end());
        r.any_hit.insert(r.any_hit.end(), b.any_hit.begin(), b.any_hit.end());
    }
    return r;
}

}  // namespace renderer
