// 2-thread scaling of independent pointer chases over a private or shared buffer of B MiB.
#include <sched.h>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <numeric>
#include <algorithm>
#include <random>
#include <thread>
#include <vector>
static void pin(int c){cpu_set_t s;CPU_ZERO(&s);CPU_SET(c,&s);sched_setaffinity(0,sizeof(s),&s);}
static double chase(const std::vector<uint32_t>& next, long steps, int cpu, uint32_t start){
    pin(cpu); auto t0=std::chrono::steady_clock::now(); uint32_t p[8];
    for(int k=0;k<8;++k) p[k]=(start+k*977)%next.size();
    for(long i=0;i<steps;++i) for(int k=0;k<8;++k) p[k]=next[p[k]];
    volatile uint32_t sink=p[0]+p[7]; (void)sink;
    return std::chrono::duration<double>(std::chrono::steady_clock::now()-t0).count();
}
int main(int argc,char**argv){
    size_t mb=argc>1?atoi(argv[1]):4; int iters=argc>2?atoi(argv[2]):20;
    size_t n=mb*1024*1024/4; std::vector<uint32_t> next(n); std::vector<uint32_t> perm(n);
    std::iota(perm.begin(),perm.end(),0); std::shuffle(perm.begin(),perm.end(),std::mt19937(1));
    for(size_t i=0;i<n;++i) next[perm[i]]=perm[(i+1)%n];
    long steps=200000;
    for(int it=0;it<iters;++it){
        double t1=chase(next,steps,0,1);
        double ta=0,tb=0; std::thread th([&]{tb=chase(next,steps,1,12345);}); ta=chase(next,steps,0,1); th.join();
        printf("%.2f ", t1/ta+t1/tb); fflush(stdout);
    }
    printf("\n");
}
