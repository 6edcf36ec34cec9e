// NeuralVolume engine: what a ray does between queries (host-device): random streams, transforms, box and
// macrocell traversal (empty-space skipping, free-flight sampling with local majorants), directions, ray setup.
#pragma once

#include "RayState.h"

namespace nv
{
namespace ray
{

// ---------------------------------------------------------------------------------------------------------
// Small helpers

NV_HD float expNeg(float x)
{
#if defined(__CUDA_ARCH__)
  return __expf(-x);
#else
  return std::exp(-x);
#endif
}
NV_HD float logf_(float x)
{
#if defined(__CUDA_ARCH__)
  return __logf(x);
#else
  return std::log(x);
#endif
}
NV_HD float powf_(float x, float y)
{
#if defined(__CUDA_ARCH__)
  return __powf(x, y);
#else
  return std::pow(x, y);
#endif
}
NV_HD int floorInt(float x)
{
  return static_cast<int>(floorf(x));
}

/// Uniform in [0,1) for path `sample` of a pixel: counter-based, identical on every backend and launch shape. The
/// accumulation frame P.frame and the sample index together select the path's random streams.
NV_HD float rand01(const Params& P, uint32_t pixel, uint32_t sample, uint32_t stream, uint32_t counter)
{
  const uint64_t k = (static_cast<uint64_t>(pixel) << 32) ^ (static_cast<uint64_t>(P.frame + sample) << 8) ^ stream;
  const uint64_t z = mix64(mix64(static_cast<uint64_t>(P.seed) * 0x9E3779B97F4A7C15ull ^ k) + counter);
  return static_cast<float>(static_cast<uint32_t>(z >> 40)) * (1.0f / 16777216.0f);
}

NV_HD V3 toUnit(const Params& P, V3 w)
{
  const float* m = P.worldToUnit;
  return { m[0] * w.x + m[1] * w.y + m[2] * w.z + m[3], m[4] * w.x + m[5] * w.y + m[6] * w.z + m[7],
    m[8] * w.x + m[9] * w.y + m[10] * w.z + m[11] };
}
/// Image of a world direction (no translation).
NV_HD V3 dirToUnit(const Params& P, V3 w)
{
  const float* m = P.worldToUnit;
  return { m[0] * w.x + m[1] * w.y + m[2] * w.z, m[4] * w.x + m[5] * w.y + m[6] * w.z,
    m[8] * w.x + m[9] * w.y + m[10] * w.z };
}
/// World gradient from a gradient in network coordinates: the transpose of the linear part.
NV_HD V3 gradToWorld(const Params& P, V3 g)
{
  const float* m = P.worldToUnit;
  return { m[0] * g.x + m[4] * g.y + m[8] * g.z, m[1] * g.x + m[5] * g.y + m[9] * g.z,
    m[2] * g.x + m[6] * g.y + m[10] * g.z };
}
NV_HD V3 unproject(const Params& P, float x, float y, float z)
{
  const float* m = P.clipToWorld;
  const float w = m[12] * x + m[13] * y + m[14] * z + m[15];
  const float iw = w != 0.0f ? 1.0f / w : 0.0f;
  return { (m[0] * x + m[1] * y + m[2] * z + m[3]) * iw, (m[4] * x + m[5] * y + m[6] * z + m[7]) * iw,
    (m[8] * x + m[9] * y + m[10] * z + m[11]) * iw };
}

/// [t0, t1] of o + t d inside `box` (xmin xmax ymin ymax zmin zmax; t0 > t1: no intersection).
NV_HD void boxIntervalOf(const float* box, V3 o, V3 d, float& t0, float& t1)
{
  const float oo[3] = { o.x, o.y, o.z }, dd[3] = { d.x, d.y, d.z };
  t0 = -3.0e38f;
  t1 = 3.0e38f;
  for (int a = 0; a < 3; ++a)
  {
    const float lo = box[2 * a], hi = box[2 * a + 1];
    if (dd[a] == 0.0f)
    {
      if (oo[a] < lo || oo[a] > hi)
      {
        t0 = 1.0f;
        t1 = 0.0f;
        return;
      }
      continue;
    }
    const float inv = 1.0f / dd[a];
    float a0 = (lo - oo[a]) * inv, a1 = (hi - oo[a]) * inv;
    if (a0 > a1)
    {
      const float s = a0;
      a0 = a1;
      a1 = s;
    }
    t0 = fmaxf_(t0, a0);
    t1 = fminf_(t1, a1);
  }
}

/// [t0, t1] of o + t d inside the marched box P.box (t0 > t1: no intersection).
NV_HD void boxInterval(const Params& P, V3 o, V3 d, float& t0, float& t1)
{
  boxIntervalOf(P.box, o, d, t0, t1);
}

NV_HD V3 clampUnit(V3 p)
{
  return { clamp01(p.x), clamp01(p.y), clamp01(p.z) };
}

/// Transfer function at entry coordinate c (clamped to the table): colour and extinction (per world unit); a NaN
/// coordinate (no value) is transparent.
NV_HD void lookupEntry(const Params& P, float c, float out[4])
{
  c = c < 0.0f ? 0.0f : c;
  const float last = static_cast<float>(P.tfSize - 1);
  c = c > last ? last : c;
  if (!(c == c)) // NaN value: transparent
  {
    out[0] = out[1] = out[2] = out[3] = 0.0f;
    return;
  }
  int i = static_cast<int>(c);
  i = i > P.tfSize - 2 ? P.tfSize - 2 : i;
  const float f = c - static_cast<float>(i);
  const float* a = P.tf + 4 * i;
  for (int k = 0; k < 4; ++k)
    out[k] = a[k] + f * (a[k + 4] - a[k]);
}

/// Transfer function at the network's normalised value y: colour and extinction (per world unit).
NV_HD void lookup(const Params& P, float y, float out[4])
{
  lookupEntry(P, y * P.tfScale + P.tfShift, out);
}

NV_HD int cellIndex(const Params& P, V3 u)
{
  int c[3];
  const float uu[3] = { u.x, u.y, u.z };
  for (int a = 0; a < 3; ++a)
  {
    int i = floorInt(uu[a] * P.mcScale[a]);
    i = i < 0 ? 0 : (i >= P.mc[a] ? P.mc[a] - 1 : i);
    c[a] = i;
  }
  return (c[2] * P.mc[1] + c[1]) * P.mc[0] + c[0];
}

/// Distance at which o + t d leaves the macrocell that contains o + t d (t given), at least t.
NV_HD float cellExit(const Params& P, V3 o, V3 d, float t)
{
  const V3 p = o + d * t;
  const float pp[3] = { p.x, p.y, p.z }, oo[3] = { o.x, o.y, o.z }, dd[3] = { d.x, d.y, d.z };
  float tx = 3.0e38f;
  for (int a = 0; a < 3; ++a)
  {
    if (dd[a] == 0.0f)
      continue;
    int i = floorInt(pp[a] * P.mcScale[a]);
    i = i < 0 ? 0 : (i >= P.mc[a] ? P.mc[a] - 1 : i);
    const float b = static_cast<float>(dd[a] > 0.0f ? i + 1 : i) / P.mcScale[a];
    const float ta = (b - oo[a]) / dd[a];
    tx = fminf_(tx, ta);
  }
  return fmaxf_(tx, t);
}

/// Next marching sample at or after index j on segment [t0, tEnd) with step h (sample k at t0 + (k + 1/2) h),
/// skipping macrocells whose majorant is 0 when `skip`. False when the segment is exhausted.
NV_HD bool nextSample(const Params& P, V3 o, V3 d, float t0, float tEnd, float h, bool skip, int& j, float& t)
{
  for (int guard = 0; guard < kMaxIterations; ++guard)
  {
    t = t0 + (static_cast<float>(j) + 0.5f) * h;
    if (!(t < tEnd))
      return false;
    if (!skip)
      return true;
    const V3 p = o + d * t;
    if (P.majorant[cellIndex(P, p)] > 0.0f)
      return true;
    const float tx = cellExit(P, o, d, t);
    int jn = static_cast<int>(ceilf((tx - t0) / h - 0.5f));
    jn = jn <= j ? j + 1 : jn;
    j = jn;
  }
  return false;
}

/// Free-flight sampling with local majorants: the next tentative collision after t on [.., tEnd). Uses the flight
/// stream from counter n (advanced). False when the segment ends first (t = tEnd then).
NV_HD bool nextFlight(const Params& P, const Ray& r, V3 o, V3 d, float tEnd, float& t, uint32_t& n)
{
  for (int guard = 0; guard < kMaxIterations; ++guard)
  {
    if (!(t < tEnd))
    {
      t = tEnd;
      return false;
    }
    float mj = P.maxMajorant;
    float tx = tEnd;
    if (P.skipping)
    {
      const V3 p = o + d * t;
      mj = P.majorant[cellIndex(P, p)];
      tx = fminf_(cellExit(P, o, d, t), tEnd);
      if (tx <= t) // on a boundary: step past it
        tx = fminf_(t + 1e-6f * (1.0f + t), tEnd);
    }
    if (!(mj > 0.0f))
    {
      t = tx;
      continue;
    }
    const float xi = rand01(P, r.pixel, r.sample, 1u, n++);
    const float tau = -logf_(1.0f - xi) / mj;
    if (t + tau < tx)
    {
      t += tau;
      return true;
    }
    t = tx;
  }
  t = tEnd;
  return false;
}

NV_HD float localMajorant(const Params& P, V3 p)
{
  return P.skipping ? P.majorant[cellIndex(P, p)] : P.maxMajorant;
}

/// Uniform direction on the sphere.
NV_HD V3 sphereDir(float u1, float u2)
{
  const float z = 1.0f - 2.0f * u1;
  const float s = sqrtf(fmaxf_(0.0f, 1.0f - z * z));
  const float phi = 6.28318530718f * u2;
  return { s * cosf(phi), s * sinf(phi), z };
}

/// The unit direction at cosine ct from axis a (unit length) and azimuth 2 pi u.
NV_HD V3 aroundAxis(V3 a, float ct, float u)
{
  const float st = sqrtf(fmaxf_(0.0f, 1.0f - ct * ct));
  const float phi = 6.28318530718f * u;
  const V3 h = fabsf(a.x) > 0.9f ? mk(0.0f, 1.0f, 0.0f) : mk(1.0f, 0.0f, 0.0f);
  const V3 b1 = normalize(cross(h, a));
  const V3 b2 = cross(a, b1);
  return b1 * (st * cosf(phi)) + b2 * (st * sinf(phi)) + a * ct;
}

/// The sun's radiance lobe (path tracing): in world direction w (unit length), diffuse * intensity * 2 (n + 1) *
/// max(0, cos)^n around the light direction, n = P.sunExponent. Its integral over the sphere is 4 pi diffuse *
/// intensity whatever n: at a scattering event the sun contributes phase * diffuse * intensity on average, as the
/// diffuse term of ray marching with shadows does.
NV_HD float sunRadiance(const Params& P, V3 w)
{
  const float c = dot(w, P.lightW);
  if (!(c > 0.0f))
    return 0.0f;
  return P.diffuse * P.intensity * 2.0f * (P.sunExponent + 1.0f) * powf_(c, P.sunExponent);
}

/// Direction drawn from the sun's lobe around axis a (unit length): density (n + 1) / (2 pi) cos^n on the
/// hemisphere of a, so sunRadiance / density = 4 pi diffuse * intensity exactly (next-event estimation).
NV_HD V3 sunDir(V3 a, float n, float u1, float u2)
{
  // cos = v^(1 / (n + 1)) with v = 1 - u1 in (0, 1]: never the grazing cosine 0 exactly.
  return aroundAxis(a, powf_(1.0f - u1, 1.0f / (n + 1.0f)), u2);
}

// ---------------------------------------------------------------------------------------------------------
// Ray setup

/// Start the primary ray of pixel (px, py), path `sample` of the pixel. Pixel centres, row 0 at the bottom; the ray
/// starts on the near plane (a camera inside the volume sees it from there) and stops at the far plane or the opaque
/// depth.
NV_HD void initRay(const Params& P, int px, int py, Ray& r, uint32_t sample = 0)
{
  r = Ray{};
  r.pixel = static_cast<uint32_t>(py * P.width + px);
  r.sample = sample;
  const float x = 2.0f * (static_cast<float>(px) + 0.5f) / static_cast<float>(P.width) - 1.0f;
  const float y = 2.0f * (static_cast<float>(py) + 0.5f) / static_cast<float>(P.height) - 1.0f;
  const V3 nearW = unproject(P, x, y, -1.0f), farW = unproject(P, x, y, 1.0f);
  V3 dirW = farW - nearW;
  const float len = sqrtf(dot(dirW, dirW));
  r.phase = Done;
  if (!(len > 0.0f))
    return;
  dirW = dirW * (1.0f / len);
  float tFar = len;
  if (P.depth)
  {
    const float z = P.depth[r.pixel];
    if (z < 1.0f)
    {
      const V3 pd = unproject(P, x, y, 2.0f * z - 1.0f);
      tFar = fminf_(tFar, fmaxf_(0.0f, dot(pd - nearW, dirW)));
    }
  }
  r.origin = toUnit(P, nearW);
  r.direction = dirToUnit(P, dirW);
  r.worldDirection = dirW;
  float t0, t1;
  boxInterval(P, r.origin, r.direction, t0, t1);
  t0 = fmaxf_(t0, 0.0f);
  t1 = fminf_(t1, tFar);
  if (!(t0 < t1))
    return;
  r.marchStart = t0;
  r.segmentEnd = t1;
  r.distance = t0;
  r.throughput[0] = r.throughput[1] = r.throughput[2] = 1.0f;
  r.projection = P.blend == Minimum ? 3.0e38f : (P.blend == Maximum ? -3.0e38f : 0.0f);
  r.phase = P.shading >= PathTrace ? Track : March;
}

/// Samples of a plain marcher on [t0, tEnd): k with t0 + (k + 1/2) h < tEnd.
NV_HD int segmentSamples(float t0, float tEnd, float h)
{
  const float k = ceilf((tEnd - t0) / h - 0.5f);
  return k > 0.0f ? static_cast<int>(k) : 0;
}

NV_HD bool marchSkips(const Params& P)
{
  return P.skipping && (P.blend == Composite || P.blend == Additive);
}
/// Gradient shading needs six neighbours per step; only compositing uses them (projections and additive do not).
NV_HD bool marchGradients(const Params& P)
{
  return P.shading == RayMarchGradient && P.blend == Composite;
}
NV_HD int queriesPerStep(const Params& P)
{
  return marchGradients(P) ? 7 : 1;
}

/// Shadow ray from network point p towards the light (marching with shadows) or in world direction w (NEE).
NV_HD void startShadow(const Params& P, Ray& r, V3 p, V3 w)
{
  r.shadowOrigin = p;
  r.shadowDirection = dirToUnit(P, w);
  float t0, t1;
  boxInterval(P, p, r.shadowDirection, t0, t1);
  r.shadowEnd = fmaxf_(t1, 0.0f);
  r.shadowTransmittance = 1.0f;
  r.shadowSampleIndex = 0;
  r.distance = 0.0f;
}

} // namespace ray
} // namespace nv
