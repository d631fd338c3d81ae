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
