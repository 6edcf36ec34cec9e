// NeuralVolume engine: the per-ray state machine of every render path and backend (host-device code).
//
// A ray alternates between emit() -- the next queries (points in network coordinates [0,1]^3) whose field values it
// needs -- and consume() -- those values, in order. emit() is a pure function of the ray; consume() replays the
// same sequence (skipping decisions, free-flight distances) and advances the ray. The three render paths differ
// only in who evaluates the queries between the two calls:
//   Decode:          a trilinear lookup in the decoded grid, one query at a time;
//   In-Shader:       the encoding + MLP inside the marching kernel (GPU: a warp's lanes together on tensor cores);
//   Sample Streaming: every live ray emits up to K steps, all queries are inferred in one batch, then consumed.
// Every iteration either emits at least one query or ends / changes phase in consume(values, 0), so the loop
//   while (r.phase != Done) { n = emit(P, r, K, q); evaluate(q, n, v); consume(P, r, K, v, n); }
// terminates. Geometry: the ray lives in network coordinates u with p(t) = o + t d, where t is the world distance
// (d is the image of a unit world direction), so opacity correction and step sizes are in world units whatever the
// voxel spacing. Colours are premultiplied.
#pragma once

#include "HashGridMath.h"
#include "HostDevice.h"

#include <cstdint>

#if !defined(__CUDACC__)
#include <cmath>
#endif

namespace nv
{
namespace ray
{

struct V3
{
  float x, y, z;
};
NV_HD V3 mk(float x, float y, float z)
{
  return { x, y, z };
}
NV_HD V3 operator+(V3 a, V3 b)
{
  return { a.x + b.x, a.y + b.y, a.z + b.z };
}
NV_HD V3 operator-(V3 a, V3 b)
{
  return { a.x - b.x, a.y - b.y, a.z - b.z };
}
NV_HD V3 operator*(V3 a, float s)
{
  return { a.x * s, a.y * s, a.z * s };
}
NV_HD float dot(V3 a, V3 b)
{
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
NV_HD V3 cross(V3 a, V3 b)
{
  return { a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x };
}
NV_HD V3 normalize(V3 a)
{
  const float l = sqrtf(dot(a, a));
  return l > 0.0f ? a * (1.0f / l) : a;
}
NV_HD float clamp01(float x)
{
  return x < 0.0f ? 0.0f : (x > 1.0f ? 1.0f : x);
}
NV_HD float fminf_(float a, float b)
{
  return a < b ? a : b;
}
NV_HD float fmaxf_(float a, float b)
{
  return a > b ? a : b;
}

enum Phase : int
{
  Done = 0,
  March = 1,  ///< ray marching along the primary ray
  Shadow = 2, ///< ray marching with shadows: the shadow ray of a pending sample
  Track = 3,  ///< path tracing: delta tracking along the current path segment
  Nee = 4     ///< path tracing: ratio-tracked shadow ray towards the sun
};

/// Values as in Render.h (ShadingMode, BlendMode).
enum Shading : int
{
  RayMarch = 0,
  RayMarchGradient = 1,
  RayMarchShadows = 2,
  PathTrace = 3,
  PathTraceNee = 4
};
enum Blend : int
{
  Composite = 0,
  Maximum = 1,
  Minimum = 2,
  Average = 3,
  Additive = 4
};

constexpr int kMaxQueriesPerStep = 7; ///< gradient shading: centre and six neighbours
constexpr int kMaxIterations = 1 << 20; ///< safety bound of the emit/consume loop

/// Everything a ray needs; plain data, copied to the GPU by value. Pointers live in the executing memory space.
struct Params
{
  int width, height;
  float clipToWorld[16]; ///< inverse view-projection, row-major
  float worldToUnit[12]; ///< rows of the affine map world -> network coordinates
  float dt;              ///< world distance between samples of a primary ray
  float dtShadow;        ///< world distance between samples of a shadow ray (ray marching with shadows)
  float termination;     ///< early ray termination opacity (>= 1: off)
  float gradH[3];        ///< central-difference half steps in network coordinates
  // Transfer function: entries (r, g, b, extinction per world unit), linear between entries; the entry coordinate
  // of a normalised value y is y * tfScale + tfShift, clamped to [0, tfSize - 1].
  const float* tf;
  int tfSize;
  float tfScale, tfShift;
  float unitDistance;    ///< for the raw opacity of an entry: 1 - exp(-extinction * unitDistance)
  // Macrocells: per cell the largest extinction the transfer function gives over the cell's value range (0: empty).
  const float* majorant;
  int mc[3];
  float mcScale[3];      ///< cell index along axis a = floor(u_a * mcScale[a])
  float maxMajorant;     ///< the largest majorant of all cells (tracking without skipping)
  int skipping;          ///< 1: skip empty cells (marching) and use local majorants (tracking)
  int shading, blend;
  float avgLo, avgHi;    ///< Average blend: normalised range (avgLo >= avgHi: every value)
  V3 lightW;             ///< world direction towards the light, unit length
  float ambient, diffuse, specular, specularPower, intensity;
  float sunCos;          ///< cosine of the sun's angular radius
  float g;               ///< Henyey-Greenstein anisotropy of the phase function (0: isotropic)
  int maxBounces;
  uint32_t seed, frame;
  const float* depth;    ///< window depth of opaque geometry per pixel, or null
};

struct Ray
{
  V3 o, d;          ///< network coordinates: p(t) = o + t d, t in world units
  V3 dW;            ///< world direction of the current segment (unit length)
  float t0, tEnd;   ///< marching: first segment start; end of the current segment (box exit / opaque depth)
  float t;          ///< tracking: current distance
  int j;            ///< marching: index of the next sample, at t0 + (j + 1/2) dt
  V3 so, sd;        ///< shadow / NEE ray
  float stEnd, sT;  ///< its end and transmittance
  int sj;           ///< shadow marching: next sample index
  float c[4];       ///< accumulated premultiplied colour and opacity
  float pend[4];    ///< marching with shadows: the pending sample's shaded colour (rgb) and alpha; NEE: phase weight
  float thr[3];     ///< path tracing: throughput
  float acc;        ///< Maximum / Minimum / Average / Additive accumulator
  int count;        ///< Average: samples in range
  uint32_t pixel;
  uint32_t sample;  ///< path index within the pixel (several paths per pixel per render)
  uint32_t nFlight; ///< counter of the free-flight random stream
  uint32_t nEvent;  ///< counter of the event random stream
  int phase;
  int bounces;
  int plain;        ///< samples a plain marcher takes on this ray (set when marching ends)
};

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

/// [t0, t1] of o + t d inside [0,1]^3 (t0 > t1: no intersection).
NV_HD void boxInterval(V3 o, V3 d, float& t0, float& t1)
{
  const float oo[3] = { o.x, o.y, o.z }, dd[3] = { d.x, d.y, d.z };
  t0 = -3.0e38f;
  t1 = 3.0e38f;
  for (int a = 0; a < 3; ++a)
  {
    if (dd[a] == 0.0f)
    {
      if (oo[a] < 0.0f || oo[a] > 1.0f)
      {
        t0 = 1.0f;
        t1 = 0.0f;
        return;
      }
      continue;
    }
    const float inv = 1.0f / dd[a];
    float a0 = (0.0f - oo[a]) * inv, a1 = (1.0f - oo[a]) * inv;
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

NV_HD V3 clampUnit(V3 p)
{
  return { clamp01(p.x), clamp01(p.y), clamp01(p.z) };
}

/// Transfer function at normalised value y: colour and extinction (per world unit).
NV_HD void lookup(const Params& P, float y, float out[4])
{
  float c = y * P.tfScale + P.tfShift;
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

/// Uniform direction in the cone of cosine cosMax around axis a (unit length).
NV_HD V3 coneDir(V3 a, float cosMax, float u1, float u2)
{
  const float ct = 1.0f - u1 * (1.0f - cosMax);
  const float st = sqrtf(fmaxf_(0.0f, 1.0f - ct * ct));
  const float phi = 6.28318530718f * u2;
  const V3 h = fabsf(a.x) > 0.9f ? mk(0.0f, 1.0f, 0.0f) : mk(1.0f, 0.0f, 0.0f);
  const V3 b1 = normalize(cross(h, a));
  const V3 b2 = cross(a, b1);
  return b1 * (st * cosf(phi)) + b2 * (st * sinf(phi)) + a * ct;
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
  r.o = toUnit(P, nearW);
  r.d = dirToUnit(P, dirW);
  r.dW = dirW;
  float t0, t1;
  boxInterval(r.o, r.d, t0, t1);
  t0 = fmaxf_(t0, 0.0f);
  t1 = fminf_(t1, tFar);
  if (!(t0 < t1))
    return;
  r.t0 = t0;
  r.tEnd = t1;
  r.t = t0;
  r.thr[0] = r.thr[1] = r.thr[2] = 1.0f;
  r.acc = P.blend == Minimum ? 3.0e38f : (P.blend == Maximum ? -3.0e38f : 0.0f);
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
  r.so = p;
  r.sd = dirToUnit(P, w);
  float t0, t1;
  boxInterval(p, r.sd, t0, t1);
  r.stEnd = fmaxf_(t1, 0.0f);
  r.sT = 1.0f;
  r.sj = 0;
  r.t = 0.0f;
}

// ---------------------------------------------------------------------------------------------------------
// emit

/// Write the queries of the next (at most) K steps into q (room for K * queriesPerStep(P)); returns their number.
/// q may be null: only count them.
NV_HD int emit(const Params& P, const Ray& r, int K, V3* q)
{
  int n = 0;
  switch (r.phase)
  {
    case March:
    {
      const bool skip = marchSkips(P);
      const bool grad = marchGradients(P);
      int j = r.j;
      for (int k = 0; k < K; ++k, ++j)
      {
        float t;
        if (!nextSample(P, r.o, r.d, r.t0, r.tEnd, P.dt, skip, j, t))
          break;
        const V3 p = r.o + r.d * t;
        if (!q)
        {
          n += grad ? 7 : 1;
          continue;
        }
        q[n++] = clampUnit(p);
        if (grad)
        {
          q[n++] = clampUnit(mk(p.x + P.gradH[0], p.y, p.z));
          q[n++] = clampUnit(mk(p.x - P.gradH[0], p.y, p.z));
          q[n++] = clampUnit(mk(p.x, p.y + P.gradH[1], p.z));
          q[n++] = clampUnit(mk(p.x, p.y - P.gradH[1], p.z));
          q[n++] = clampUnit(mk(p.x, p.y, p.z + P.gradH[2]));
          q[n++] = clampUnit(mk(p.x, p.y, p.z - P.gradH[2]));
        }
      }
      return n;
    }
    case Shadow:
    {
      int j = r.sj;
      for (int k = 0; k < K; ++k, ++j)
      {
        float t;
        if (!nextSample(P, r.so, r.sd, 0.0f, r.stEnd, P.dtShadow, P.skipping != 0, j, t))
          break;
        if (q)
          q[n] = clampUnit(r.so + r.sd * t);
        ++n;
      }
      return n;
    }
    case Track:
    case Nee:
    {
      const bool nee = r.phase == Nee;
      const V3 o = nee ? r.so : r.o, d = nee ? r.sd : r.d;
      const float tEnd = nee ? r.stEnd : r.tEnd;
      float t = r.t;
      uint32_t c = r.nFlight;
      for (int k = 0; k < K; ++k)
      {
        if (!nextFlight(P, r, o, d, tEnd, t, c))
          break;
        if (q)
          q[n] = clampUnit(o + d * t);
        ++n;
      }
      return n;
    }
    default:
      return 0;
  }
}

// ---------------------------------------------------------------------------------------------------------
// consume

/// Blinn-Phong with the light, the normal facing the viewer (two-sided), white specular.
NV_HD void shadeGradient(const Params& P, const Ray& r, const float* v, float rgb[3])
{
  const V3 gu = mk((v[1] - v[2]) / (2.0f * P.gradH[0]), (v[3] - v[4]) / (2.0f * P.gradH[1]),
    (v[5] - v[6]) / (2.0f * P.gradH[2]));
  V3 g = gradToWorld(P, gu);
  const float gl = sqrtf(dot(g, g));
  if (!(gl > 1e-12f))
  {
    for (int k = 0; k < 3; ++k)
      rgb[k] *= (P.ambient + P.diffuse) * P.intensity;
    return;
  }
  V3 nrm = g * (-1.0f / gl);
  const V3 view = r.dW * -1.0f;
  if (dot(nrm, view) < 0.0f)
    nrm = nrm * -1.0f;
  const float ndl = fmaxf_(dot(nrm, P.lightW), 0.0f);
  const V3 h = normalize(P.lightW + view);
  const float ndh = fmaxf_(dot(nrm, h), 0.0f);
  const float spec = ndl > 0.0f ? P.specular * powf_(ndh, P.specularPower) : 0.0f;
  for (int k = 0; k < 3; ++k)
    rgb[k] = P.intensity * (rgb[k] * (P.ambient + P.diffuse * ndl) + spec);
}

NV_HD void compositeSample(Ray& r, const float rgb[3], float alpha)
{
  const float w = (1.0f - r.c[3]) * alpha;
  r.c[0] += w * rgb[0];
  r.c[1] += w * rgb[1];
  r.c[2] += w * rgb[2];
  r.c[3] += w;
}

/// Final colour of the projection blends from the accumulated value.
NV_HD void finishProjection(const Params& P, Ray& r)
{
  float y = r.acc;
  if (P.blend == Average)
    y = r.count > 0 ? r.acc / static_cast<float>(r.count) : 0.0f;
  if (P.blend == Additive)
  {
    for (int k = 0; k < 4; ++k)
      r.c[k] = fminf_(r.c[k], 1.0f);
    return;
  }
  const bool any = P.blend == Average ? r.count > 0 : (r.acc > -1.0e38f && r.acc < 1.0e38f);
  if (!any)
    return;
  float e[4];
  lookup(P, y, e);
  const float a = 1.0f - expNeg(e[3] * P.unitDistance);
  r.c[0] = e[0] * a;
  r.c[1] = e[1] * a;
  r.c[2] = e[2] * a;
  r.c[3] = a;
}

/// Start a new path segment from network point p in world direction w.
NV_HD void startSegment(const Params& P, Ray& r, V3 p, V3 w)
{
  r.o = p;
  r.dW = w;
  r.d = dirToUnit(P, w);
  float t0, t1;
  boxInterval(p, r.d, t0, t1);
  r.t = 0.0f;
  r.tEnd = fmaxf_(t1, 0.0f);
}

/// A path leaves the volume: sky, and the sun when it is not sampled by NEE.
NV_HD void escape(const Params& P, Ray& r)
{
  if (r.bounces > 0)
  {
    float L = P.ambient * P.intensity;
    if (P.shading != PathTraceNee && dot(r.dW, P.lightW) >= P.sunCos)
    {
      const float omega = 6.28318530718f * (1.0f - P.sunCos);
      L += P.diffuse * P.intensity * 12.5663706144f / omega;
    }
    for (int k = 0; k < 3; ++k)
      r.c[k] += r.thr[k] * L;
  }
  r.phase = Done;
}

/// Henyey-Greenstein phase function times 4 pi (1 for g = 0) at the cosine between incoming and outgoing directions.
NV_HD float phase4pi(float g, float cosTheta)
{
  if (g == 0.0f)
    return 1.0f;
  const float d = 1.0f + g * g - 2.0f * g * cosTheta;
  return (1.0f - g * g) / (d * sqrtf(fmaxf_(d, 1e-12f)));
}

/// Direction sampled from the Henyey-Greenstein phase function around the incoming direction w (unit length).
NV_HD V3 phaseDir(float g, V3 w, float u1, float u2)
{
  if (g == 0.0f)
    return sphereDir(u1, u2);
  const float s = (1.0f - g * g) / (1.0f - g + 2.0f * g * u1);
  float ct = (1.0f + g * g - s * s) / (2.0f * g);
  ct = ct < -1.0f ? -1.0f : (ct > 1.0f ? 1.0f : ct);
  const float st = sqrtf(fmaxf_(0.0f, 1.0f - ct * ct));
  const float phi = 6.28318530718f * u2;
  const V3 h = fabsf(w.x) > 0.9f ? mk(0.0f, 1.0f, 0.0f) : mk(1.0f, 0.0f, 0.0f);
  const V3 b1 = normalize(cross(h, w));
  const V3 b2 = cross(w, b1);
  return b1 * (st * cosf(phi)) + b2 * (st * sinf(phi)) + w * ct;
}

/// New direction after a scattering event at p (NEE done or not used).
NV_HD void scatter(const Params& P, Ray& r, V3 p)
{
  const float u1 = rand01(P, r.pixel, r.sample, 2u, r.nEvent++), u2 = rand01(P, r.pixel, r.sample, 2u, r.nEvent++);
  ++r.bounces;
  startSegment(P, r, p, phaseDir(P.g, r.dW, u1, u2));
}

/// Consume the n values of the queries emit(P, r, K, q) produced (same K), in order.
NV_HD void consume(const Params& P, Ray& r, int K, const float* v, int n)
{
  switch (r.phase)
  {
    case March:
    {
      const bool skip = marchSkips(P);
      const int qs = queriesPerStep(P);
      const bool projection = P.blend != Composite && P.blend != Additive;
      int j = r.j;
      for (int k = 0; k < K; ++k, ++j)
      {
        float t;
        // emit() stopped before K steps only where the segment ends: then so does the ray.
        if (k * qs >= n || !nextSample(P, r.o, r.d, r.t0, r.tEnd, P.dt, skip, j, t))
        {
          r.plain = segmentSamples(r.t0, r.tEnd, P.dt);
          if (projection || P.blend == Additive)
            finishProjection(P, r);
          r.phase = Done;
          return;
        }
        const float* s = v + k * qs;
        const float y = s[0];
        if (projection)
        {
          if (!(y == y)) // NaN (a hole in a reference grid): not a value
            continue;
          if (P.blend == Maximum)
            r.acc = fmaxf_(r.acc, y);
          else if (P.blend == Minimum)
            r.acc = fminf_(r.acc, y);
          else if (P.avgLo >= P.avgHi || (y >= P.avgLo && y <= P.avgHi))
          {
            r.acc += y;
            ++r.count;
          }
          continue;
        }
        float e[4];
        lookup(P, y, e);
        const float alpha = 1.0f - expNeg(e[3] * P.dt);
        if (!(alpha > 0.0f))
          continue;
        float rgb[3] = { e[0], e[1], e[2] };
        if (P.blend == Additive)
        {
          for (int c = 0; c < 3; ++c)
            r.c[c] += alpha * rgb[c];
          r.c[3] += alpha;
          continue;
        }
        if (P.shading == RayMarchGradient)
          shadeGradient(P, r, s, rgb);
        if (P.shading == RayMarchShadows)
        {
          for (int c = 0; c < 3; ++c)
            r.pend[c] = rgb[c];
          r.pend[3] = alpha;
          r.j = j + 1;
          startShadow(P, r, r.o + r.d * t, P.lightW);
          r.phase = Shadow;
          return;
        }
        compositeSample(r, rgb, alpha);
        if (r.c[3] >= P.termination)
        {
          r.plain = j + 1;
          r.phase = Done;
          return;
        }
      }
      r.j = j;
      return;
    }
    case Shadow:
    {
      int j = r.sj;
      bool end = false;
      for (int k = 0; k < K; ++k, ++j)
      {
        float t;
        if (k >= n || !nextSample(P, r.so, r.sd, 0.0f, r.stEnd, P.dtShadow, P.skipping != 0, j, t))
        {
          end = true; // the shadow ray left the volume
          break;
        }
        float e[4];
        lookup(P, v[k], e);
        r.sT *= expNeg(e[3] * P.dtShadow);
        if (r.sT < 1e-3f)
        {
          r.sT = 0.0f;
          end = true;
          break;
        }
      }
      r.sj = j;
      if (!end)
        return;
      float rgb[3];
      const float light = P.intensity * (P.ambient + P.diffuse * r.sT);
      for (int c = 0; c < 3; ++c)
        rgb[c] = r.pend[c] * light;
      compositeSample(r, rgb, r.pend[3]);
      r.phase = March;
      if (r.c[3] >= P.termination)
      {
        r.plain = r.j;
        r.phase = Done;
      }
      return;
    }
    case Track:
    {
      float t = r.t;
      uint32_t c = r.nFlight;
      for (int k = 0; k < K; ++k)
      {
        // nextFlight first: where emit() found the segment's end it drew random numbers past the last collision,
        // and the replay must draw them too (the stream continues after this segment).
        if (!nextFlight(P, r, r.o, r.d, r.tEnd, t, c) || k >= n)
        {
          // emit() stopped before K tentative collisions only where the segment ends: the path escapes.
          r.t = r.tEnd;
          r.nFlight = c;
          escape(P, r);
          return;
        }
        const V3 p = r.o + r.d * t;
        const float mj = localMajorant(P, clampUnit(p));
        float e[4];
        lookup(P, v[k], e);
        const float xi = rand01(P, r.pixel, r.sample, 3u, r.nEvent++);
        if (xi * mj < e[3]) // real collision
        {
          r.t = t;
          r.nFlight = c;
          r.c[3] = 1.0f;
          if (r.bounces >= P.maxBounces)
          {
            r.phase = Done;
            return;
          }
          for (int q = 0; q < 3; ++q)
            r.thr[q] *= e[q];
          if (P.shading == PathTraceNee)
          {
            const float u1 = rand01(P, r.pixel, r.sample, 4u, r.nEvent++), u2 = rand01(P, r.pixel, r.sample, 4u, r.nEvent++);
            const V3 w = coneDir(P.lightW, P.sunCos, u1, u2);
            r.pend[0] = phase4pi(P.g, dot(r.dW, w)); // phase weight of the sun direction
            startShadow(P, r, clampUnit(p), w);
            r.phase = Nee;
          }
          else
          {
            scatter(P, r, clampUnit(p));
          }
          return;
        }
      }
      r.t = t;
      r.nFlight = c;
      return;
    }
    case Nee:
    {
      float t = r.t;
      uint32_t c = r.nFlight;
      bool end = false;
      for (int k = 0; k < K; ++k)
      {
        // nextFlight first, as in Track: the path's flights continue this stream after the shadow ray, so the
        // number that overshot the shadow ray's end must be consumed here (else the next flight reuses it and is
        // biased long).
        if (!nextFlight(P, r, r.so, r.sd, r.stEnd, t, c) || k >= n)
        {
          end = true; // the shadow ray left the volume
          break;
        }
        const V3 p = r.so + r.sd * t;
        const float mj = localMajorant(P, clampUnit(p));
        float e[4];
        lookup(P, v[k], e);
        // mj is > 0 where nextFlight stopped; a point rounded into a neighbouring empty cell must not give 0/0.
        const float ratio = mj > 0.0f ? e[3] / mj : (e[3] > 0.0f ? 1.0f : 0.0f);
        r.sT *= fmaxf_(0.0f, 1.0f - ratio);
        if (r.sT < 1e-4f)
        {
          r.sT = 0.0f;
          end = true;
          break;
        }
      }
      r.t = t;
      r.nFlight = c;
      if (!end)
        return;
      for (int q = 0; q < 3; ++q)
        r.c[q] += r.thr[q] * P.diffuse * P.intensity * r.sT * r.pend[0];
      scatter(P, r, r.so);
      r.phase = Track;
      return;
    }
    default:
      return;
  }
}

/// The pixel's premultiplied colour and opacity once the ray is done.
NV_HD void result(const Ray& r, float out[4])
{
  for (int k = 0; k < 4; ++k)
    out[k] = r.c[k];
}

} // namespace ray
} // namespace nv
