// ipc.c MODE SECONDS: register-only loops that ask for many or few instructions per cycle.
// wide: 4 integer add chains + 4 vector add chains per step (8 independent ops, more than a
// Zen 4 core dispatches per cycle: 6); narrow: 1 integer + 1 vector chain (2 per cycle, latency
// bound). Prints giga-instructions per second (approximate: loop overhead excluded).
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
static double now(void) { struct timespec t; clock_gettime(CLOCK_MONOTONIC, &t); return t.tv_sec + 1e-9 * t.tv_nsec; }
#define W8 "add $1,%%r8\n add $1,%%r9\n add $1,%%r10\n add $1,%%r11\n vpaddd %%xmm8,%%xmm0,%%xmm0\n vpaddd %%xmm8,%%xmm1,%%xmm1\n vpaddd %%xmm8,%%xmm2,%%xmm2\n vpaddd %%xmm8,%%xmm3,%%xmm3\n"
#define N2 "add $1,%%r8\n vpaddd %%xmm8,%%xmm0,%%xmm0\n"
int main(int argc, char** argv) {
  const int wide = argc > 1 && !strcmp(argv[1], "wide");
  const double secs = argc > 2 ? atof(argv[2]) : 0.3;
  double t0 = now(), t; long n = 0;
  do {
    if (wide) { for (int k = 0; k < 10000; ++k) __asm__ volatile(W8 W8 W8 W8 W8 W8 W8 W8 ::: "r8","r9","r10","r11","xmm0","xmm1","xmm2","xmm3","xmm8"); n += 10000L * 64; }
    else { for (int k = 0; k < 10000; ++k) __asm__ volatile(N2 N2 N2 N2 N2 N2 N2 N2 ::: "r8","xmm0","xmm8"); n += 10000L * 16; }
    t = now();
  } while (t - t0 < secs);
  printf("%.2f\n", n / (t - t0) / 1e9);
  return 0;
}
