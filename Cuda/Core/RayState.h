// NeuralVolume engine: the state of a ray and the parameters every ray reads (host-device plain data). See
// RayMachine.h for how a ray is driven.
#pragma once

#include "DomainMask.h"
#include "Macrocells.h"
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
  float box[6];          ///< the box rays march in network coordinates (RenderRequest::clipBox)
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
  float sunExponent;     ///< the sun's radiance lobe: max(0, cos)^sunExponent around lightW (sunRadiance)
  float anisotropy;      ///< Henyey-Greenstein anisotropy of the phase function (0: isotropic)
  int maxBounces;
  uint32_t seed, frame;
  const float* depth;    ///< window depth of opaque geometry per pixel, or null
  // The source's domain (SourceInfo::domain, in the renderer's memory): one bit per source sample, x fastest;
  // null: the whole box. A query whose nearest source sample is outside has no value (NaN: transparent).
  const uint32_t* domain;
  int domainDims[3];
  // A sparse source (SourceInfo::occupancy, in the renderer's memory): one bit per macrocell; a query in a cell
  // without it takes `background` (normalised) exactly. Null: every cell occupied.
  const uint32_t* occupancy;
  float background;
  // The surroundings (RenderRequest::surroundings, in the renderer's memory; RaySurroundings.h): values normalised
  // to the grid's own finite range (NaN: no data) on a grid whose corner samples lie at surroundBox (network coordinates). Secondary rays continue
  // through it beyond the clip box. Null: they stop at the clip box.
  const float* surround;
  int surroundDims[3];
  float surroundBox[6];
  float surroundScale[3];   ///< grid coordinate along a = (u_a - surroundBox[2a]) * surroundScale[a]
  float surroundTfScale, surroundTfShift; ///< the entry coordinate of a grid value y: y * scale + shift (the grid is
                                          ///< normalised to its own value range, not the network's)
  float surroundMajorant;   ///< the largest extinction the transfer function gives over the grid's values
};

/// True when the nearest source sample of network point q is inside the domain (or there is no domain mask).
NV_HD bool inDomain(const Params& P, const V3& q)
{
  return !P.domain || domainBit(P.domain, P.domainDims, q.x, q.y, q.z);
}

/// True when the macrocell of network point q is occupied (or there is no occupancy mask).
NV_HD bool inOccupiedCell(const Params& P, const V3& q)
{
  if (!P.occupancy)
    return true;
  MacrocellLayout m;
  for (int a = 0; a < 3; ++a)
  {
    m.dims[a] = P.mc[a];
    m.scale[a] = P.mcScale[a];
  }
  return cellOccupied(P.occupancy, m, q.x, q.y, q.z);
}

/// After the queries q[0..n) are evaluated into v: NaN (no value) for those outside the source's domain, the
/// background for those in an empty cell of a sparse source.
NV_HD void maskOutsideDomain(const Params& P, const V3* q, float* v, int n)
{
  if (!P.domain && !P.occupancy)
    return;
  for (int i = 0; i < n; ++i)
  {
    if (!inDomain(P, q[i]))
      v[i] = NAN;
    else if (!inOccupiedCell(P, q[i]))
      v[i] = P.background;
  }
}

struct Ray
{
  V3 origin, direction;             ///< network coordinates: p(t) = origin + t direction, t in world units
  V3 worldDirection;                ///< world direction of the current segment (unit length)
  float marchStart;                 ///< marching: start of the first segment
  float segmentEnd;                 ///< end of the current segment (box exit / opaque depth)
  float distance;                   ///< tracking: current distance t
  int sampleIndex;                  ///< marching: index j of the next sample, at marchStart + (j + 1/2) dt
  V3 shadowOrigin, shadowDirection; ///< shadow / NEE ray
  float shadowEnd;                  ///< its end
  float shadowTransmittance;        ///< its transmittance
  int shadowSampleIndex;            ///< shadow marching: next sample index
  float rgba[4];                    ///< accumulated premultiplied colour and opacity
  float pending[4];                 ///< shadows: the pending sample's shaded rgb and alpha; NEE: phase weight
  float throughput[3];              ///< path tracing: throughput
  float projection;                 ///< Maximum / Minimum / Average / Additive accumulator
  int count;                        ///< Average: samples in range
  uint32_t pixel;
  uint32_t sample;                  ///< path index within the pixel (several paths per pixel per render)
  uint32_t nFlight;                 ///< counter of the free-flight random stream
  uint32_t nEvent;                  ///< counter of the event random stream
  int phase;
  int bounces;
  int plain;                        ///< samples a plain marcher takes on this ray (set when marching ends)
};

} // namespace ray
} // namespace nv
