// NeuralVolume engine: the smoothing kernels of a particle field (ParticleField.h). Every kernel is written in the
// normalised distance q = r / R, where R is the particle's support radius (zero at and beyond q = 1), and scaled so
// that it integrates to one over its ball: the integral of particleKernel(k, |x| / R) / R^3 over |x| < R is 1.
#pragma once

#include <cmath>

namespace nv
{

enum class ParticleKernel : int
{
  Gaussian = 0,    ///< exp(-q^2 / (2 sigma^2)) with sigma = R / 3, truncated at R
  CubicSpline = 1, ///< the M4 B-spline of SPH (Monaghan), smoothing length h = R / 2
  WendlandC2 = 2   ///< Wendland's C2 function (1 - q)^4 (1 + 4 q)
};

/// The Gaussian's exponent factor: exp(-kGaussianFactor q^2), sigma = 1/3 of the support radius.
constexpr double kGaussianFactor = 4.5;

/// 1 / (4 pi integral_0^1 q^2 exp(-a q^2) dq): the truncated Gaussian's normalisation (closed form with erf).
inline double gaussianNormalisation()
{
  const double a = kGaussianFactor, pi = 3.14159265358979323846;
  const double integral = std::sqrt(pi) * std::erf(std::sqrt(a)) / (4.0 * a * std::sqrt(a)) - std::exp(-a) / (2.0 * a);
  return 1.0 / (4.0 * pi * integral);
}

/// The kernel at normalised distance q >= 0 (0 for q >= 1), normalised to unit integral over the unit ball.
inline double particleKernel(ParticleKernel kernel, double q)
{
  constexpr double pi = 3.14159265358979323846;
  if (!(q < 1.0))
    return 0.0;
  switch (kernel)
  {
    case ParticleKernel::Gaussian:
    {
      static const double norm = gaussianNormalisation();
      return norm * std::exp(-kGaussianFactor * q * q);
    }
    case ParticleKernel::CubicSpline:
    {
      const double s = 2.0 * q; // r / h with h = R / 2
      const double f = s < 1.0 ? 1.0 - 1.5 * s * s + 0.75 * s * s * s : 0.25 * (2.0 - s) * (2.0 - s) * (2.0 - s);
      return 8.0 / pi * f; // 1 / (pi h^3) with h = 1/2
    }
    case ParticleKernel::WendlandC2:
    default:
    {
      const double t = 1.0 - q;
      return 21.0 / (2.0 * pi) * t * t * t * t * (1.0 + 4.0 * q);
    }
  }
}

/// "Gaussian", "cubic spline", "Wendland C2".
inline const char* particleKernelName(ParticleKernel kernel)
{
  return kernel == ParticleKernel::Gaussian ? "Gaussian"
    : kernel == ParticleKernel::CubicSpline ? "cubic spline"
                                            : "Wendland C2";
}

} // namespace nv
