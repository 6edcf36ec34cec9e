// NeuralVolume engine: secondary rays beyond the clip box, through the coarse surroundings grid (host-device code;
// RenderRequest::surroundings). Under MPI a rank's network covers its padded piece only and its primary rays march
// its own piece (the clip box), but light reaches a sample through the whole dataset: the shadow ray of
// RayMarchShadows, the sun's shadow ray of PathTraceNee and the scattered segments of path tracing continue, once
// they leave the clip box, through a coarse grid of the whole field here -- trilinear lookups of its normalised values
// and the transfer function, no network queries -- until they leave the grid's box. The random numbers come from the
// ray's own streams (RayTraversal.h's rand01, the counters nFlight and nEvent continued), so every backend and path
// draws the same ones.
#pragma once

#include "RayTraversal.h"

namespace nv
{
namespace ray
{

/// [t0, t1] of o + t d inside the surroundings grid's box (t0 > t1: no intersection).
NV_HD void surroundInterval(const Params& P, V3 o, V3 d, float& t0, float& t1)
{
  boxIntervalOf(P.surroundBox, o, d, t0, t1);
}

/// True when secondary rays continue through the surroundings (a grid is bound and something in it is opaque).
NV_HD bool surroundsAnything(const Params& P)
{
  return P.surround != nullptr && P.surroundMajorant > 0.0f;
}

/// Value of the surroundings (normalised to the grid's range) at network point p: trilinear in the grid, the finite corners' weights
/// renormalised where some corners have no data; NaN (transparent) outside the grid's box or where no corner has a
/// value.
NV_HD float surroundValue(const Params& P, V3 p)
{
  const float pp[3] = { p.x, p.y, p.z };
  int base[3];
  float frac[3];
  for (int a = 0; a < 3; ++a)
  {
    const float g = (pp[a] - P.surroundBox[2 * a]) * P.surroundScale[a];
    const float last = static_cast<float>(P.surroundDims[a] - 1);
    if (!(g >= 0.0f && g <= last)) // outside (or NaN): no value
      return NAN;
    int i = floorInt(g);
    i = i > P.surroundDims[a] - 2 ? P.surroundDims[a] - 2 : i;
    base[a] = i;
    frac[a] = g - static_cast<float>(i);
  }
  const int64_t nx = P.surroundDims[0], nxy = nx * P.surroundDims[1];
  const int64_t origin = base[2] * nxy + base[1] * nx + base[0];
  float sum = 0.0f, weights = 0.0f;
  for (int corner = 0; corner < 8; ++corner)
  {
    const int cx = corner & 1, cy = (corner >> 1) & 1, cz = corner >> 2;
    const float w = (cx ? frac[0] : 1.0f - frac[0]) * (cy ? frac[1] : 1.0f - frac[1]) *
      (cz ? frac[2] : 1.0f - frac[2]);
    const float v = P.surround[origin + cz * nxy + cy * nx + cx];
    if (v == v)
    {
      sum += w * v;
      weights += w;
    }
  }
  return weights > 1e-6f ? sum / weights : NAN;
}

/// Colour and extinction (per world unit) of the surroundings at network point p.
NV_HD void surroundLookup(const Params& P, V3 p, float e[4])
{
  lookupEntry(P, surroundValue(P, p) * P.surroundTfScale + P.surroundTfShift, e);
}

/// Ray marching with shadows: the transmittance of the shadow ray o + t d beyond the clip box, times `transmittance`.
/// Its samples continue the clip box's lattice (sample k at (k + 1/2) h, from index j on) from its exit tStart to
/// the surroundings' exit; below `cutoff` it is 0.
NV_HD float marchSurroundings(const Params& P, V3 o, V3 d, int j, float tStart, float h, float transmittance,
  float cutoff)
{
  if (!surroundsAnything(P) || !(transmittance > 0.0f))
    return transmittance;
  float t0, t1;
  surroundInterval(P, o, d, t0, t1);
  const float first = ceilf(fmaxf_(tStart, t0) / h - 0.5f);
  if (first > static_cast<float>(j))
    j = first < 2.0e9f ? static_cast<int>(first) : 2000000000;
  for (int guard = 0; guard < kMaxIterations; ++guard, ++j)
  {
    const float t = (static_cast<float>(j) + 0.5f) * h;
    if (!(t < t1))
      break;
    float e[4];
    surroundLookup(P, o + d * t, e);
    transmittance *= expNeg(e[3] * h);
    if (transmittance < cutoff)
      return 0.0f;
  }
  return transmittance;
}

/// Path tracing + NEE: ratio tracking of the sun's shadow ray o + t d through the surroundings from tStart (its
/// clip-box exit, or 0 for a ray that starts in the surroundings) to their exit with the grid's majorant, times
/// `transmittance`; the flight stream from counter n (advanced). Below 1e-4 it is 0.
NV_HD float ratioTrackSurroundings(const Params& P, const Ray& r, V3 o, V3 d, float tStart, uint32_t& n,
  float transmittance)
{
  if (!surroundsAnything(P) || !(transmittance > 0.0f))
    return transmittance;
  float t0, t1;
  surroundInterval(P, o, d, t0, t1);
  const float mj = P.surroundMajorant;
  float t = fmaxf_(tStart, t0);
  for (int guard = 0; guard < kMaxIterations; ++guard)
  {
    t += -logf_(1.0f - rand01(P, r.pixel, r.sample, 1u, n++)) / mj;
    if (!(t < t1))
      break;
    float e[4];
    surroundLookup(P, o + d * t, e);
    transmittance *= fmaxf_(0.0f, 1.0f - e[3] / mj);
    if (transmittance < 1e-4f)
      return 0.0f;
  }
  return transmittance;
}

/// Path tracing: delta tracking of the segment r.origin + t r.direction through the surroundings from t (advanced)
/// with the grid's majorant. True at a real collision (e: its colour and extinction); false when the segment leaves
/// the surroundings first. Flights from the ray's flight stream, the collision test from its event stream.
NV_HD bool trackSurroundings(const Params& P, Ray& r, float& t, float e[4])
{
  if (!surroundsAnything(P))
    return false;
  float t0, t1;
  surroundInterval(P, r.origin, r.direction, t0, t1);
  const float mj = P.surroundMajorant;
  t = fmaxf_(t, t0);
  for (int guard = 0; guard < kMaxIterations; ++guard)
  {
    t += -logf_(1.0f - rand01(P, r.pixel, r.sample, 1u, r.nFlight++)) / mj;
    if (!(t < t1))
      return false;
    surroundLookup(P, r.origin + r.direction * t, e);
    if (rand01(P, r.pixel, r.sample, 3u, r.nEvent++) * mj < e[3])
      return true;
  }
  return false;
}

} // namespace ray
} // namespace nv
