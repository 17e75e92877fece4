#include <stdlib.h>
#include <string.h>
#include <immintrin.h>
#include <stdio.h>
int main(int argc,char**argv){
  const char*mode=argv[1]; size_t mb=argc>2?atol(argv[2]):64;
  if(!strcmp(mode,"stream")){ size_t n=mb<<20; char*p=malloc(n); memset(p,1,n); volatile long s=0;
    for(;;){ for(size_t i=0;i<n;i+=64) s+=p[i]; } }
  if(!strcmp(mode,"write")){ size_t n=mb<<20; char*p=malloc(n); for(;;) memset(p,(int)mb,n); }
  if(!strcmp(mode,"fp")){ __m256 a=_mm256_set1_ps(1.0001f),b=_mm256_set1_ps(0.9999f),c[8]; for(int i=0;i<8;i++)c[i]=_mm256_set1_ps(i);
    for(long k=0;;k++){ for(int i=0;i<8;i++) c[i]=_mm256_fmadd_ps(c[i],a,b); if(k==-1) printf("%f",c[0][0]);} }
  if(!strcmp(mode,"rand")){ size_t n=(mb<<20)/8; long*p=malloc(n*8); for(size_t i=0;i<n;i++)p[i]=(i*2654435761u)%n; long j=0; for(;;) j=p[j]; }
  return 0;}
