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

/// Core/Denoise.h's algorithm in double precision, written out plainly: demodulate, variance (temporal from the
/// moments with two or more frames, else the 3 x 3 spatial variance), `iterations` a-trous passes with the guide and
/// luminance edge-stopping weights (the noise level: the 3 x 3 binomial blur of the variance), the shrinkage towards
/// the raw average, remodulate.
inline std::vector<double> referenceDenoise(const DenoiseInput& in)
{
  const nv::DenoiseParams& p = in.params;
  const int w = p.width, h = p.height;
  const size_t n = size_t(w) * h;
  auto lum = [](const double* c) { return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]; };
  auto divisor = [&p](double g) { return g > p.albedoFloor ? g : double(p.albedoFloor); };
  std::vector<double> illum(4 * n), var(n, 0.0);
  std::vector<char> valid(n, 0);
  for (size_t i = 0; i < n; ++i)
  {
    const float* q = &in.noisy[4 * i];
    const float* g = &in.guide[4 * i];
    valid[i] = g[3] > p.albedoFloor && std::isfinite(q[0]) && std::isfinite(q[1]) && std::isfinite(q[2]) &&
      std::isfinite(q[3]);
    if (!valid[i])
      continue;
    for (int c = 0; c < 4; ++c)
      illum[4 * i + c] = q[c] / divisor(g[c]);
    if (p.frames >= 2)
    {
      const double qd[3] = { q[0], q[1], q[2] }, gd[3] = { divisor(g[0]), divisor(g[1]), divisor(g[2]) };
      const double mu = lum(qd), gl = lum(gd);
      var[i] = std::max(0.0, in.moments[i] - double(p.paths) * mu * mu) / (p.frames - 1) / p.paths / (gl * gl);
    }
  }
  if (p.frames < 2)
  {
    std::vector<double> spatial(n, 0.0);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
      {
        double s = 0, s2 = 0, k = 0;
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx)
          {
            const int qx = x + dx, qy = y + dy;
            if (qx < 0 || qy < 0 || qx >= w || qy >= h || !valid[size_t(qy) * w + qx])
              continue;
            const double l = lum(&illum[4 * (size_t(qy) * w + qx)]);
            s += l;
            s2 += l * l;
            k += 1;
          }
        if (valid[size_t(y) * w + x])
          spatial[size_t(y) * w + x] = k > 1 ? std::max(0.0, (s2 - s * s / k) / (k - 1)) : 0.0;
      }
    var = spatial;
  }
  const double kernel[3] = { 3.0 / 8, 1.0 / 4, 1.0 / 16 }, blur[2] = { 0.5, 0.25 };
  auto blurred = [&](const std::vector<double>& v, int x, int y) {
    double bv = 0, bw = 0;
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx)
      {
        const int qx = x + dx, qy = y + dy;
        if (qx < 0 || qy < 0 || qx >= w || qy >= h)
          continue;
        const double wt = blur[std::abs(dx)] * blur[std::abs(dy)];
        bv += wt * v[size_t(qy) * w + qx];
        bw += wt;
      }
    return bv / bw;
  };
  const std::vector<double> rawVar = var, rawIllum = illum;
  for (int it = 0; it < p.iterations; ++it)
  {
    const int step = 1 << it;
    std::vector<double> nextIllum = illum, nextVar = var;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
      {
        const size_t i = size_t(y) * w + x;
        if (!valid[i])
          continue;
        const double noise = p.sigmaLuminance * std::sqrt(blurred(var, x, y)) + 1e-6;
        const double lp = lum(&illum[4 * i]);
        double sum[4] = { 0, 0, 0, 0 }, ws = 0, vs = 0;
        for (int dy = -2; dy <= 2; ++dy)
          for (int dx = -2; dx <= 2; ++dx)
          {
            const int qx = x + dx * step, qy = y + dy * step;
            if (qx < 0 || qy < 0 || qx >= w || qy >= h)
              continue;
            const size_t j = size_t(qy) * w + qx;
            if (!valid[j])
              continue;
            double dg = 0;
            for (int c = 0; c < 4; ++c)
              dg += double(in.guide[4 * i + c] - in.guide[4 * j + c]) * (in.guide[4 * i + c] - in.guide[4 * j + c]);
            const double wt = kernel[std::abs(dx)] * kernel[std::abs(dy)] *
              std::exp(-dg / (double(p.sigmaGuide) * p.sigmaGuide) - std::fabs(lp - lum(&illum[4 * j])) / noise);
            for (int c = 0; c < 4; ++c)
              sum[c] += wt * illum[4 * j + c];
            ws += wt;
            vs += wt * wt * var[j];
          }
        for (int c = 0; c < 4; ++c)
          nextIllum[4 * i + c] = sum[c] / ws;
        nextVar[i] = vs / (ws * ws);
      }
    illum.swap(nextIllum);
    var.swap(nextVar);
  }
  // The bias correction: the local (valid 3 x 3) mean of raw - filtered, shrunk by max(0, 1 - rawBlend x blurred raw
  // variance / (count x its luminance^2)), and the pixel's own rest, shrunk by max(0, 1 - pixelBlend x variance /
  // its luminance^2).
  // Step 4: fade to the raw image by the raw accumulation's estimated PSNR (mean variance of the mean's luminance).
  double fadeWeight = 0.0;
  if (p.frames >= 2)
  {
    double sum = 0.0;
    for (size_t i = 0; i < n; ++i)
    {
      const float* q = &in.noisy[4 * i];
      if (!(std::isfinite(q[0]) && std::isfinite(q[1]) && std::isfinite(q[2]) && std::isfinite(q[3])))
        continue;
      const double qd[3] = { q[0], q[1], q[2] }, mu = lum(qd);
      sum += std::max(0.0, in.moments[i] - double(p.paths) * mu * mu) / (p.frames - 1) / p.paths;
    }
    const double db = -10.0 * std::log10(sum / double(n));
    fadeWeight = std::min(1.0, std::max(0.0, (db - p.fadeStartDb) / (p.fadeEndDb - p.fadeStartDb)));
  }
  std::vector<double> out(4 * n);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
    {
      const size_t i = size_t(y) * w + x;
      if (!valid[i])
      {
        for (int c = 0; c < 4; ++c)
          out[4 * i + c] = in.noisy[4 * i + c];
        continue;
      }
      double diff[4] = { 0, 0, 0, 0 }, count = 0;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx)
        {
          const int qx = x + dx, qy = y + dy;
          if (qx < 0 || qy < 0 || qx >= w || qy >= h || !valid[size_t(qy) * w + qx])
            continue;
          const size_t j = size_t(qy) * w + qx;
          for (int c = 0; c < 4; ++c)
            diff[c] += rawIllum[4 * j + c] - illum[4 * j + c];
          count += 1;
        }
      double own[4];
      for (int c = 0; c < 4; ++c)
      {
        diff[c] /= count;
        own[c] = rawIllum[4 * i + c] - illum[4 * i + c] - diff[c];
      }
      const double v = blurred(rawVar, x, y), d = lum(diff), r = lum(own);
      const double meanWeight = p.rawBlend > 0 && d != 0 ? std::max(0.0, 1.0 - p.rawBlend * v / (count * d * d)) : 0.0;
      const double pixelWeight = p.pixelBlend > 0 && r != 0 ? std::max(0.0, 1.0 - p.pixelBlend * v / (r * r)) : 0.0;
      for (int c = 0; c < 4; ++c)
      {
        const double denoised =
          (illum[4 * i + c] + meanWeight * diff[c] + pixelWeight * own[c]) * divisor(in.guide[4 * i + c]);
        out[4 * i + c] = denoised + fadeWeight * (in.noisy[4 * i + c] - denoised);
      }
    }
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
