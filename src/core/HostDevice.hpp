#pragma once
// KF_HD marks functions compiled for both the host and (under nvcc) the device, so that every
// numerical kernel is written once and used by both backends.
#if defined(__CUDACC__)
#define KF_HD __host__ __device__
#define KF_INLINE __forceinline__
#else
#define KF_HD
#define KF_INLINE inline
#endif

// KF_UNROLL before a loop of fixed trip count: unrolled in device code, left to the host compiler.
#if defined(__CUDA_ARCH__)
#define KF_UNROLL _Pragma("unroll")
#else
#define KF_UNROLL
#endif
