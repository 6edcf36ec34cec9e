// Shared pieces of the denoiser tests (engine and GPU): a synthetic accumulation with its guide and moments, and a
// straightforward double-precision implementation of Core/Denoise.h's algorithm written from its description (not
// from its code) that the CPU and CUDA denoisers are compared against.
#pragma once

#include "Core/Denoise.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

namespace nvtest
{

struct DenoiseInput
{
  nv::DenoiseParams params;
  std::vector<float> noisy, guide, moments; ///< rgba, rgba, one per pixel
};

/// Two soft discs of different colours over an empty background, lit by a light with a sharp shadow edge; `frames`
/// frames of one noisy path each (uniform noise of +-100 %), accumulated with their moments (fixed seed).
inline DenoiseInput syntheticDenoiseInput(int width, int height, int frames, uint64_t seed)
{
  DenoiseInput in;
  in.params.width = width;
  in.params.height = height;
  in.params.frames = frames;
  in.params.paths = static_cast<float>(frames);
  const size_t pixels = size_t(width) * height;
  in.guide.assign(4 * pixels, 0.0f);
  in.noisy.assign(4 * pixels, 0.0f);
  in.moments.assign(pixels, 0.0f);
  std::vector<float> sums(4 * pixels, 0.0f), before(4);
  uint64_t state = seed * 0x9E3779B97F4A7C15ull + 1;
  auto uniform = [&state]() {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return float((state >> 40) & 0xFFFFFF) / float(0x1000000);
  };
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
    {
      const size_t p = size_t(y) * width + x;
      const float u = (x + 0.5f) / width, v = (y + 0.5f) / height;
      const float d1 = std::hypot(u - 0.38f, v - 0.45f), d2 = std::hypot(u - 0.66f, v - 0.6f);
      const float a1 = std::min(1.0f, std::max(0.0f, (0.28f - d1) * 12.0f));
      const float a2 = std::min(1.0f, std::max(0.0f, (0.22f - d2) * 12.0f));
      const float alpha = a1 + (1.0f - a1) * a2;
      const float rgb[3] = { 0.9f * a1 + 0.2f * (1 - a1) * a2, 0.4f * a1 + 0.5f * (1 - a1) * a2,
        0.2f * a1 + 0.9f * (1 - a1) * a2 };
      const float light = (u + 0.3f * v > 0.55f ? 1.0f : 0.25f) * (0.6f + 0.4f * v);
      for (int c = 0; c < 3; ++c)
        in.guide[4 * p + c] = rgb[c];
      in.guide[4 * p + 3] = alpha;
      for (int f = 0; f < frames; ++f)
      {
        std::copy(&sums[4 * p], &sums[4 * p] + 4, before.begin());
        const float n = 1.0f + (2.0f * uniform() - 1.0f);
        for (int c = 0; c < 3; ++c)
          sums[4 * p + c] += rgb[c] * light * n;
        sums[4 * p + 3] += alpha * (uniform() < 0.9f ? 1.0f : 0.0f) / 0.9f * (alpha > 0.0f ? 1.0f : 0.0f);
        nv::denoise::addFrameMoment(before.data(), &sums[4 * p], 1.0f, in.moments[p]);
      }
      for (int c = 0; c < 4; ++c)
        in.noisy[4 * p + c] = sums[4 * p + c] / float(frames);
    }
  return in;
}

/// The double-precision implementation's state between its steps.
struct ReferenceDenoiseState
{
  const DenoiseInput& in;
  int w, h;
  size_t n;
  std::vector<double> illum, var, rawIllum, rawVar;
  std::vector<char> valid;

  explicit ReferenceDenoiseState(const DenoiseInput& input)
    : in(input)
    , w(input.params.width)
    , h(input.params.height)
    , n(size_t(w) * h)
    , illum(4 * n, 0.0)
    , var(n, 0.0)
    , valid(n, 0)
  {
  }
  static double lum(const double* c) { return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]; }
  double divisor(double g) const { return g > in.params.albedoFloor ? g : double(in.params.albedoFloor); }
  bool inside(int x, int y) const { return x >= 0 && y >= 0 && x < w && y < h; }
  /// The 3 x 3 binomial blur of v at (x, y) over the pixels inside the image.
  double blurred(const std::vector<double>& v, int x, int y) const
  {
    const double blur[2] = { 0.5, 0.25 };
    double bv = 0, bw = 0;
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx)
        if (inside(x + dx, y + dy))
        {
          const double wt = blur[std::abs(dx)] * blur[std::abs(dy)];
          bv += wt * v[size_t(y + dy) * w + x + dx];
          bw += wt;
        }
    return bv / bw;
  }
};

/// Step 1: demodulated illumination and its variance (temporal from the moments, else 3 x 3 spatial).
inline void referenceDemodulate(ReferenceDenoiseState& s)
{
  const nv::DenoiseParams& p = s.in.params;
  for (size_t i = 0; i < s.n; ++i)
  {
    const float* q = &s.in.noisy[4 * i];
    const float* g = &s.in.guide[4 * i];
    s.valid[i] = g[3] > p.albedoFloor && std::isfinite(q[0]) && std::isfinite(q[1]) && std::isfinite(q[2]) &&
      std::isfinite(q[3]);
    if (!s.valid[i])
      continue;
    for (int c = 0; c < 4; ++c)
      s.illum[4 * i + c] = q[c] / s.divisor(g[c]);
    if (p.frames >= 2)
    {
      const double qd[3] = { q[0], q[1], q[2] }, gd[3] = { s.divisor(g[0]), s.divisor(g[1]), s.divisor(g[2]) };
      const double mu = s.lum(qd), gl = s.lum(gd);
      s.var[i] = std::max(0.0, s.in.moments[i] - double(p.paths) * mu * mu) / (p.frames - 1) / p.paths / (gl * gl);
    }
  }
  if (p.frames >= 2)
    return;
  for (int y = 0; y < s.h; ++y)
    for (int x = 0; x < s.w; ++x)
    {
      double sum = 0, sum2 = 0, k = 0;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx)
          if (s.inside(x + dx, y + dy) && s.valid[size_t(y + dy) * s.w + x + dx])
          {
            const double l = s.lum(&s.illum[4 * (size_t(y + dy) * s.w + x + dx)]);
            sum += l;
            sum2 += l * l;
            k += 1;
          }
      const size_t i = size_t(y) * s.w + x;
      s.var[i] = s.valid[i] && k > 1 ? std::max(0.0, (sum2 - sum * sum / k) / (k - 1)) : 0.0;
    }
}

/// Step 2: one a-trous pass of step `step` (guide and luminance edge-stopping; the variance filtered along).
inline void referenceAtrous(ReferenceDenoiseState& s, int step)
{
  const nv::DenoiseParams& p = s.in.params;
  const double kernel[3] = { 3.0 / 8, 1.0 / 4, 1.0 / 16 };
  std::vector<double> nextIllum = s.illum, nextVar = s.var;
  for (int y = 0; y < s.h; ++y)
    for (int x = 0; x < s.w; ++x)
    {
      const size_t i = size_t(y) * s.w + x;
      if (!s.valid[i])
        continue;
      const double noise = p.sigmaLuminance * std::sqrt(s.blurred(s.var, x, y)) + 1e-6;
      const double lp = s.lum(&s.illum[4 * i]);
      double sum[4] = { 0, 0, 0, 0 }, ws = 0, vs = 0;
      for (int dy = -2; dy <= 2; ++dy)
        for (int dx = -2; dx <= 2; ++dx)
        {
          const int qx = x + dx * step, qy = y + dy * step;
          if (!s.inside(qx, qy) || !s.valid[size_t(qy) * s.w + qx])
            continue;
          const size_t j = size_t(qy) * s.w + qx;
          double dg = 0;
          for (int c = 0; c < 4; ++c)
          {
            const double e = double(s.in.guide[4 * i + c]) - s.in.guide[4 * j + c];
            dg += e * e;
          }
          const double wt = kernel[std::abs(dx)] * kernel[std::abs(dy)] *
            std::exp(-dg / (double(p.sigmaGuide) * p.sigmaGuide) - std::fabs(lp - s.lum(&s.illum[4 * j])) / noise);
          for (int c = 0; c < 4; ++c)
            sum[c] += wt * s.illum[4 * j + c];
          ws += wt;
          vs += wt * wt * s.var[j];
        }
      for (int c = 0; c < 4; ++c)
        nextIllum[4 * i + c] = sum[c] / ws;
      nextVar[i] = vs / (ws * ws);
    }
  s.illum.swap(nextIllum);
  s.var.swap(nextVar);
}

/// Step 4's weight of the raw image: the raw accumulation's estimated PSNR (mean variance of the mean's luminance)
/// between fadeStartDb and fadeEndDb.
inline double referenceFade(const ReferenceDenoiseState& s)
{
  const nv::DenoiseParams& p = s.in.params;
  if (p.frames < 2)
    return 0.0;
  double sum = 0.0, covered = 0.0;
  for (size_t i = 0; i < s.n; ++i)
  {
    if (!(s.in.guide[4 * i + 3] > p.albedoFloor)) // the pixels the volume covers only
      continue;
    covered += 1.0;
    const float* q = &s.in.noisy[4 * i];
    if (!(std::isfinite(q[0]) && std::isfinite(q[1]) && std::isfinite(q[2]) && std::isfinite(q[3])))
      continue;
    const double qd[3] = { q[0], q[1], q[2] }, mu = s.lum(qd);
    sum += std::max(0.0, s.in.moments[i] - double(p.paths) * mu * mu) / (p.frames - 1) / p.paths;
  }
  if (covered == 0.0)
    return 0.0;
  const double db = -10.0 * std::log10(sum / covered);
  return std::min(1.0, std::max(0.0, (db - p.fadeStartDb) / (p.fadeEndDb - p.fadeStartDb)));
}

/// Steps 3 and 4 at (x, y): the bias correction -- the local (valid 3 x 3) mean of raw - filtered shrunk by
/// max(0, 1 - rawBlend x blurred raw variance / (count x its luminance^2)), the pixel's own rest by max(0, 1 -
/// pixelBlend x variance / its luminance^2) -- remodulation and the fade to the raw image.
inline void referenceRemodulate(const ReferenceDenoiseState& s, int x, int y, double fade, double* out)
{
  const nv::DenoiseParams& p = s.in.params;
  const size_t i = size_t(y) * s.w + x;
  if (!s.valid[i])
  {
    for (int c = 0; c < 4; ++c)
      out[c] = s.in.noisy[4 * i + c];
    return;
  }
  double diff[4] = { 0, 0, 0, 0 }, count = 0, own[4];
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx)
      if (s.inside(x + dx, y + dy) && s.valid[size_t(y + dy) * s.w + x + dx])
      {
        const size_t j = size_t(y + dy) * s.w + x + dx;
        for (int c = 0; c < 4; ++c)
          diff[c] += s.rawIllum[4 * j + c] - s.illum[4 * j + c];
        count += 1;
      }
  for (int c = 0; c < 4; ++c)
  {
    diff[c] /= count;
    own[c] = s.rawIllum[4 * i + c] - s.illum[4 * i + c] - diff[c];
  }
  const double v = s.blurred(s.rawVar, x, y), d = s.lum(diff), r = s.lum(own);
  const double meanWeight = p.rawBlend > 0 && d != 0 ? std::max(0.0, 1.0 - p.rawBlend * v / (count * d * d)) : 0.0;
  const double pixelWeight = p.pixelBlend > 0 && r != 0 ? std::max(0.0, 1.0 - p.pixelBlend * v / (r * r)) : 0.0;
  for (int c = 0; c < 4; ++c)
  {
    const double denoised =
      (s.illum[4 * i + c] + meanWeight * diff[c] + pixelWeight * own[c]) * s.divisor(s.in.guide[4 * i + c]);
    out[c] = denoised + fade * (s.in.noisy[4 * i + c] - denoised);
  }
}

/// Core/Denoise.h's algorithm in double precision, written out plainly from its description: demodulate (variance
/// temporal from the moments with two or more frames, else the 3 x 3 spatial variance), `iterations` a-trous passes,
/// the bias correction, remodulate, the fade to the raw image.
inline std::vector<double> referenceDenoise(const DenoiseInput& in)
{
  ReferenceDenoiseState s(in);
  referenceDemodulate(s);
  s.rawVar = s.var;
  s.rawIllum = s.illum;
  for (int it = 0; it < in.params.iterations; ++it)
    referenceAtrous(s, 1 << it);
  const double fade = referenceFade(s);
  std::vector<double> out(4 * s.n);
  for (int y = 0; y < s.h; ++y)
    for (int x = 0; x < s.w; ++x)
      referenceRemodulate(s, x, y, fade, &out[4 * (size_t(y) * s.w + x)]);
  return out;
}

/// The largest |a - b| over the image; infinity when their finiteness differs at a value.
inline double maxDifference(const std::vector<float>& a, const std::vector<double>& b)
{
  double worst = 0.0;
  for (size_t i = 0; i < a.size() && i < b.size(); ++i)
  {
    if (std::isfinite(a[i]) != std::isfinite(b[i]))
      return INFINITY;
    if (std::isfinite(a[i]))
      worst = std::max(worst, std::fabs(double(a[i]) - b[i]));
  }
  return a.size() == b.size() ? worst : INFINITY;
}

} // namespace nvtest
