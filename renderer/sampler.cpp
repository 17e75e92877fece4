#include "renderer/sampler.h"

#include <immintrin.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>

namespace renderer {

namespace {

/// The bytes reversed by one instruction (bswap), then the bits within each byte: three
/// swap steps instead of five, on every scrambled draw.
[[gnu::always_inline]] inline uint32_t reverse_bits(uint32_t v) {
    v = __builtin_bswap32(v);
    v = ((v >> 1) & 0x55555555u) | ((v & 0x55555555u) << 1);
    v = ((v >> 2) & 0x33333333u) | ((v & 0x33333333u) << 2);
    return ((v >> 4) & 0x0F0F0F0Fu) | ((v & 0x0F0F0F0Fu) << 4);
}

/// The same on both halves of a 64-bit word at once, each half staying in its place
/// (the 64-bit reversal would also swap them): a 2D draw reverses its two coordinates
/// for the price of one.
[[gnu::always_inline]] inline uint64_t reverse_halves(uint64_t v) {
    v = __builtin_bswap64(v);
    v = (v >> 32) | (v << 32);
    v = ((v >> 1) & 0x5555555555555555ull) | ((v & 0x5555555555555555ull) << 1);
    v = ((v >> 2) & 0x3333333333333333ull) | ((v & 0x3333333333333333ull) << 2);
    return ((v >> 4) & 0x0F0F0F0F0F0F0F0Full) | ((v & 0x0F0F0F0F0F0F0F0Full) << 4);
}

/// Laine and Karras's hash as Burley 2020 (listing 2) tunes it: bit k of the result is
/// bit k of x flipped by a function of the bits below it (additions and products by even
/// constants carry only upward), so on reversed bits it is a nested uniform (Owen)
/// scramble and keeps every elementary interval of a net.
[[gnu::always_inline]] inline uint32_t laine_karras(uint32_t x, uint32_t seed) {
    x += seed;
    x ^= x * 0x6c50b47cu;
    x ^= x * 0xb82f1e52u;
    x ^= x * 0xc7afe638u;
    x ^= x * 0x8d22f6e6u;
    return x;
}

/// Owen scrambling of a value in [0, 1) as 32-bit fixed point (Burley 2020, section 3).
[[gnu::always_inline]] inline uint32_t owen_scramble(uint32_t v, uint32_t seed) {
    return reverse_bits(laine_karras(reverse_bits(v), seed));
}

/// The same on a sample index (Burley 2020, section 4, "shuffling"): bit k of the index
/// flips by a function of the bits above it, so the aligned blocks of 2^m indices are
/// permuted among themselves and stay blocks, and each block of a (0,2)-sequence stays a
/// (0,m,2)-net: the first 2^m samples of a pixel are still stratified.
/// Takes the index already reversed (PixelSample keeps its sample's reversal), which
/// leaves one reversal per draw.
[[gnu::always_inline]] inline uint32_t shuffle_reversed_index(uint32_t reversed_i,
                                                              uint32_t seed) {
    return reverse_bits(laine_karras(reversed_i, seed));
}

/// Sobol's first dimension, Owen-scrambled: the van der Corput value (the index's bits
/// reversed) through owen_scramble, whose first reversal undoes that one, leaving
/// reverse_bits(laine_karras(i, seed)).
[[gnu::always_inline]] inline uint32_t owen_sobol0(uint32_t i, uint32_t seed) {
    return reverse_bits(laine_karras(i, seed));
}

/// Sobol's second dimension, for the primitive polynomial x + 1: its direction numbers
/// follow from m_k = 2 m_{k-1} xor m_{k-1}, m_1 = 1 (Bratley and Fox 1988), so m_k's bit j
/// is C(k-1, j) mod 2 and the generator matrix is Pascal's triangle mod 2; with sobol0
/// a (0,2)-sequence in base 2. Returned bit-reversed, because an Owen scramble of
/// sobol1(i) starts by reversing it. By Lucas's theorem, reversed output bit c is the XOR
/// of the index bits b whose position contains c's as a bit subset (C(b, c) odd iff
/// c & ~b is 0): a superset-sum (Moebius) transform over the five bits of a bit position,
/// one shift-and-xor step per bit, with no table, so that it vectorises.
[[gnu::always_inline]] inline uint32_t sobol1_reversed(uint32_t i) {
    i ^= (i >> 1) & 0x55555555u;
    i ^= (i >> 2) & 0x33333333u;
    i ^= (i >> 4) & 0x0F0F0F0Fu;
    i ^= (i >> 8) & 0x00FF00FFu;
    i ^= (i >> 16) & 0x0000FFFFu;
    return i;
}

/// Owen-scrambled (sobol0(i), sobol1(i)), each the reversal of laine_karras on the
/// reversed Sobol value, the two reversals made as one (reverse_halves): x in the low
/// half.
[[gnu::always_inline]] inline uint64_t owen_sobol01(uint32_t i, uint32_t seed0,
                                                    uint32_t seed1) {
    return reverse_halves(uint64_t(laine_karras(sobol1_reversed(i), seed1)) << 32 |
                          laine_karras(i, seed0));
}

[[gnu::always_inline]] inline Vec2f to_unit2(uint64_t xy) {
    return {float(uint32_t(xy) >> 8) * 0x1p-24f,
            float(uint32_t(xy >> 32) >> 8) * 0x1p-24f};
}

// The same in the eight 32-bit lanes of an AVX2 register, for vertex_draws_avx2; the
// renderer is built for any x86-64, so these carry their own target and run only where
// the CPU reports AVX2 (Sampler::use_avx2_draws).
#define PT_AVX2 __attribute__((target("avx2")))

PT_AVX2 inline __m256i laine_karras8(__m256i x, __m256i seed) {
    x = _mm256_add_epi32(x, seed);
    x = _mm256_xor_si256(x, _mm256_mullo_epi32(x, _mm256_set1_epi32(int(0x6c50b47cu))));
    x = _mm256_xor_si256(x, _mm256_mullo_epi32(x, _mm256_set1_epi32(int(0xb82f1e52u))));
    x = _mm256_xor_si256(x, _mm256_mullo_epi32(x, _mm256_set1_epi32(int(0xc7afe638u))));
    x = _mm256_xor_si256(x, _mm256_mullo_epi32(x, _mm256_set1_epi32(int(0x8d22f6e6u))));
    return x;
}

/// Bit reversal of each lane: its bytes reversed by one shuffle, then each byte's two
/// nibbles swapped and reversed by a 16-entry table lookup (pshufb).
PT_AVX2 inline __m256i reverse_bits8(__m256i v) {
    const __m256i bytes = _mm256_setr_epi8(3, 2, 1, 0, 7, 6, 5, 4, 11, 10, 9, 8, 15, 14, 13, 12,
                                           3, 2, 1, 0, 7, 6, 5, 4, 11, 10, 9, 8, 15, 14, 13, 12);
    const __m256i nibble = _mm256_setr_epi8(0x0, 0x8, 0x4, 0xC, 0x2, 0xA, 0x6, 0xE, 0x1, 0x9, 0x5, 0xD, 0x3,
                                            0xB, 0x7, 0xF, 0x0, 0x8, 0x4, 0xC, 0x2, 0xA, 0x6, 0xE, 0x1, 0x9,
                                            0x5, 0xD, 0x3, 0xB, 0x7, 0xF);
    const __m256i low4 = _mm256_set1_epi8(0x0F);
    v = _mm256_shuffle_epi8(v, bytes);
    const __m256i lo = _mm256_shuffle_epi8(nibble, _mm256_and_si256(v, low4));
    const __m256i hi = _mm256_shuffle_epi8(nibble, _mm256_and_si256(_mm256_srli_epi16(v, 4), low4));
    return _mm256_or_si256(_mm256_slli_epi16(lo, 4), hi);
}

/// sobol1_reversed in every lane.
PT_AVX2 inline __m256i sobol1_reversed8(__m256i i) {
    i = _mm256_xor_si256(i, _mm256_and_si256(_mm256_srli_epi32(i, 1), _mm256_set1_epi32(0x55555555)));
    i = _mm256_xor_si256(i, _mm256_and_si256(_mm256_srli_epi32(i, 2), _mm256_set1_epi32(0x33333333)));
    i = _mm256_xor_si256(i, _mm256_and_si256(_mm256_srli_epi32(i, 4), _mm256_set1_epi32(0x0F0F0F0F)));
    i = _mm256_xor_si256(i, _mm256_and_si256(_mm256_srli_epi32(i, 8), _mm256_set1_epi32(0x00FF00FF)));
    return _mm256_xor_si256(i, _mm256_and_si256(_mm256_srli_epi32(i, 16), _mm256_set1_epi32(0x0000FFFF)));
}

/// lowbias32 in every lane.
PT_AVX2 inline __m256i lowbias32x8(__m256i x) {
    x = _mm256_xor_si256(x, _mm256_srli_epi32(x, 16));
    x = _mm256_mullo_epi32(x, _mm256_set1_epi32(0x7feb352d));
    x = _mm256_xor_si256(x, _mm256_srli_epi32(x, 15));
    x = _mm256_mullo_epi32(x, _mm256_set1_epi32(int(0x846ca68bu)));
    return _mm256_xor_si256(x, _mm256_srli_epi32(x, 16));
}

/// A third 32-bit seed from a 64-bit key: the high half of its product with an odd
/// constant depends on every bit of the key, at the price of one multiply instead of
/// another mix64.
[[gnu::always_inline]] inline uint32_t third_seed(uint64_t k) {
    return uint32_t((k * 0xD6E8FEB86659FD93ull) >> 32);
}

/// A 32-bit finaliser (lowbias32, Wellons 2018, "Prospecting for hash functions"): two
/// multiplies, for the seeds of a vertex's numbers ("one key per vertex" in
/// renderer/README.md).
[[gnu::always_inline]] inline uint32_t lowbias32(uint32_t x) {
    x ^= x >> 16;
    x *= 0x7feb352du;
    x ^= x >> 15;
    x *= 0x846ca68bu;
    return x ^ (x >> 16);
}

/// Each number of a vertex (its offset from dims::bounce) xors one salt into each half of
/// the vertex's key. The two coordinates of a 2D draw (offsets 1-2 and 4-5) share a
/// shuffle salt, since they share the shuffled index; a number's second coordinate takes
/// the next offset's scramble salt. Lane 7 of the AVX2 form is padding.
alignas(32) constexpr uint32_t kShuffleSalt[8] = {0x3C6EF372u, 0x1B873593u, 0x1B873593u, 0x5BD1E995u,
                                                  0x68E31DA4u, 0x68E31DA4u, 0x7FEB352Du, 0u};
alignas(32) constexpr uint32_t kScrambleSalt[8] = {0x2545F491u, 0x4F1BBCDDu, 0x6A09E667u, 0x510E527Fu,
                                                   0x1F83D9ABu, 0x5BE0CD19u, 0x243F6A88u, 0x85A308D3u};

/// Fixed point to [0, 1): the top 24 bits, so the result is never 1.
[[gnu::always_inline]] inline float to_unit(uint32_t v) {
    return float(v >> 8) * 0x1p-24f;
}

/// A bijection of [0, n) chosen by `seed`: an invertible hash on the enclosing power of
/// two (xor, odd multiply and xorshift are each invertible modulo 2^k), cycle-walked until
/// it lands below n (Kensler 2013, "Correlated Multi-Jittered Sampling", section 3).
uint32_t permute(uint32_t i, uint32_t n, uint32_t seed) {
    if (n <= 1) return 0;
    uint32_t mask = n - 1;
    mask |= mask >> 1;
    mask |= mask >> 2;
    mask |= mask >> 4;
    mask |= mask >> 8;
    mask |= mask >> 16;
    do {
        i ^= seed;
        i = (i * 0xe170893du) & mask;
        i ^= (i >> 4) & mask;
        i ^= seed >> 16;
        i = (i * 0x0929eb3fu) & mask;
        i ^= i >> 1;
        i = (i * (1u | (seed >> 27) << 1)) & mask;
        i ^= i >> 11;
        i = (i * 0x6935fa69u) & mask;
        i ^= i >> 7;
    } while (i >= n);
    return i;
}

/// Interleaves the bits of x and y (x in the even bits).
uint64_t morton2(uint32_t x, uint32_t y) {
    auto spread = [](uint64_t v) {
        v &= 0xFFFFFFFFull;
        v = (v | (v << 16)) & 0x0000FFFF0000FFFFull;
        v = (v | (v << 8)) & 0x00FF00FF00FF00FFull;
        v = (v | (v << 4)) & 0x0F0F0F0F0F0F0F0Full;
        v = (v | (v << 2)) & 0x3333333333333333ull;
        v = (v | (v << 1)) & 0x5555555555555555ull;
        return v;
    };
    return spread(x) | (spread(y) << 1);
}

/// The 24 permutations of the base-4 digits {0, 1, 2, 3}, in lexicographic order.
struct Base4Permutations {
    std::array<std::array<uint8_t, 4>, 24> p{};
    constexpr Base4Permutations() {
        std::array<uint8_t, 4> a{0, 1, 2, 3};
        for (size_t k = 0; k < 24; ++k) {
            p[k] = a;
            // next lexicographic permutation
            int i = 2;
            while (i >= 0 && a[size_t(i)] >= a[size_t(i + 1)]) --i;
            if (i < 0) break;
            int j = 3;
            while (a[size_t(j)] <= a[size_t(i)]) --j;
            std::swap(a[size_t(i)], a[size_t(j)]);
            for (int l = i + 1, r = 3; l < r; ++l, --r) std::swap(a[size_t(l)], a[size_t(r)]);
        }
    }
};
constexpr Base4Permutations kBase4{};

int ceil_log2(uint32_t v) {
    int k = 0;
    while ((uint64_t(1) << k) < v) ++k;
    return k;
}

/// hash3's innermost step, on its last argument alone (Sampler tabulates it per dimension).
uint64_t hash3_inner(uint64_t c) { return mix64(c + 0x9E3779B97F4A7C15ull); }
uint64_t hash3(uint64_t a, uint64_t b, uint64_t c) { return mix64(a ^ mix64(b ^ hash3_inner(c))); }

/// `hashed`'s per-sample part: the sample index and which of a 2D point's coordinates.
uint64_t sample_hash(uint32_t sample, uint32_t which) {
    return mix64((uint64_t(sample) << 2 | which) + 0xD1B54A32D192ED03ull);
}

constexpr uint32_t kZSobolSalt = 0x2D50B01u;

}  // namespace

SamplerKind parse_sampler(const std::string& name) {
    if (name == "independent") return SamplerKind::Independent;
    if (name == "stratified") return SamplerKind::Stratified;
    if (name == "sobol") return SamplerKind::Sobol;
    if (name == "zsobol") return SamplerKind::ZSobol;
    if (name == "pmj02") return SamplerKind::Pmj02;
    throw std::invalid_argument("unknown sampler '" + name +
                                "' (expected independent, stratified, sobol, zsobol or pmj02)");
}

const char* sampler_name(SamplerKind kind) {
    switch (kind) {
        case SamplerKind::Independent: return "independent";
        case SamplerKind::Stratified: return "stratified";
        case SamplerKind::Sobol: return "sobol";
        case SamplerKind::ZSobol: return "zsobol";
        case SamplerKind::Pmj02: return "pmj02";
    }
    return "?";
}

// Christensen, Kensler and Kilpatrick 2018, sections 3 and 5: the sequence doubles in
// turn. Each old point of an n x n grid of squares gets a new one in the diagonally
// opposite quarter of its square (even step), then the two remaining quarters are filled,
// one new point per square at a time (odd step). Inside its quarter a new point takes a
// cell of the finest elementary intervals (1/2N wide and high) that is free in every
// interval shape 2^k x 2^(m-k); the paper draws candidate points until one fits, which is
// the same as drawing uniformly among the free cells, as here. Should no cell be free
// (possible in the odd step), the other quarter is tried, and if that fails the whole
// sequence is drawn again from the next stream.
std::vector<uint32_t> generate_pmj02(uint32_t n, uint64_t seed) {
    for (uint64_t attempt = 0;; ++attempt) {
        Rng rng(seed, 0x504D4A3032ull + attempt);
        std::vector<uint32_t> pts;
        pts.reserve(size_t(2) * n);
        pts.push_back(rng.next_u32());
        pts.push_back(rng.next_u32());
        // occupied[k][cell] for the current resolution 2^m.
        int m = 0;
        std::vector<std::vector<uint8_t>> occupied;
        auto cell = [&](uint32_t X, uint32_t Y, int k) { return (X >> k) + ((Y >> (m - k)) << (m - k)); };
        auto mark = [&](uint32_t x, uint32_t y) {
            const uint32_t X = m ? x >> (32 - m) : 0, Y = m ? y >> (32 - m) : 0;
            for (int k = 0; k <= m; ++k) occupied[size_t(k)][cell(X, Y, k)] = 1;
        };
        auto start = [&](int new_m) {  // resolution for the next 2^new_m points
            m = new_m;
            occupied.assign(size_t(m + 1), std::vector<uint8_t>(size_t(1) << m, 0));
            for (size_t s = 0; s < pts.size(); s += 2) mark(pts[s], pts[s + 1]);
        };
        std::vector<uint32_t> free_x, free_y;
        std::vector<std::pair<uint32_t, uint32_t>> fits;
        // A new point in quarter (xh, yh) of square (i, j) of the 2^g x 2^g grid.
        auto place = [&](uint32_t i, uint32_t j, uint32_t xh, uint32_t yh, int g) {
            const int side = m - 1 - g;  // the quarter spans 2^side finest cells per axis
            const uint32_t X0 = ((i << 1 | xh) << side), Y0 = ((j << 1 | yh) << side);
            free_x.clear();
            free_y.clear();
            for (uint32_t a = 0; a < (1u << side); ++a) {
                if (!occupied[0][cell(X0 + a, 0, 0)]) free_x.push_back(X0 + a);
                if (!occupied[size_t(m)][cell(0, Y0 + a, m)]) free_y.push_back(Y0 + a);
            }
            fits.clear();
            for (uint32_t X : free_x)
                for (uint32_t Y : free_y) {
                    bool ok = true;
                    for (int k = 1; k < m && ok; ++k) ok = !occupied[size_t(k)][cell(X, Y, k)];
                    if (ok) fits.emplace_back(X, Y);
                }
            if (fits.empty()) return false;
            const auto [X, Y] = fits[size_t(rng.next_u32() % uint32_t(fits.size()))];
            const uint32_t low = m < 32 ? 0xFFFFFFFFu >> m : 0;
            const uint32_t x = (X << (32 - m)) | (rng.next_u32() & low);
            const uint32_t y = (Y << (32 - m)) | (rng.next_u32() & low);
            pts.push_back(x);
            pts.push_back(y);
            mark(x, y);
            return true;
        };
        auto square = [](uint32_t v, int g) { return g ? v >> (32 - g) : 0u; };
        auto half = [](uint32_t v, int g) { return (v >> (31 - g)) & 1u; };
        bool stuck = false;
        for (uint32_t N = 1, g = 0; N < n && !stuck; N *= 4, ++g) {
            // Even step: N = 4^g points, one per square of the 2^g grid -> 2N.
            start(ceil_log2(2 * N));
            for (uint32_t s = 0; s < N && !stuck; ++s) {
                const uint32_t x = pts[2 * s], y = pts[2 * s + 1];
                stuck = !place(square(x, int(g)), square(y, int(g)), 1 - half(x, int(g)), 1 - half(y, int(g)), int(g));
            }
            if (2 * N >= n || stuck) break;
            // Odd step: 2N -> 4N, the two quarters left in each square.
            start(ceil_log2(4 * N));
            std::vector<uint8_t> flip_x(N);
            for (uint32_t s = 0; s < N && !stuck; ++s) {
                const uint32_t x = pts[2 * s], y = pts[2 * s + 1];
                const uint32_t i = square(x, int(g)), j = square(y, int(g)), xh = half(x, int(g)), yh = half(y, int(g));
                flip_x[s] = uint8_t(rng.next_u32() & 1u);
                if (!place(i, j, flip_x[s] ? 1 - xh : xh, flip_x[s] ? yh : 1 - yh, int(g))) {
                    flip_x[s] ^= 1u;
                    stuck = !place(i, j, flip_x[s] ? 1 - xh : xh, flip_x[s] ? yh : 1 - yh, int(g));
                }
            }
            for (uint32_t s = 0; s < N && !stuck; ++s) {
                const uint32_t x = pts[2 * s], y = pts[2 * s + 1];
                const uint32_t i = square(x, int(g)), j = square(y, int(g)), xh = half(x, int(g)), yh = half(y, int(g));
                // The quarter diagonal to the one just filled.
                stuck = !place(i, j, flip_x[s] ? xh : 1 - xh, flip_x[s] ? 1 - yh : yh, int(g));
            }
        }
        if (!stuck) {
            pts.resize(size_t(2) * n);
            return pts;
        }
    }
}

Sampler::Sampler(SamplerKind kind, uint64_t seed, int spp, int width, int height)
    : kind_(kind), seed_(seed) {
    lay_out(spp, width, height);
    use_avx2_draws(true);
    if (kind_ == SamplerKind::Pmj02) {
        pmj_.reserve(size_t(2) * kPmjSamples * kPmjTables);
        for (uint32_t t = 0; t < kPmjTables; ++t) {
            const std::vector<uint32_t> table =
                generate_pmj02(kPmjSamples, 0x7AB1E000ull + t);
            pmj_.insert(pmj_.end(), table.begin(), table.end());
        }
    }
    dim_hash_.resize(dims::kLdDimensions);
    for (uint32_t d = 0; d < dims::kLdDimensions; ++d) dim_hash_[d] = hash3_inner(d);
    if (kind_ == SamplerKind::ZSobol) {
        zsobol_scramble_.resize(dims::kLdDimensions);
        for (uint32_t d = 0; d < dims::kLdDimensions; ++d) zsobol_scramble_[d] = hash3(seed_, kZSobolSalt, d);
    }
}

void Sampler::use_avx2_draws(bool on) { avx2_ = on && __builtin_cpu_supports("avx2"); }

Sampler Sampler::with_spp(int spp, int width, int height) const {
    Sampler out = *this;
    out.lay_out(spp, width, height);
    return out;
}

void Sampler::lay_out(int spp, int width, int height) {
    spp_ = uint32_t(std::max(1, spp));
    if (kind_ == SamplerKind::Stratified) {
        // The most square grid of spp strata (pbrt-v4 takes x and y counts; we factor).
        int sx = int(std::sqrt(double(spp_)));
        while (sx > 1 && spp_ % uint32_t(sx) != 0) --sx;
        strata_x_ = std::max(1, sx);
        strata_y_ = int(spp_) / strata_x_;
    } else if (kind_ == SamplerKind::ZSobol) {
        log2_spp_ = ceil_log2(spp_);
        const int res = ceil_log2(uint32_t(std::max({width, height, 1})));
        base4_digits_ = res + (log2_spp_ + 1) / 2;
    }
}

namespace {

uint64_t pixel_key(uint64_t seed, int x, int y, int width) {
    return mix64(seed ^ mix64(uint64_t(y) * uint64_t(width) + uint64_t(x) + 0x632BE59BD9B4E019ull));
}

}  // namespace

PixelSample::PixelSample(const Sampler& sampler, int x, int y, int width, uint32_t sample)
    : PixelSample(sampler, x, y, sample, pixel_key(sampler.seed_, x, y, width)) {}

// The sample's hashes serve `hashed`, every draw of the independent and stratified
// samplers; the others hash only past their low-discrepancy dimensions, so they compute
// them there ("branch samples" in renderer/README.md).
PixelSample::PixelSample(const Sampler& sampler, int x, int y, uint32_t sample, uint64_t key)
    : s_(&sampler),
      pixel_key_(key),
      morton_(0),
      sample_(sample),
      reversed_sample_(reverse_bits(sample)) {
    if (hashes_every_draw()) sample_hash_[0] = sample_hash(sample, 0), sample_hash_[1] = sample_hash(sample, 1);
    if (sampler.kind_ == SamplerKind::ZSobol)
        morton_ = (morton2(uint32_t(x), uint32_t(y)) << sampler.log2_spp_) | uint64_t(sample);
}

PixelSample PixelSample::other_sample(const Sampler& sampler, int x, int y, int width, uint32_t sample) const {
    return PixelSample(sampler, x, y, sample,
                       sampler.seed_ == s_->seed_ ? pixel_key_ : pixel_key(sampler.seed_, x, y, width));
}

// A draw's key: the hash of (seed, pixel) made once per sample, combined with the
// dimension's tabulated hash by one more mixing step, instead of hashing seed, pixel and
// dimension in a chain at every draw ("cheaper draws" in renderer/README.md).
uint64_t PixelSample::key(uint32_t dim) const {
    const uint64_t inner = dim < dims::kLdDimensions ? s_->dim_hash_[dim] : hash3_inner(dim);
    return mix64(pixel_key_ ^ inner);
}

uint64_t PixelSample::vertex_key(uint32_t base) const { return mix64(pixel_key_ ^ s_->dim_hash_[base]); }

// A path vertex's numbers take their seeds from one key per vertex, each number's two
// halves of it salted and finalised by lowbias32 (two multiplies), instead of a 64-bit
// key each: a vertex hashed five keys ("one key per vertex" in renderer/README.md). The
// camera's numbers (pixel and lens) keep a key per draw.
void PixelSample::sobol_seeds(uint32_t dim, uint32_t seeds[3]) const {
    if (dim >= dims::kFirstBounce && dim < dims::kLdDimensions) {
        const uint32_t j = (dim - dims::kFirstBounce) % dims::kPerBounce;
        const uint64_t k = vertex_key(dim - j);
        const uint32_t lo = uint32_t(k), hi = uint32_t(k >> 32);
        seeds[0] = lowbias32(lo ^ kShuffleSalt[j]);
        seeds[1] = lowbias32(hi ^ kScrambleSalt[j]);
        seeds[2] = lowbias32(hi ^ kScrambleSalt[j + 1]);
        return;
    }
    const uint64_t k = key(dim);
    seeds[0] = uint32_t(k), seeds[1] = uint32_t(k >> 32), seeds[2] = third_seed(k);
}

float PixelSample::hashed(uint32_t dim, uint32_t which) const {
    const uint64_t h = mix64(key(dim) ^ (hashes_every_draw() ? sample_hash_[which] : sample_hash(sample_, which)));
    return to_unit(uint32_t(h >> 32));
}

namespace {

/// ZSobol's sample index for `dim` (Ahmed and Wonka 2020, as pbrt-v4 8.7.7 writes it):
/// the Morton index of (pixel, sample) with each base-4 digit permuted by one of the 24
/// permutations, chosen by a hash of the digits above it and the dimension. Pixels that
/// are neighbours on the Morton curve take neighbouring blocks of one Sobol sequence, so
/// their samples are stratified against each other as well.
uint64_t zsobol_index(uint64_t morton, int digits, int log2_spp, uint32_t dim, uint64_t seed) {
    uint64_t index = 0;
    const bool odd = (log2_spp & 1) != 0;  // spp = 2 * 4^k: the lowest "digit" is one bit
    const int last = odd ? 1 : 0;
    const uint64_t salt = mix64(seed ^ (0x55555555ull * (uint64_t(dim) + 1)));
    for (int i = digits - 1; i >= last; --i) {
        const int shift = 2 * i - (odd ? 1 : 0);
        const uint64_t digit = (morton >> shift) & 3u;
        const uint64_t higher = morton >> (shift + 2);
        const size_t p = size_t(mix64(higher ^ salt) >> 32) % 24u;
        index |= uint64_t(kBase4.p[p][size_t(digit)]) << shift;
    }
    if (odd) index |= (morton & 1u) ^ (mix64((morton >> 1) ^ salt) & 1u);
    return index;
}

}  // namespace

// Every PMJ02 table has the same skeleton (each new point goes diagonally opposite an old
// one), so two dimensions that read their tables at the same index are correlated, worse
// than independent (measured: 1.6x the independent sampler's RMSE on CBbunny at 64 spp).
// Unlike Sobol, these sequences are nets only in their power-of-two prefixes, not in
// every aligned block, so Burley's index shuffle would break the stratification. So each
// (pixel, dimension) reads the first spp points of its table in its own random order, as
// pbrt-v4 pads its PMJ02BN and Sobol samplers: the spp samples of a pixel are a (0,2)-net
// for a power-of-two spp, and a pixel stopped early by adaptive sampling holds a random
// subset of them (unbiased, less stratified).
const uint32_t* PixelSample::pmj_point(const Sampler& s, uint32_t dim, uint32_t sample, uint64_t k) {
    const uint32_t round = sample / s.spp_;
    const uint32_t index = round * s.spp_ + permute(sample % s.spp_, s.spp_, uint32_t(k >> 16) ^ round);
    const uint32_t t = (dim + index / kPmjSamples) % kPmjTables, i = index % kPmjSamples;
    return &s.pmj_[(size_t(t) * kPmjSamples + i) * 2];
}

float PixelSample::get1d(uint32_t dim) const {
    const Sampler& s = *s_;
    if (dim >= dims::kLdDimensions) return hashed(dim, 0);
    switch (s.kind_) {
        case SamplerKind::Independent: return hashed(dim, 0);
        case SamplerKind::Stratified: {
            const uint64_t k = key(dim);
            const uint32_t stratum = permute(sample_ % s.spp_, s.spp_, uint32_t(k));
            return std::min((float(stratum) + hashed(dim, 0)) / float(s.spp_), 0x1.fffffep-1f);
        }
        case SamplerKind::Sobol: {
            uint32_t seed[3];
            sobol_seeds(dim, seed);
            return to_unit(owen_sobol0(shuffle_reversed_index(reversed_sample_, seed[0]), seed[1]));
        }
        case SamplerKind::ZSobol: {
            const uint64_t i = zsobol_index(morton_, s.base4_digits_, s.log2_spp_, dim, s.seed_);
            const uint64_t h = s.zsobol_scramble_[dim];
            return to_unit(owen_sobol0(uint32_t(i), uint32_t(h)));
        }
        case SamplerKind::Pmj02: {
            const uint64_t k = key(dim);
            const uint32_t* p = pmj_point(s, dim, sample_, k);
            return to_unit(owen_scramble(p[0], uint32_t(k)));
        }
    }
    return 0.0f;
}

Vec2f PixelSample::get2d(uint32_t dim) const {
    const Sampler& s = *s_;
    if (dim >= dims::kLdDimensions) return {hashed(dim, 0), hashed(dim, 1)};
    switch (s.kind_) {
        case SamplerKind::Independent: return {hashed(dim, 0), hashed(dim, 1)};
        case SamplerKind::Stratified: {
            const uint64_t k = key(dim);
            const uint32_t stratum = permute(sample_ % s.spp_, s.spp_, uint32_t(k));
            const float sx = float(stratum % uint32_t(s.strata_x_)), sy = float(stratum / uint32_t(s.strata_x_));
            return {std::min((sx + hashed(dim, 0)) / float(s.strata_x_), 0x1.fffffep-1f),
                    std::min((sy + hashed(dim, 1)) / float(s.strata_y_), 0x1.fffffep-1f)};
        }
        case SamplerKind::Sobol: {
            uint32_t seed[3];
            sobol_seeds(dim, seed);
            return to_unit2(owen_sobol01(shuffle_reversed_index(reversed_sample_, seed[0]), seed[1], seed[2]));
        }
        case SamplerKind::ZSobol: {
            const uint64_t i = zsobol_index(morton_, s.base4_digits_, s.log2_spp_, dim, s.seed_);
            const uint64_t h = s.zsobol_scramble_[dim];
            return to_unit2(owen_sobol01(uint32_t(i), uint32_t(h), uint32_t(h >> 32)));
        }
        case SamplerKind::Pmj02: {
            const uint64_t k = key(dim);
            const uint32_t* p = pmj_point(s, dim, sample_, k);
            return {to_unit(owen_scramble(p[0], uint32_t(k))), to_unit(owen_scramble(p[1], uint32_t(k >> 32)))};
        }
    }
    return {};
}

void PixelSample::vertex_draws(uint32_t base, float* out, VertexDraws parts) const {
    switch (parts) {
        case VertexDraws::All:
            return vertex_draws<true, true>(base, out);
        case VertexDraws::Light:
            return vertex_draws<true, false>(base, out);
        case VertexDraws::Bounce:
            return vertex_draws<false, true>(base, out);
    }
}

template <bool kLight, bool kBounce>
void PixelSample::vertex_draws(uint32_t base, float* out) const {
    static_assert(dims::kLightChoice == 0 && dims::kLightPoint == 1 &&
                  dims::kBsdfLobe == 3 && dims::kBsdfDir == 4 && dims::kRoulette == 6 &&
                  dims::kPerBounce == 7);
    // Other samplers, and vertices past the low-discrepancy dimensions (which get1d
    // hashes), one number at a time.
    if (s_->kind_ != SamplerKind::Sobol || base + dims::kPerBounce > dims::kLdDimensions) {
        if constexpr (kLight) {
            out[0] = get1d(base);
            const Vec2f a = get2d(base + 1);
            out[1] = a.x;
            out[2] = a.y;
        }
        if constexpr (kBounce) {
            out[3] = get1d(base + 3);
            const Vec2f b = get2d(base + 4);
            out[4] = b.x;
            out[5] = b.y;
            out[6] = get1d(base + 6);
        }
        return;
    }
    if (s_->avx2_) return vertex_draws_avx2<kLight, kBounce>(base, out);
    // get1d and get2d's sobol draws written out stage by stage (seeds, shuffles,
    // scrambles), so the five chains interleave: the same draws as five calls of one
    // inlined helper each, which the compiler leaves one after the other, made a render
    // 3-4 % slower. The seeds are sobol_seeds' from the vertex's one key.
    const uint64_t k = vertex_key(base);
    const uint32_t lo = uint32_t(k), hi = uint32_t(k >> 32);
    uint32_t i0 = 0, i1 = 0, i3 = 0, i4 = 0, i6 = 0;
    if constexpr (kLight) {
        i0 = shuffle_reversed_index(reversed_sample_, lowbias32(lo ^ kShuffleSalt[0]));
        i1 = shuffle_reversed_index(reversed_sample_, lowbias32(lo ^ kShuffleSalt[1]));
    }
    if constexpr (kBounce) {
        i3 = shuffle_reversed_index(reversed_sample_, lowbias32(lo ^ kShuffleSalt[3]));
        i4 = shuffle_reversed_index(reversed_sample_, lowbias32(lo ^ kShuffleSalt[4]));
        i6 = shuffle_reversed_index(reversed_sample_, lowbias32(lo ^ kShuffleSalt[6]));
    }
    if constexpr (kLight) {
        out[0] = to_unit(owen_sobol0(i0, lowbias32(hi ^ kScrambleSalt[0])));
        const Vec2f a = to_unit2(owen_sobol01(i1, lowbias32(hi ^ kScrambleSalt[1]), lowbias32(hi ^ kScrambleSalt[2])));
        out[1] = a.x;
        out[2] = a.y;
    }
    if constexpr (kBounce) {
        out[3] = to_unit(owen_sobol0(i3, lowbias32(hi ^ kScrambleSalt[3])));
        const Vec2f b = to_unit2(owen_sobol01(i4, lowbias32(hi ^ kScrambleSalt[4]), lowbias32(hi ^ kScrambleSalt[5])));
        out[6] = to_unit(owen_sobol0(i6, lowbias32(hi ^ kScrambleSalt[6])));
        out[4] = b.x;
        out[5] = b.y;
    }
}

// The seven sobol numbers of a vertex in the lanes of one register, in the order of
// `out`: lane j computes out[j]. Burley's index shuffle runs in every lane (the 2D draws'
// two lanes shuffle the same index), the second coordinates' lanes then take Sobol's
// second dimension of their index, and one Owen scramble with each lane's seed finishes
// all seven: two Laine-Karras hashes and two reversals for the vertex instead of twelve
// and twelve ("AVX2 draws" in renderer/README.md). The vertex's key stays scalar (AVX2
// has no 64-bit multiply); its lanes' seeds do not. The same bits as the scalar stages
// above (VertexDrawsAreTheSingleDraws).
template <bool kLight, bool kBounce>
PT_AVX2 void PixelSample::vertex_draws_avx2(uint32_t base, float* out) const {
    // sobol_seeds of the vertex's numbers: its one key's halves broadcast, salted per lane.
    const uint64_t k = vertex_key(base);
    const __m256i shuffle_seeds =
        lowbias32x8(_mm256_xor_si256(_mm256_set1_epi32(int(uint32_t(k))),
                                     _mm256_load_si256(reinterpret_cast<const __m256i*>(kShuffleSalt))));
    const __m256i scramble_seeds =
        lowbias32x8(_mm256_xor_si256(_mm256_set1_epi32(int(uint32_t(k >> 32))),
                                     _mm256_load_si256(reinterpret_cast<const __m256i*>(kScrambleSalt))));
    __m256i index = reverse_bits8(laine_karras8(_mm256_set1_epi32(int(reversed_sample_)), shuffle_seeds));
    index = _mm256_blend_epi32(index, sobol1_reversed8(index), 0x24);  // lanes 2 and 5
    const __m256i v = reverse_bits8(laine_karras8(index, scramble_seeds));
    const __m256 u = _mm256_mul_ps(_mm256_cvtepi32_ps(_mm256_srli_epi32(v, 8)), _mm256_set1_ps(0x1p-24f));
    // Stores only the lanes asked for: out has kPerBounce = 7 floats.
    const __m256i store = _mm256_setr_epi32(kLight ? -1 : 0, kLight ? -1 : 0, kLight ? -1 : 0, kBounce ? -1 : 0,
                                            kBounce ? -1 : 0, kBounce ? -1 : 0, kBounce ? -1 : 0, 0);
    _mm256_maskstore_ps(out, store, u);
}

}  // namespace renderer
