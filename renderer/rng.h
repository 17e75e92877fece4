// Per-sample random streams: every camera sample draws from its own generator derived
// from the user's seed, the pixel index and the sample index, so an image is bit-identical
// for any split of the work (threads, tiles, passes, MPI ranks, a resumed checkpoint);
// no global engine is shared across threads.
#pragma once

#include <cstdint>

namespace renderer {

/// SplitMix64 finaliser (Steele, Lea, Flood 2014): decorrelates (seed, pixel) keys.
inline uint64_t mix64(uint64_t z) {
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

/// PCG32 (O'Neill 2014): small state, good statistical quality, cheap.
class Rng {
public:
    Rng(uint64_t seed, uint64_t stream) {
        inc_ = (mix64(stream) << 1u) | 1u;
        state_ = 0;
        next_u32();
        state_ += mix64(seed ^ 0x9E3779B97F4A7C15ull);
        next_u32();
    }
    /// The stream of sample `sample` of pixel `pixel`: the sample index is folded into the
    /// seed, so sample k of a pixel never depends on how many numbers samples 0..k-1 drew.
    Rng(uint64_t seed, uint64_t pixel, uint64_t sample)
        : Rng(mix64(seed ^ mix64(sample + 0x632BE59BD9B4E019ull)), pixel) {}
    uint32_t next_u32() {
        uint64_t old = state_;
        state_ = old * 6364136223846793005ull + inc_;
        uint32_t xorshifted = uint32_t(((old >> 18u) ^ old) >> 27u);
        uint32_t rot = uint32_t(old >> 59u);
        return (xorshifted >> rot) | (xorshifted << ((32u - rot) & 31u));
    }
    /// Uniform in [0, 1): 24 random mantissa bits, never returns 1.
    float next_float() { return float(next_u32() >> 8) * 0x1p-24f; }

private:
    uint64_t state_, inc_;
};

}  // namespace renderer
