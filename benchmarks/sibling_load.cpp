// sibling_load MODE [SECONDS]: a load for the CPU beside a timed trace, to measure what a
// busy neighbour costs each backend (accel/DECISIONS.md, "sibling thread's cost";
// benchmarks/sibling_cost.sh runs it). Each mode stresses one resource a neighbour on the
// same core, or beside it, competes for:
//   pause   a spin loop of `pause`: almost nothing but the core's issue slots
//   fp      12 independent multiply-add chains: the floating-point ports
//   chase   a random pointer chase over 256 MiB: memory latency, the core barely busy
//   l2      the same over 512 KiB: L2 latency
//   stream  a sequential read of 256 MiB: memory bandwidth
// Runs until killed, or for SECONDS. --quick runs each mode for 20 ms (the test suite's
// smoke run).
#include <emmintrin.h>
#include <xmmintrin.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <numeric>
#include <random>
#include <string>
#include <vector>

namespace {

volatile float g_sink_f;
volatile uintptr_t g_sink_p;

using Clock = std::chrono::steady_clock;

bool expired(Clock::time_point end) { return end != Clock::time_point{} && Clock::now() >= end; }

void chase(size_t bytes, Clock::time_point end) {
    const size_t n = bytes / sizeof(void*);
    std::vector<void*> a(n);
    std::vector<size_t> perm(n);
    std::iota(perm.begin(), perm.end(), size_t{0});
    std::shuffle(perm.begin(), perm.end(), std::mt19937_64(1));
    for (size_t i = 0; i < n; ++i) a[perm[i]] = &a[perm[(i + 1) % n]];
    void** p = &a[perm[0]];
    do {
        for (int k = 0; k < 100000; ++k) p = static_cast<void**>(*p);
        g_sink_p = reinterpret_cast<uintptr_t>(p);
    } while (!expired(end));
}

void fp(Clock::time_point end) {
    __m128 a[12];
    for (int i = 0; i < 12; ++i) a[i] = _mm_set1_ps(1.0f + float(i) * 1e-3f);
    const __m128 mu = _mm_set1_ps(0.999999f), c = _mm_set1_ps(1e-7f);
    do {
        for (int k = 0; k < 100000; ++k)
            for (__m128& x : a) x = _mm_add_ps(_mm_mul_ps(x, mu), c);
        g_sink_f = _mm_cvtss_f32(a[0]) + _mm_cvtss_f32(a[11]);
    } while (!expired(end));
}

void stream(Clock::time_point end) {
    std::vector<uint64_t> b((size_t(256) << 20) / 8, 1);
    uint64_t s = 0;
    do {
        for (size_t i = 0; i < b.size(); i += 8) s += b[i];
        g_sink_p = s;
    } while (!expired(end));
}

void spin(Clock::time_point end) {
    do {
        for (int k = 0; k < 100000; ++k) _mm_pause();
    } while (!expired(end));
}

bool run(const std::string& mode, Clock::time_point end) {
    if (mode == "pause") spin(end);
    else if (mode == "fp") fp(end);
    else if (mode == "chase") chase(size_t(256) << 20, end);
    else if (mode == "l2") chase(size_t(512) << 10, end);
    else if (mode == "stream") stream(end);
    else return false;
    return true;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc == 2 && std::strcmp(argv[1], "--quick") == 0) {
        for (const char* m : {"pause", "fp", "chase", "l2", "stream"})
            run(m, Clock::now() + std::chrono::milliseconds(20));
        std::puts("sibling_load: every mode ran");
        return 0;
    }
    if (argc < 2 || argc > 3) {
        std::fprintf(stderr, "usage: sibling_load pause|fp|chase|l2|stream [SECONDS] | --quick\n");
        return 2;
    }
    Clock::time_point end{};
    if (argc == 3) end = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(std::atof(argv[2])));
    if (!run(argv[1], end)) {
        std::fprintf(stderr, "sibling_load: unknown mode '%s' (pause, fp, chase, l2, stream)\n", argv[1]);
        return 2;
    }
    return 0;
}
