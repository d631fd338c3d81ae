#pragma once
// Numerical choices shared by the scene (domain layer) and the kernels.

namespace kf {

/// Smoothing kernels (support radius h): the paper's spiky (Eq. 5, 6), cubic spline, Wendland C2.
enum class KernelType { Spiky, CubicSpline, WendlandC2 };
/// Equations of state: the paper's linear P = k (rho - rho0), and Tait.
enum class EosType { Linear, Tait };
/// Where the fluid's density comes from: the paper's summation (Eq. 2), recomputed from the
/// neighbours every step, or the continuity equation, integrated with density diffusion (as
/// DualSPHysics does), which lets one neighbour pass a step give both density rate and forces.
enum class DensityModel { Summation, Continuity };

} // namespace kf
