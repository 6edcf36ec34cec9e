// NeuralVolume engine: the edge-aware denoiser of the accumulated path-tracing image (issue 24), per-pixel math
// shared by the CPU loop (Cpu/CpuDenoiser.cpp) and the CUDA kernels (Gpu/GpuDenoiser.cu).
//
// The guide is a noise-free picture of the same scene: the emission-absorption ray-marched image of the same
// request (premultiplied colour = the transfer function's colour x opacity, and alpha). The path-traced image is
// that colour times the light the volume receives, so the denoiser
//   1. demodulates: illumination = path-traced / guide, per channel (alpha too: the path tracer's coverage over the
//      marched opacity), with a variance of its luminance per pixel -- the variance of the accumulated mean, from the
//      frames' second moments (RenderRequest accumulation: every render adds a frame) or, with a single frame, the
//      spatial variance of the 3 x 3 neighbourhood (SVGF's fallback);
//   2. filters the illumination with `iterations` passes of the edge-avoiding a-trous wavelet (Dammertz et al. 2010,
//      the 5 x 5 B3-spline kernel, step 1, 2, 4, ...), whose weights stop at edges of the guide's colour and alpha and
//      at illumination differences large against the noise (SVGF, Schied et al. 2017: |l_p - l_q| / (sigma_l x the
//      standard deviation of the noise)); the variance is filtered along (weights squared), so the filter weakens as
//      samples accumulate and the noise falls;
//   3. corrects the filter's bias: it adds back the local (3 x 3) mean of raw - filtered illumination, shrunk by
//      max(0, 1 - rawBlend x variance / (9 x mean difference^2)) (positive-part James-Stein): with few paths the mean
//      difference is noise and little is added, with many the noise is small and what is left is the filter's bias
//      (a blurred shadow edge, a gradient's curvature), which goes back in -- denoising then does not increase the
//      error at high paths per pixel (measured: Testing/Benchmarks/results/pt_convergence_2026-11-27.md);
//      remodulates: illumination x guide.
// Defaults chosen by measuring (the same file): the guide term is weak (sigmaGuide 1: demodulation does most of the
// guide's work on smooth volumes), the luminance term SVGF's 4 standard deviations, 5 passes (129-pixel footprint).
//   4. fades to the raw accumulation as the accumulation converges by itself: the mean over the pixels the volume
//      covers (guide alpha > albedoFloor: an empty background would make a small volume look converged) of every
//      pixel's variance of its mean (from the moments) estimates the raw picture's squared error, hence its PSNR; between
//      fadeStartDb and fadeEndDb the image goes linearly from denoised to raw (the filter's residual bias on fine
//      structure, e.g. a CT at one pixel per vessel wall, is then never worse than the converged raw picture).
// Pixels the guide leaves empty (alpha <= floor) keep the path-traced value; a non-finite input pixel stays
// non-finite in the output (never smoothed away) and is left out of its neighbours' sums.
#pragma once

#include "HostDevice.h"
#include "Volume.h" // finiteValue

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace nv
{

struct DenoiseParams
{
  int width = 0;
  int height = 0;
  int frames = 1;              ///< renders accumulated (each added one frame of moments)
  float paths = 1.0f;          ///< paths per pixel accumulated in all
  int iterations = 5;          ///< a-trous passes (footprint 4 x 2^iterations + 1 pixels)
  float sigmaGuide = 1.0f;     ///< guide colour / alpha distance at which a tap's weight falls to 1/e
  float sigmaLuminance = 4.0f; ///< illumination difference, in standard deviations of the noise, at 1/e
  float rawBlend = 2.0f;       ///< the bias correction's shrinkage of the local mean (step 3); <= 0: none
  float pixelBlend = 8.0f;     ///< ... of a pixel's own difference (finer than 3 x 3); <= 0: none
  float fadeStartDb = 35.0f;   ///< step 4: the raw accumulation's estimated PSNR at which the filter starts to fade
  float fadeEndDb = 45.0f;     ///< ... and at which the image is the raw accumulation
  float rawFade = 0.0f;        ///< step 4's weight of the raw image for this call (set by the backends, fade())
  float albedoFloor = 1e-3f;   ///< guide values below this divide by it; guide alpha below it: an empty pixel
};

namespace denoise
{

NV_HD float luminance(float r, float g, float b)
{
  return 0.2126f * r + 0.7152f * g + 0.0722f * b;
}

NV_HD bool finite4(const float* v)
{
  return finiteValue(v[0]) && finiteValue(v[1]) && finiteValue(v[2]) && finiteValue(v[3]);
}

/// After a frame of `framePaths` paths: the accumulation's sums went from `before` to `after` (rgba of one pixel);
/// moments += framePaths x luminance(frame mean)^2.
NV_HD void addFrameMoment(const float* before, const float* after, float framePaths, float& moment)
{
  const float inv = 1.0f / framePaths;
  const float l = luminance((after[0] - before[0]) * inv, (after[1] - before[1]) * inv, (after[2] - before[2]) * inv);
  moment += framePaths * l * l;
}

/// Whether the guide shows the volume at a pixel (alpha above the floor): the pixels the filter and step 4's estimate
/// take part in.
NV_HD bool guideCovers(const DenoiseParams& p, const float* guide)
{
  return guide[3] > p.albedoFloor;
}

/// Step 4's estimate, one pixel: the variance of the accumulated mean's luminance (image units; 0 with one frame or a
/// non-finite value). It is averaged over the pixels guideCovers.
NV_HD float rawVarianceOfMean(const DenoiseParams& p, const float* noisy, float moment)
{
  if (p.frames < 2 || !finite4(noisy) || !finiteValue(moment))
    return 0.0f;
  const float mu = luminance(noisy[0], noisy[1], noisy[2]);
  return fmaxf(0.0f, moment - p.paths * mu * mu) / float(p.frames - 1) / p.paths;
}

/// Step 4's weight of the raw image from the mean of rawVarianceOfMean over the pixels guideCovers (values in [0, 1];
/// host and device: the CUDA backend computes it on the GPU, without waiting for the sum).
NV_HD float fade(const DenoiseParams& p, double meanVariance)
{
  if (p.frames < 2 || !(p.fadeEndDb > p.fadeStartDb))
    return 0.0f;
  if (!(meanVariance > 0.0))
    return meanVariance == 0.0 ? 1.0f : 0.0f; // no noise at all: the raw accumulation is the picture
  const double t = (-10.0 * log10(meanVariance) - p.fadeStartDb) / (p.fadeEndDb - p.fadeStartDb);
  return static_cast<float>(t < 0.0 ? 0.0 : (t > 1.0 ? 1.0 : t));
}

/// The guide's value that the channel divides by.
NV_HD float guideDivisor(const DenoiseParams& p, float guide)
{
  return guide > p.albedoFloor ? guide : p.albedoFloor;
}

/// Step 1, one pixel: illumination (4) and the variance of its luminance. `moment`: the pixel's accumulated second
/// moment (used with frames >= 2; else the variance is left at -1 for spatialVariance). A pixel that does not take
/// part (empty guide, non-finite input) gets a NaN illumination.
NV_HD void demodulate(const DenoiseParams& p, const float* noisy, const float* guide, float moment, float* illum,
  float& variance)
{
  if (!guideCovers(p, guide) || !finite4(noisy))
  {
    illum[0] = illum[1] = illum[2] = illum[3] = NAN;
    variance = 0.0f;
    return;
  }
  for (int c = 0; c < 4; ++c)
    illum[c] = noisy[c] / guideDivisor(p, guide[c]);
  variance = -1.0f;
  if (p.frames >= 2)
  {
    // sigma^2 of one path = (sum n_i m_i^2 - N mu^2) / (F - 1); the mean of N paths has sigma^2 / N.
    const float mu = luminance(noisy[0], noisy[1], noisy[2]);
    const float pathVar = fmaxf(0.0f, moment - p.paths * mu * mu) / float(p.frames - 1);
    const float gl = luminance(guideDivisor(p, guide[0]), guideDivisor(p, guide[1]), guideDivisor(p, guide[2]));
    variance = pathVar / p.paths / (gl * gl);
    if (!finiteValue(variance))
      variance = 0.0f;
  }
}

/// Step 1b (a single frame), one pixel: the variance of the illumination's luminance over its 3 x 3 neighbourhood.
NV_HD float spatialVariance(const DenoiseParams& p, int x, int y, const float* illum)
{
  float sum = 0.0f, sum2 = 0.0f, n = 0.0f;
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx)
    {
      const int qx = x + dx, qy = y + dy;
      if (qx < 0 || qy < 0 || qx >= p.width || qy >= p.height)
        continue;
      const float* q = illum + 4 * (int64_t(qy) * p.width + qx);
      if (!finiteValue(q[0]))
        continue;
      const float l = luminance(q[0], q[1], q[2]);
      sum += l;
      sum2 += l * l;
      n += 1.0f;
    }
  return n > 1.0f ? fmaxf(0.0f, (sum2 - sum * sum / n) / (n - 1.0f)) : 0.0f;
}

/// The variance at (x, y) blurred by the 3 x 3 binomial kernel (the edge-stopping function's noise level).
NV_HD float blurredVariance(const DenoiseParams& p, int x, int y, const float* variance)
{
  const float k[2] = { 0.5f, 0.25f }; // [1 2 1] / 4 per axis
  float sum = 0.0f, wsum = 0.0f;
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx)
    {
      const int qx = x + dx, qy = y + dy;
      if (qx < 0 || qy < 0 || qx >= p.width || qy >= p.height)
        continue;
      const float w = k[dx == 0 ? 0 : 1] * k[dy == 0 ? 0 : 1];
      sum += w * variance[int64_t(qy) * p.width + qx];
      wsum += w;
    }
  return sum / wsum;
}

/// Step 2, one pixel of one a-trous pass of step `step`: the filtered illumination and variance of (x, y).
NV_HD void atrousPixel(const DenoiseParams& p, int x, int y, int step, const float* illum, const float* variance,
  const float* guide, float* illumOut, float* varianceOut)
{
  const int64_t pixel = int64_t(y) * p.width + x;
  const float* ip = illum + 4 * pixel;
  if (!finiteValue(ip[0]))
  {
    for (int c = 0; c < 4; ++c)
      illumOut[4 * pixel + c] = ip[c];
    varianceOut[pixel] = variance[pixel];
    return;
  }
  const float kernel[3] = { 0.375f, 0.25f, 0.0625f };
  const float* gp = guide + 4 * pixel;
  const float lp = luminance(ip[0], ip[1], ip[2]);
  const float noise = p.sigmaLuminance * sqrtf(blurredVariance(p, x, y, variance)) + 1e-6f;
  const float invGuide = 1.0f / (p.sigmaGuide * p.sigmaGuide);
  float sum[4] = { 0.0f, 0.0f, 0.0f, 0.0f };
  float wsum = 0.0f, vsum = 0.0f;
  for (int dy = -2; dy <= 2; ++dy)
    for (int dx = -2; dx <= 2; ++dx)
    {
      const int qx = x + dx * step, qy = y + dy * step;
      if (qx < 0 || qy < 0 || qx >= p.width || qy >= p.height)
        continue;
      const int64_t q = int64_t(qy) * p.width + qx;
      const float* iq = illum + 4 * q;
      if (!finiteValue(iq[0]))
        continue;
      const float* gq = guide + 4 * q;
      float dg = 0.0f;
      for (int c = 0; c < 4; ++c)
        dg += (gp[c] - gq[c]) * (gp[c] - gq[c]);
      const float dl = fabsf(lp - luminance(iq[0], iq[1], iq[2]));
      const float w = kernel[dx < 0 ? -dx : dx] * kernel[dy < 0 ? -dy : dy] * expf(-dg * invGuide - dl / noise);
      for (int c = 0; c < 4; ++c)
        sum[c] += w * iq[c];
      wsum += w;
      vsum += w * w * variance[q];
    }
  // The centre tap has weight kernel[0]^2 > 0: wsum > 0.
  for (int c = 0; c < 4; ++c)
    illumOut[4 * pixel + c] = sum[c] / wsum;
  varianceOut[pixel] = vsum / (wsum * wsum);
}

/// Step 3, one pixel: the denoised value -- the filtered illumination plus the part of the local (3 x 3) mean
/// difference raw - filtered that the noise does not explain, x the guide; the path-traced value where the pixel took
/// no part. `noisy`, `guide`, `illum` (filtered) and `rawVariance` (the demodulated variance before filtering) are
/// whole images; `out` may not be `noisy` (neighbours are read).
NV_HD void remodulate(const DenoiseParams& p, int x, int y, const float* noisy, const float* guide, const float* illum,
  const float* rawVariance, float* out)
{
  const int64_t pixel = int64_t(y) * p.width + x;
  const float* n = noisy + 4 * pixel;
  const float* g = guide + 4 * pixel;
  const float* f = illum + 4 * pixel;
  float* o = out + 4 * pixel;
  if (!(g[3] > p.albedoFloor) || !finite4(n) || !finiteValue(f[0]))
  {
    for (int c = 0; c < 4; ++c)
      o[c] = n[c];
    return;
  }
  // The mean difference over the valid 3 x 3 neighbourhood: the filter's bias there plus noise of variance / count.
  float diff[4] = { 0.0f, 0.0f, 0.0f, 0.0f }, count = 0.0f;
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx)
    {
      const int qx = x + dx, qy = y + dy;
      if (qx < 0 || qy < 0 || qx >= p.width || qy >= p.height)
        continue;
      const int64_t q = int64_t(qy) * p.width + qx;
      const float* nq = noisy + 4 * q;
      const float* gq = guide + 4 * q;
      const float* fq = illum + 4 * q;
      if (!(gq[3] > p.albedoFloor) || !finite4(nq) || !finiteValue(fq[0]))
        continue;
      for (int c = 0; c < 4; ++c)
        diff[c] += nq[c] / guideDivisor(p, gq[c]) - fq[c];
      count += 1.0f;
    }
  float own[4];
  for (int c = 0; c < 4; ++c)
  {
    diff[c] /= count; // count >= 1: the pixel itself
    own[c] = n[c] / guideDivisor(p, g[c]) - f[c] - diff[c];
  }
  // Shrunk by the noise: the local mean by its variance / count, the pixel's own rest (detail finer than 3 x 3) by a
  // stricter factor (pixelBlend: a pure-noise pixel rarely passes it).
  const float variance = blurredVariance(p, x, y, rawVariance);
  const float d = luminance(diff[0], diff[1], diff[2]), r = luminance(own[0], own[1], own[2]);
  float meanWeight = 0.0f, pixelWeight = 0.0f;
  if (p.rawBlend > 0.0f && d * d > 0.0f)
    meanWeight = fmaxf(0.0f, 1.0f - p.rawBlend * variance / (count * d * d));
  if (p.pixelBlend > 0.0f && r * r > 0.0f)
    pixelWeight = fmaxf(0.0f, 1.0f - p.pixelBlend * variance / (r * r));
  for (int c = 0; c < 4; ++c)
  {
    const float denoised = (f[c] + meanWeight * diff[c] + pixelWeight * own[c]) * guideDivisor(p, g[c]);
    o[c] = denoised + p.rawFade * (n[c] - denoised);
  }
}

} // namespace denoise
} // namespace nv
