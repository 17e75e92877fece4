#include "benchmarks/machine_probe.h"
#include <cstdio>
#include <cstdlib>
int main(int argc, char** argv) {
    const bench::MachineProbe p(true);
    const int n = argc > 1 ? std::atoi(argv[1]) : 5;
    for (int i = 0; i < n; ++i) std::printf("%.2f ", p.scaling(2));
    std::printf("\n");
}
