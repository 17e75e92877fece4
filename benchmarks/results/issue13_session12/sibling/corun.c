// Co-runner loads for the sibling-thread experiment (session 12): run on the other vCPU
// while a kernel is timed on this one. Modes: fp, chase (DRAM latency), l2 (L2 latency),
// stream (bandwidth), pause.
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <stdint.h>
#include <xmmintrin.h>
#include <immintrin.h>
static volatile float sinkf; static volatile uintptr_t sinkp;
static void chase(size_t bytes) {
  size_t n = bytes / sizeof(void*); void** a = malloc(n * sizeof(void*)); size_t* perm = malloc(n * sizeof(size_t));
  for (size_t i = 0; i < n; ++i) perm[i] = i;
  srand(1); for (size_t i = n - 1; i > 0; --i) { size_t j = ((size_t)rand() * 65536u + (size_t)rand()) % (i + 1); size_t t = perm[i]; perm[i] = perm[j]; perm[j] = t; }
  for (size_t i = 0; i < n; ++i) a[perm[i]] = &a[perm[(i + 1) % n]];
  void** p = &a[perm[0]];
  for (;;) { for (int k = 0; k < 1000000; ++k) p = (void**)*p; sinkp = (uintptr_t)p; }
}
int main(int argc, char** argv) {
  const char* m = argc > 1 ? argv[1] : "fp";
  if (!strcmp(m, "fp")) {
    __m128 a[12]; for (int i = 0; i < 12; ++i) a[i] = _mm_set1_ps(1.0f + i * 1e-3f);
    const __m128 mu = _mm_set1_ps(0.999999f), c = _mm_set1_ps(1e-7f);
    for (;;) { for (int k = 0; k < 1000000; ++k) {
#define S(i) a[i] = _mm_add_ps(_mm_mul_ps(a[i], mu), c);
      S(0) S(1) S(2) S(3) S(4) S(5) S(6) S(7) S(8) S(9) S(10) S(11) }
      sinkf = _mm_cvtss_f32(a[0]) + _mm_cvtss_f32(a[11]); }
  } else if (!strcmp(m, "chase")) chase(256u << 20);
  else if (!strcmp(m, "l2")) chase(512u << 10);
  else if (!strcmp(m, "stream")) {
    size_t n = (256u << 20) / 8; uint64_t* b = malloc(n * 8); memset(b, 1, n * 8); uint64_t s = 0;
    for (;;) { for (size_t i = 0; i < n; i += 8) s += b[i]; sinkp = s; }
  } else if (!strcmp(m, "pause")) { for (;;) _mm_pause(); }
  return 0;
}
