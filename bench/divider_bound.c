// The f64 divider's throughput on this CPU, for the lane tracer's arithmetic bound (docs/performance.md,
// "The image plane's root skipped; re-measured"): eight independent chains of AVX-512 (zmm) divisions,
// then square roots, then AVX2 (ymm) divisions; nanoseconds per f64 element. Run on both cores at once
// to see whether they share a divider.
// Build and run: gcc -O2 -mavx512f -o /tmp/divider_bound bench/divider_bound.c && /tmp/divider_bound
#include <immintrin.h>
#include <stdio.h>
#include <time.h>
static double now(){struct timespec t;clock_gettime(CLOCK_MONOTONIC,&t);return t.tv_sec+t.tv_nsec*1e-9;}
int main(){
  const long N=20000000;
  __m512d a[8]; for(int i=0;i<8;i++) a[i]=_mm512_set1_pd(1.0+i*1e-3);
  __m512d d=_mm512_set1_pd(1.0000001);
  double t0=now();
  for(long k=0;k<N;k++){ for(int i=0;i<8;i++) a[i]=_mm512_div_pd(a[i],d); }
  double t1=now();
  for(long k=0;k<N;k++){ for(int i=0;i<8;i++) a[i]=_mm512_sqrt_pd(a[i]); }
  double t2=now();
  __m256d b[8]; for(int i=0;i<8;i++) b[i]=_mm256_set1_pd(1.0+i*1e-3);
  __m256d e=_mm256_set1_pd(1.0000001);
  double t3=now();
  for(long k=0;k<N;k++){ for(int i=0;i<8;i++) b[i]=_mm256_div_pd(b[i],e); }
  double t4=now();
  double s=0; for(int i=0;i<8;i++){double o[8];_mm512_storeu_pd(o,a[i]);s+=o[0];double p[4];_mm256_storeu_pd(p,b[i]);s+=p[0];}
  printf("zmm div %.3f ns/element, zmm sqrt %.3f ns/element, ymm div %.3f ns/element (%g)\n",(t1-t0)/(N*64.0)*1e9,(t2-t1)/(N*64.0)*1e9,(t4-t3)/(N*32.0)*1e9,s);
}
