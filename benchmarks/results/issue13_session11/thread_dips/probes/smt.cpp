// 2-thread scaling of a high-IPC vector loop: ~2.0 on separate cores, ~1.0-1.3 on SMT siblings.
#include <immintrin.h>
#include <pthread.h>
#include <sched.h>
#include <chrono>
#include <cstdio>
#include <thread>
static double work(int cpu, long n) {
    cpu_set_t s; CPU_ZERO(&s); CPU_SET(cpu, &s); sched_setaffinity(0, sizeof(s), &s);
    __m256 a[8]; for (int i = 0; i < 8; ++i) a[i] = _mm256_set1_ps(1.0f + i * 1e-3f);
    const __m256 m = _mm256_set1_ps(0.999999f), c = _mm256_set1_ps(1e-7f);
    for (long k = 0; k < n; ++k)
        for (int i = 0; i < 8; ++i) a[i] = _mm256_fmadd_ps(a[i], m, c);
    float r = 0; for (int i = 0; i < 8; ++i) r += _mm256_cvtss_f32(a[i]);
    return r;
}
int main(int argc, char** argv) {
    const long n = 20000000;
    volatile double sink = 0;
    for (int it = 0; it < (argc > 1 ? atoi(argv[1]) : 20); ++it) {
        auto t0 = std::chrono::steady_clock::now();
        sink = sink + work(0, n);
        double t1 = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        t0 = std::chrono::steady_clock::now();
        double r1 = 0;
        std::thread th([&] { r1 = work(1, n); });
        sink = sink + work(0, n);
        th.join();
        double t2 = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        std::printf("%.2f ", 2 * t1 / t2);
        std::fflush(stdout);
    }
    std::printf("\n");
}
