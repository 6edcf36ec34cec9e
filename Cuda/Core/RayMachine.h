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

#include "RaySurroundings.h"

namespace nv
{
namespace ray
{

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
      int j = r.sampleIndex;
      for (int k = 0; k < K; ++k, ++j)
      {
        float t;
        if (!nextSample(P, r.origin, r.direction, r.marchStart, r.segmentEnd, P.dt, skip, j, t))
          break;
        const V3 p = r.origin + r.direction * t;
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
      int j = r.shadowSampleIndex;
      for (int k = 0; k < K; ++k, ++j)
      {
        float t;
        if (!nextSample(P, r.shadowOrigin, r.shadowDirection, 0.0f, r.shadowEnd, P.dtShadow, P.skipping != 0, j, t))
          break;
        if (q)
          q[n] = clampUnit(r.shadowOrigin + r.shadowDirection * t);
        ++n;
      }
      return n;
    }
    case Track:
    case Nee:
    {
      const bool nee = r.phase == Nee;
      const V3 o = nee ? r.shadowOrigin : r.origin, d = nee ? r.shadowDirection : r.direction;
      const float tEnd = nee ? r.shadowEnd : r.segmentEnd;
      float t = r.distance;
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
  // A neighbour outside the source's domain (NaN) counts as the centre value: a one-sided difference there.
  float w[7];
  for (int k = 0; k < 7; ++k)
    w[k] = v[k] == v[k] ? v[k] : v[0];
  const V3 gu = mk((w[1] - w[2]) / (2.0f * P.gradH[0]), (w[3] - w[4]) / (2.0f * P.gradH[1]),
    (w[5] - w[6]) / (2.0f * P.gradH[2]));
  V3 g = gradToWorld(P, gu);
  const float gl = sqrtf(dot(g, g));
  if (!(gl > 1e-12f))
  {
    for (int k = 0; k < 3; ++k)
      rgb[k] *= (P.ambient + P.diffuse) * P.intensity;
    return;
  }
  V3 nrm = g * (-1.0f / gl);
  const V3 view = r.worldDirection * -1.0f;
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
  const float w = (1.0f - r.rgba[3]) * alpha;
  r.rgba[0] += w * rgb[0];
  r.rgba[1] += w * rgb[1];
  r.rgba[2] += w * rgb[2];
  r.rgba[3] += w;
}

/// Final colour of the projection blends from the accumulated value.
NV_HD void finishProjection(const Params& P, Ray& r)
{
  float y = r.projection;
  if (P.blend == Average)
    y = r.count > 0 ? r.projection / static_cast<float>(r.count) : 0.0f;
  if (P.blend == Additive)
  {
    for (int k = 0; k < 4; ++k)
      r.rgba[k] = fminf_(r.rgba[k], 1.0f);
    return;
  }
  const bool any = P.blend == Average ? r.count > 0 : (r.projection > -1.0e38f && r.projection < 1.0e38f);
  if (!any)
    return;
  float e[4];
  lookup(P, y, e);
  const float a = 1.0f - expNeg(e[3] * P.unitDistance);
  r.rgba[0] = e[0] * a;
  r.rgba[1] = e[1] * a;
  r.rgba[2] = e[2] * a;
  r.rgba[3] = a;
}

/// Start a new path segment from network point p in world direction w.
NV_HD void startSegment(const Params& P, Ray& r, V3 p, V3 w)
{
  r.origin = p;
  r.worldDirection = w;
  r.direction = dirToUnit(P, w);
  float t0, t1;
  boxInterval(P, p, r.direction, t0, t1);
  r.distance = 0.0f;
  r.segmentEnd = fmaxf_(t1, 0.0f);
}

/// A path leaves the volume after at least one scattering event: the uniform sky, and the sun's lobe when NEE does
/// not sample it. (A primary ray that leaves the volume shows the view's background, in both modes.)
NV_HD void escape(const Params& P, Ray& r)
{
  if (r.bounces > 0)
  {
    float L = P.ambient * P.intensity;
    if (P.shading != PathTraceNee)
      L += sunRadiance(P, r.worldDirection);
    for (int k = 0; k < 3; ++k)
      r.rgba[k] += r.throughput[k] * L;
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
  return aroundAxis(w, ct, u2);
}

/// New direction after a scattering event at p (NEE done or not used).
NV_HD void scatter(const Params& P, Ray& r, V3 p)
{
  const float u1 = rand01(P, r.pixel, r.sample, 2u, r.nEvent++), u2 = rand01(P, r.pixel, r.sample, 2u, r.nEvent++);
  ++r.bounces;
  startSegment(P, r, p, phaseDir(P.anisotropy, r.worldDirection, u1, u2));
}

/// Projection blends (Maximum, Minimum, Average): one sample's value into the accumulated one (NaN, a hole in a
/// reference grid, is not a value).
NV_HD_INLINE void accumulateProjection(const Params& P, Ray& r, float y)
{
  if (!(y == y))
    return;
  if (P.blend == Maximum)
    r.projection = fmaxf_(r.projection, y);
  else if (P.blend == Minimum)
    r.projection = fminf_(r.projection, y);
  else if (P.avgLo >= P.avgHi || (y >= P.avgLo && y <= P.avgHi))
  {
    r.projection += y;
    ++r.count;
  }
}

/// consume() in the March phase: up to K samples of queriesPerStep(P) values each.
NV_HD_INLINE void consumeMarch(const Params& P, Ray& r, int K, const float* v, int n)
{
  const bool skip = marchSkips(P);
  const int qs = queriesPerStep(P);
  const bool projection = P.blend != Composite && P.blend != Additive;
  int j = r.sampleIndex;
  for (int k = 0; k < K; ++k, ++j)
  {
    float t;
    // emit() stopped before K steps only where the segment ends: then so does the ray.
    if (k * qs >= n || !nextSample(P, r.origin, r.direction, r.marchStart, r.segmentEnd, P.dt, skip, j, t))
    {
      r.plain = segmentSamples(r.marchStart, r.segmentEnd, P.dt);
      if (projection || P.blend == Additive)
        finishProjection(P, r);
      r.phase = Done;
      return;
    }
    const float* s = v + k * qs;
    if (projection)
    {
      accumulateProjection(P, r, s[0]);
      continue;
    }
    float e[4];
    lookup(P, s[0], e);
    const float alpha = 1.0f - expNeg(e[3] * P.dt);
    if (!(alpha > 0.0f))
      continue;
    float rgb[3] = { e[0], e[1], e[2] };
    if (P.blend == Additive)
    {
      for (int c = 0; c < 3; ++c)
        r.rgba[c] += alpha * rgb[c];
      r.rgba[3] += alpha;
      continue;
    }
    if (P.shading == RayMarchGradient)
      shadeGradient(P, r, s, rgb);
    if (P.shading == RayMarchShadows)
    {
      for (int c = 0; c < 3; ++c)
        r.pending[c] = rgb[c];
      r.pending[3] = alpha;
      r.sampleIndex = j + 1;
      startShadow(P, r, r.origin + r.direction * t, P.lightW);
      r.phase = Shadow;
      return;
    }
    compositeSample(r, rgb, alpha);
    if (r.rgba[3] >= P.termination)
    {
      r.plain = j + 1;
      r.phase = Done;
      return;
    }
  }
  r.sampleIndex = j;
}

/// consume() in the Shadow phase (ray marching with shadows): the shadow ray's transmittance; at its end the held
/// sample is composited and marching resumes.
NV_HD_INLINE void consumeShadow(const Params& P, Ray& r, int K, const float* v, int n)
{
  int j = r.shadowSampleIndex;
  bool end = false;
  for (int k = 0; k < K; ++k, ++j)
  {
    float t;
    if (k >= n ||
      !nextSample(P, r.shadowOrigin, r.shadowDirection, 0.0f, r.shadowEnd, P.dtShadow, P.skipping != 0, j, t))
    {
      end = true; // the shadow ray left the volume
      break;
    }
    float e[4];
    lookup(P, v[k], e);
    r.shadowTransmittance *= expNeg(e[3] * P.dtShadow);
    if (r.shadowTransmittance < 1e-3f)
    {
      r.shadowTransmittance = 0.0f;
      end = true;
      break;
    }
  }
  r.shadowSampleIndex = j;
  if (!end)
    return;
  // Beyond the clip box: the rest of the shadow ray through the surroundings (none: the light arrives unshadowed).
  r.shadowTransmittance = marchSurroundings(P, r.shadowOrigin, r.shadowDirection, j, r.shadowEnd, P.dtShadow,
    r.shadowTransmittance, 1e-3f);
  float rgb[3];
  const float light = P.intensity * (P.ambient + P.diffuse * r.shadowTransmittance);
  for (int c = 0; c < 3; ++c)
    rgb[c] = r.pending[c] * light;
  compositeSample(r, rgb, r.pending[3]);
  r.phase = March;
  if (r.rgba[3] >= P.termination)
  {
    r.plain = r.sampleIndex;
    r.phase = Done;
  }
}

/// A real collision of a path at p (e: the sample's colour and extinction): the path ends at maxBounces; else its
/// throughput takes the colour and it scatters, with next-event estimation after the sun's shadow ray.
NV_HD_INLINE void collide(const Params& P, Ray& r, V3 p, const float e[4])
{
  r.rgba[3] = 1.0f;
  if (r.bounces >= P.maxBounces)
  {
    r.phase = Done;
    return;
  }
  for (int q = 0; q < 3; ++q)
    r.throughput[q] *= e[q];
  if (P.shading == PathTraceNee)
  {
    const float u1 = rand01(P, r.pixel, r.sample, 4u, r.nEvent++), u2 = rand01(P, r.pixel, r.sample, 4u, r.nEvent++);
    // sunRadiance(w) / density(w) = 4 pi diffuse * intensity: the estimate is the phase function times
    // diffuse * intensity, times the shadow ray's transmittance.
    const V3 w = sunDir(P.lightW, P.sunExponent, u1, u2);
    r.pending[0] = phase4pi(P.anisotropy, dot(r.worldDirection, w)); // phase weight of the sun direction
    startShadow(P, r, clampUnit(p), w);
    r.phase = Nee;
  }
  else
  {
    scatter(P, r, clampUnit(p));
  }
}

/// The rest of a scattered path that left the clip box, traced in the surroundings grid (RaySurroundings.h) to its end
/// within this call: delta tracking from the clip box's exit; at each real collision the throughput takes the colour,
/// NEE's shadow ray is ratio-tracked through the grid, and the path scatters -- until it leaves the grid's box (the
/// sky and sun, as escape() gives them) or reaches maxBounces. Even where it re-enters the clip box it stays in the
/// grid (which covers the piece too): the network is not queried again.
NV_HD_INLINE void traceInSurroundings(const Params& P, Ray& r)
{
  float t = r.segmentEnd;
  for (int guard = 0; guard < kMaxIterations; ++guard)
  {
    float e[4];
    if (!trackSurroundings(P, r, t, e))
    {
      escape(P, r);
      return;
    }
    if (r.bounces >= P.maxBounces)
    {
      r.phase = Done;
      return;
    }
    const V3 p = r.origin + r.direction * t;
    for (int q = 0; q < 3; ++q)
      r.throughput[q] *= e[q];
    if (P.shading == PathTraceNee)
    {
      const float u1 = rand01(P, r.pixel, r.sample, 4u, r.nEvent++), u2 = rand01(P, r.pixel, r.sample, 4u, r.nEvent++);
      const V3 w = sunDir(P.lightW, P.sunExponent, u1, u2);
      const float transmittance = ratioTrackSurroundings(P, r, p, dirToUnit(P, w), 0.0f, r.nFlight, 1.0f);
      const float phaseWeight = phase4pi(P.anisotropy, dot(r.worldDirection, w));
      for (int q = 0; q < 3; ++q)
        r.rgba[q] += r.throughput[q] * P.diffuse * P.intensity * transmittance * phaseWeight;
    }
    const float u1 = rand01(P, r.pixel, r.sample, 2u, r.nEvent++), u2 = rand01(P, r.pixel, r.sample, 2u, r.nEvent++);
    ++r.bounces;
    r.origin = p;
    r.worldDirection = phaseDir(P.anisotropy, r.worldDirection, u1, u2);
    r.direction = dirToUnit(P, r.worldDirection);
    t = 0.0f;
  }
  r.phase = Done;
}

/// consume() in the Track phase (path tracing): delta tracking along the segment until a real collision or the
/// segment's end (the path escapes).
NV_HD_INLINE void consumeTrack(const Params& P, Ray& r, int K, const float* v, int n)
{
  float t = r.distance;
  uint32_t c = r.nFlight;
  for (int k = 0; k < K; ++k)
  {
    // nextFlight first: where emit() found the segment's end it drew random numbers past the last collision,
    // and the replay must draw them too (the stream continues after this segment).
    if (!nextFlight(P, r, r.origin, r.direction, r.segmentEnd, t, c) || k >= n)
    {
      // emit() stopped before K tentative collisions only where the segment ends: the path escapes the clip box,
      // into the surroundings after a scattering event (a primary ray leaves the rest to the other pieces).
      r.distance = r.segmentEnd;
      r.nFlight = c;
      if (r.bounces > 0 && surroundsAnything(P))
        traceInSurroundings(P, r);
      else
        escape(P, r);
      return;
    }
    const V3 p = r.origin + r.direction * t;
    const float mj = localMajorant(P, clampUnit(p));
    float e[4];
    lookup(P, v[k], e);
    const float xi = rand01(P, r.pixel, r.sample, 3u, r.nEvent++);
    if (xi * mj < e[3]) // real collision
    {
      r.distance = t;
      r.nFlight = c;
      collide(P, r, p, e);
      return;
    }
  }
  r.distance = t;
  r.nFlight = c;
}

/// consume() in the Nee phase: ratio tracking of the sun's shadow ray; at its end the sun's contribution is added
/// and the path scatters.
NV_HD_INLINE void consumeNee(const Params& P, Ray& r, int K, const float* v, int n)
{
  float t = r.distance;
  uint32_t c = r.nFlight;
  bool end = false;
  for (int k = 0; k < K; ++k)
  {
    // nextFlight first, as in Track: the path's flights continue this stream after the shadow ray, so the
    // number that overshot the shadow ray's end must be consumed here (else the next flight reuses it and is
    // biased long).
    if (!nextFlight(P, r, r.shadowOrigin, r.shadowDirection, r.shadowEnd, t, c) || k >= n)
    {
      end = true; // the shadow ray left the volume
      break;
    }
    const V3 p = r.shadowOrigin + r.shadowDirection * t;
    const float mj = localMajorant(P, clampUnit(p));
    float e[4];
    lookup(P, v[k], e);
    // mj is > 0 where nextFlight stopped; a point rounded into a neighbouring empty cell must not give 0/0.
    const float ratio = mj > 0.0f ? e[3] / mj : (e[3] > 0.0f ? 1.0f : 0.0f);
    r.shadowTransmittance *= fmaxf_(0.0f, 1.0f - ratio);
    if (r.shadowTransmittance < 1e-4f)
    {
      r.shadowTransmittance = 0.0f;
      end = true;
      break;
    }
  }
  r.distance = t;
  r.nFlight = c;
  if (!end)
    return;
  // Beyond the clip box: the rest of the shadow ray through the surroundings.
  r.shadowTransmittance =
    ratioTrackSurroundings(P, r, r.shadowOrigin, r.shadowDirection, r.shadowEnd, r.nFlight, r.shadowTransmittance);
  for (int q = 0; q < 3; ++q)
    r.rgba[q] += r.throughput[q] * P.diffuse * P.intensity * r.shadowTransmittance * r.pending[0];
  scatter(P, r, r.shadowOrigin);
  r.phase = Track;
}

/// Consume the n values of the queries emit(P, r, K, q) produced (same K), in order.
NV_HD void consume(const Params& P, Ray& r, int K, const float* v, int n)
{
  switch (r.phase)
  {
    case March:
      consumeMarch(P, r, K, v, n);
      return;
    case Shadow:
      consumeShadow(P, r, K, v, n);
      return;
    case Track:
      consumeTrack(P, r, K, v, n);
      return;
    case Nee:
      consumeNee(P, r, K, v, n);
      return;
    default:
      return;
  }
}

/// The pixel's premultiplied colour and opacity once the ray is done.
NV_HD void result(const Ray& r, float out[4])
{
  for (int k = 0; k < 4; ++k)
    out[k] = r.rgba[k];
}

} // namespace ray
} // namespace nv
