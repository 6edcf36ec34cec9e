#include "RenderSetup.h"

#include "Error.h"
#include "Surroundings.h"
#include "ValueRange.h"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <sstream>
#include <string>

namespace nv
{

const char* renderPathName(RenderPath p)
{
  switch (p)
  {
    case RenderPath::Decode:
      return "Decode";
    case RenderPath::SampleStreaming:
      return "Sample Streaming";
    case RenderPath::InShader:
      return "In-Shader";
  }
  return "unknown";
}

const char* shadingModeName(ShadingMode m)
{
  switch (m)
  {
    case ShadingMode::RayMarch:
      return "Ray Marching";
    case ShadingMode::RayMarchGradient:
      return "Ray Marching + Gradient Shading";
    case ShadingMode::RayMarchShadows:
      return "Ray Marching + Shadows";
    case ShadingMode::PathTrace:
      return "Path Tracing";
    case ShadingMode::PathTraceNee:
      return "Path Tracing + NEE";
  }
  return "unknown";
}

const char* blendModeName(BlendMode b)
{
  switch (b)
  {
    case BlendMode::Composite:
      return "Composite";
    case BlendMode::Maximum:
      return "Maximum Intensity";
    case BlendMode::Minimum:
      return "Minimum Intensity";
    case BlendMode::Average:
      return "Average Intensity";
    case BlendMode::Additive:
      return "Additive";
  }
  return "unknown";
}

namespace
{
bool finite(const double* v, int n)
{
  for (int i = 0; i < n; ++i)
    if (!std::isfinite(v[i]))
      return false;
  return true;
}

/// Inverse of a row-major 4x4 matrix (Gauss-Jordan with partial pivoting); false when singular.
bool invert4(const double* m, double* out)
{
  double a[4][8];
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 8; ++c)
      a[r][c] = c < 4 ? m[4 * r + c] : (c - 4 == r ? 1.0 : 0.0);
  double scale = 0.0;
  for (int i = 0; i < 16; ++i)
    scale = std::max(scale, std::fabs(m[i]));
  if (!(scale > 0.0))
    return false;
  for (int c = 0; c < 4; ++c)
  {
    int p = c;
    for (int r = c + 1; r < 4; ++r)
      if (std::fabs(a[r][c]) > std::fabs(a[p][c]))
        p = r;
    if (std::fabs(a[p][c]) <= 1e-14 * scale)
      return false;
    if (p != c)
      for (int k = 0; k < 8; ++k)
        std::swap(a[p][k], a[c][k]);
    const double inv = 1.0 / a[c][c];
    for (int k = 0; k < 8; ++k)
      a[c][k] *= inv;
    for (int r = 0; r < 4; ++r)
    {
      if (r == c)
        continue;
      const double f = a[r][c];
      for (int k = 0; k < 8; ++k)
        a[r][k] -= f * a[c][k];
    }
  }
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
      out[4 * r + c] = a[r][c + 4];
  return finite(out, 16);
}

/// Inverse of the 3x3 linear part of a row-major affine 4x4 (columns: world extent of a network unit per axis).
bool invert3(const double* m, double b[9])
{
  const double a[9] = { m[0], m[1], m[2], m[4], m[5], m[6], m[8], m[9], m[10] };
  const double det = a[0] * (a[4] * a[8] - a[5] * a[7]) - a[1] * (a[3] * a[8] - a[5] * a[6]) +
    a[2] * (a[3] * a[7] - a[4] * a[6]);
  if (!(std::fabs(det) > 0.0) || !std::isfinite(det))
    return false;
  const double id = 1.0 / det;
  b[0] = (a[4] * a[8] - a[5] * a[7]) * id;
  b[1] = (a[2] * a[7] - a[1] * a[8]) * id;
  b[2] = (a[1] * a[5] - a[2] * a[4]) * id;
  b[3] = (a[5] * a[6] - a[3] * a[8]) * id;
  b[4] = (a[0] * a[8] - a[2] * a[6]) * id;
  b[5] = (a[2] * a[3] - a[0] * a[5]) * id;
  b[6] = (a[3] * a[7] - a[4] * a[6]) * id;
  b[7] = (a[1] * a[6] - a[0] * a[7]) * id;
  b[8] = (a[0] * a[4] - a[1] * a[3]) * id;
  return finite(b, 9);
}

/// 64-bit FNV-style hash, eight bytes per step (four chains for long arrays) (a depth buffer of a 1080p view is 8 MB, hashed every frame).
struct Hasher
{
  uint64_t hash = 1469598103934665603ull;
  void add(const void* p, size_t n)
  {
    const unsigned char* b = static_cast<const unsigned char*>(p);
    size_t i = 0;
    if (n >= 64)
    {
      // Four independent chains (the multiplies overlap), combined at the end.
      uint64_t c[4] = { hash, hash ^ 0x9E3779B97F4A7C15ull, hash ^ 0xBF58476D1CE4E5B9ull,
        hash ^ 0x94D049BB133111EBull };
      for (; i + 32 <= n; i += 32)
        for (int k = 0; k < 4; ++k)
        {
          uint64_t w;
          std::memcpy(&w, b + i + 8 * k, 8);
          c[k] = (c[k] ^ w) * 1099511628211ull;
        }
      hash = mix64(c[0] ^ mix64(c[1] ^ mix64(c[2] ^ mix64(c[3]))));
    }
    for (; i + 8 <= n; i += 8)
    {
      uint64_t w;
      std::memcpy(&w, b + i, 8);
      hash = (hash ^ w) * 1099511628211ull;
    }
    for (; i < n; ++i)
      hash = (hash ^ b[i]) * 1099511628211ull;
    hash ^= hash >> 29; // fold the high bits down so the last words reach every bit
  }
  template <typename T>
  void add(const T& v)
  {
    add(&v, sizeof(T));
  }
};
} // namespace

void validate(const RenderRequest& q)
{
  std::ostringstream os;
  if (q.width < 1 || q.height < 1 || q.width > kMaxImageSize || q.height > kMaxImageSize)
    os << "image size " << q.width << " x " << q.height << " outside 1.." << kMaxImageSize << "; ";
  if (!finite(q.viewProjection, 16))
    os << "the view-projection matrix is not finite; ";
  if (!finite(q.worldToUnit, 16))
    os << "the volume transform is not finite; ";
  const TransferFunction& tf = q.transfer;
  if (tf.rgba.size() < 8 || tf.rgba.size() % 4 != 0)
    os << "the transfer function needs at least 2 entries of 4 values (has " << tf.rgba.size() << " values); ";
  for (float v : tf.rgba)
    if (!std::isfinite(v))
    {
      os << "the transfer function has non-finite values; ";
      break;
    }
  if (!std::isfinite(tf.valueMin) || !std::isfinite(tf.valueMax))
    os << "the transfer function's value range is not finite; ";
  if (!(tf.unitDistance > 0.0) || !std::isfinite(tf.unitDistance))
    os << "the opacity unit distance must be > 0 (is " << tf.unitDistance << "); ";
  if (!(q.sampleDistance >= 0.0) || !std::isfinite(q.sampleDistance))
    os << "the sample distance must be >= 0 (is " << q.sampleDistance << "); ";
  const int path = static_cast<int>(q.path), mode = static_cast<int>(q.shading), blend = static_cast<int>(q.blend);
  if (path < 0 || path > 2)
    os << "unknown render path " << path << "; ";
  if (mode < 0 || mode > 4)
    os << "unknown shading mode " << mode << "; ";
  if (blend < 0 || blend > 4)
    os << "unknown blend mode " << blend << "; ";
  if (q.maxBounces < 0 || q.maxBounces > 1024)
    os << "max bounces must be in 0..1024 (is " << q.maxBounces << "); ";
  if (q.samplesPerPixel < 1 || q.samplesPerPixel > 4096)
    os << "samples per pixel must be in 1..4096 (is " << q.samplesPerPixel << "); ";
  if (q.streamingSamples < 0 || q.streamingSamples > 1024)
    os << "streaming samples (K) must be in 0..1024 (is " << q.streamingSamples << "); ";
  for (int a = 0; a < 3; ++a)
    if (q.decodeResolution[a] < 0 || q.decodeResolution[a] > 8192)
    {
      os << "decode resolution must be in 0..8192 per axis; ";
      break;
    }
  if (!finite(q.lightDirection, 3) || !std::isfinite(q.lightIntensity) || !std::isfinite(q.ambient) ||
    !std::isfinite(q.diffuse) || !std::isfinite(q.specular) || !std::isfinite(q.specularPower) ||
    !std::isfinite(q.sunAngle) || !std::isfinite(q.terminationOpacity) || !std::isfinite(q.anisotropy))
    os << "lighting parameters must be finite; ";
  if (!(q.liveRefreshMilliseconds >= 0.0) || !std::isfinite(q.liveRefreshMilliseconds))
    os << "the live refresh interval must be >= 0 ms (is " << q.liveRefreshMilliseconds << "); ";
  if (q.grid && (!q.grid->data || q.grid->count() < 1))
    os << "the reference grid is empty; ";
  for (int a = 0; a < 3; ++a)
    if (!finite(q.clipBox + 2 * a, 2) || !(q.clipBox[2 * a] < q.clipBox[2 * a + 1]) || q.clipBox[2 * a + 1] <= 0.0 ||
      q.clipBox[2 * a] >= 1.0)
    {
      os << "the clip box must be a non-empty box that overlaps [0,1]^3; ";
      break;
    }
  checkSurroundings(q, os);
  double inv[16];
  if (finite(q.viewProjection, 16) && !invert4(q.viewProjection, inv))
    os << "the view-projection matrix is singular; ";
  double b[9];
  if (finite(q.worldToUnit, 16) && !invert3(q.worldToUnit, b))
    os << "the volume transform is singular (a zero-thickness volume?); ";
  const std::string e = os.str();
  if (!e.empty())
    NV_THROW("invalid render request: " + e.substr(0, e.size() - 2));
}

uint64_t renderKey(const RenderRequest& q)
{
  const TransferFunction& tf = q.transfer;
  Hasher h;
  h.add(q.width);
  h.add(q.height);
  h.add(q.viewProjection, sizeof(q.viewProjection));
  h.add(q.worldToUnit, sizeof(q.worldToUnit));
  h.add(q.clipBox, sizeof(q.clipBox));
  h.add(tf.rgba.data(), tf.rgba.size() * sizeof(float));
  h.add(tf.valueMin);
  h.add(tf.valueMax);
  h.add(tf.unitDistance);
  h.add(q.path);
  h.add(q.shading);
  h.add(q.blend);
  h.add(q.sampleDistance);
  h.add(q.averageRange, sizeof(q.averageRange));
  h.add(q.lightDirection, sizeof(q.lightDirection));
  h.add(q.lightIntensity);
  h.add(q.ambient);
  h.add(q.diffuse);
  h.add(q.specular);
  h.add(q.specularPower);
  h.add(q.sunAngle);
  h.add(q.anisotropy);
  h.add(q.maxBounces);
  // (Not samplesPerPixel: an accumulation continues with any number of paths per render.)
  h.add(q.streamingSamples);
  h.add(q.emptySpaceSkipping);
  h.add(q.terminationOpacity);
  h.add(q.decodeResolution, sizeof(q.decodeResolution));
  h.add(q.seed);
  if (q.depth)
    h.add(q.depth, sizeof(float) * static_cast<size_t>(q.width) * static_cast<size_t>(q.height));
  if (q.grid)
  {
    h.add(q.grid->data);
    h.add(q.grid->dims, sizeof(q.grid->dims));
  }
  if (usesSurroundings(q))
  {
    // Its values themselves (a grid given again with other values renders again and restarts an accumulation).
    const SurroundingsGrid& g = *q.surroundings;
    h.add(g.values.data(), g.values.size() * sizeof(float));
    h.add(g.dims, sizeof(g.dims));
    h.add(g.box, sizeof(g.box));
  }
  return h.hash;
}

void transferMap(const TransferFunction& tf, double valueMin, double valueMax, float& scale, float& shift)
{
  const int n = static_cast<int>(tf.rgba.size() / 4);
  double lo = tf.valueMin, hi = tf.valueMax;
  if (!(hi > lo))
  {
    const double pad = std::max(std::fabs(lo) * 1e-6, 1e-30);
    hi = lo + pad;
    if (!(hi <= DBL_MAX)) // a constant at the top of the doubles: widen downwards
    {
      hi = lo;
      lo -= pad;
    }
  }
  const ValueRange tfRange(lo, hi), values(valueMin, valueMax);
  if (!tfRange.halved() && !values.halved())
  {
    const double vr = values.width();
    // entry coordinate of value v: (v - lo) / (hi - lo) * (n - 1); v = valueMin + y * vr.
    const double k = static_cast<double>(n - 1) / (hi - lo);
    scale = static_cast<float>(vr * k);
    shift = static_cast<float>((valueMin - lo) * k);
  }
  else
  {
    // A range wider than the largest double (ValueRange.h): the same map on halves, (v/2 - lo/2) / (hi/2 - lo/2).
    const double k = static_cast<double>(n - 1) / (0.5 * hi - 0.5 * lo);
    scale = static_cast<float>((0.5 * valueMax - 0.5 * valueMin) * k);
    shift = static_cast<float>((0.5 * valueMin - 0.5 * lo) * k);
  }
}

namespace
{
// makeRenderSetup's steps, in its order (every check throws in the order it always did).

/// The camera (clip to world) and the volume transform (world to unit box, 3 x 4).
void setCamera(const RenderRequest& q, ray::Params& P)
{
  P.width = q.width;
  P.height = q.height;
  double inv[16];
  invert4(q.viewProjection, inv);
  for (int i = 0; i < 16; ++i)
    P.clipToWorld[i] = static_cast<float>(inv[i]);
  for (int i = 0; i < 12; ++i)
    P.worldToUnit[i] = static_cast<float>(q.worldToUnit[i]);
  for (int a = 0; a < 3; ++a)
  {
    // The clip box within [0,1]^3 (validate() checked it).
    P.box[2 * a] = static_cast<float>(std::max(0.0, q.clipBox[2 * a]));
    P.box[2 * a + 1] = static_cast<float>(std::min(1.0, q.clipBox[2 * a + 1]));
  }
}

/// The sample distance (one sample per voxel by default), the gradient's half-step, the bounds on a ray's work and
/// the termination opacity.
void setSampleDistances(const RenderRequest& q, const SourceInfo& src, ray::Params& P)
{
  // One sample per voxel by default: the world length of a voxel step along the finest axis.
  double b[9];
  invert3(q.worldToUnit, b);
  double voxel = 0.0;
  for (int a = 0; a < 3; ++a)
  {
    const double len = std::sqrt(b[a] * b[a] + b[3 + a] * b[3 + a] + b[6 + a] * b[6 + a]);
    const double v = src.dims[a] > 1 ? len / static_cast<double>(src.dims[a] - 1) : len;
    voxel = voxel > 0.0 ? std::min(voxel, v) : v;
    P.gradH[a] = src.dims[a] > 1 ? static_cast<float>(0.5 / static_cast<double>(src.dims[a] - 1)) : 0.5f;
  }
  const double dt = q.sampleDistance > 0.0 ? q.sampleDistance : voxel;
  NV_CHECK(dt > 0.0 && std::isfinite(dt), "cannot derive a sample distance from the volume transform");
  // Bound the work of one ray: samples across the volume (marching) and mean free paths at the densest opacity
  // (tracking), both measured along the sum of the box's edge lengths.
  double edges = 0.0;
  for (int a = 0; a < 3; ++a)
    edges += std::sqrt(b[a] * b[a] + b[3 + a] * b[3 + a] + b[6 + a] * b[6 + a]);
  // Secondary rays also cross the surroundings (RaySurroundings.h): their box counts as well.
  if (usesSurroundings(q))
    edges = std::max(edges, surroundingsEdgeLength(*q.surroundings, b));
  // (Counts as text with %.3g: a count beyond the integers, 1e31 say, must not be converted to one.)
  auto count = [](double value) {
    char text[32];
    std::snprintf(text, sizeof(text), "%.3g", value);
    return std::string(text);
  };
  if (edges / dt > kMaxStepsPerRay)
    NV_THROW("invalid render request: sample distance " + std::to_string(dt) + " gives " + count(edges / dt) +
      " samples across the volume (at most " + count(kMaxStepsPerRay) + ")");
  if (edges / q.transfer.unitDistance > kMaxStepsPerRay)
    NV_THROW("invalid render request: opacity unit distance " + std::to_string(q.transfer.unitDistance) +
      " is too small for the volume (" + count(edges / q.transfer.unitDistance) + " units across it, at most " +
      count(kMaxStepsPerRay) + ")");
  P.dt = static_cast<float>(dt);
  P.dtShadow = static_cast<float>(2.0 * dt);
  // >= 1 is off: a ray's opacity can reach exactly 1.0f, so "off" must be out of reach.
  P.termination = q.terminationOpacity >= 1.0 ? 2.0f : static_cast<float>(q.terminationOpacity);
}

/// The transfer function: its table (opacity per unit distance -> extinction per world unit) and the map from the
/// network's normalised values to table entries (tfScale, tfShift).
void setTransferFunction(const RenderRequest& q, const SourceInfo& src, RenderSetup& s)
{
  ray::Params& P = s.params;
  const TransferFunction& tf = q.transfer;
  const int n = static_cast<int>(tf.rgba.size() / 4);
  s.table.resize(tf.rgba.size());
  const double ud = tf.unitDistance;
  for (int i = 0; i < n; ++i)
  {
    for (int c = 0; c < 3; ++c)
      s.table[4 * i + c] = std::min(1.0f, std::max(0.0f, tf.rgba[4 * i + c]));
    const double a = std::min(0.99999, std::max(0.0, static_cast<double>(tf.rgba[4 * i + 3])));
    s.table[4 * i + 3] = static_cast<float>(-std::log1p(-a) / ud);
  }
  P.tfSize = n;
  transferMap(tf, src.valueMin, src.valueMax, P.tfScale, P.tfShift);
  NV_CHECK(std::isfinite(P.tfScale) && std::isfinite(P.tfShift),
    "the transfer function's range is too small for the field's value range");
  P.unitDistance = static_cast<float>(ud);
}

/// The macrocell layout, skipping, shading and blend modes and the Average Intensity range.
void setCellsAndModes(const RenderRequest& q, const SourceInfo& src, RenderSetup& s)
{
  ray::Params& P = s.params;
  s.cells = macrocellLayout(src.dims);
  for (int a = 0; a < 3; ++a)
  {
    P.mc[a] = s.cells.dims[a];
    P.mcScale[a] = s.cells.scale[a];
  }
  P.skipping = q.emptySpaceSkipping ? 1 : 0;
  P.shading = static_cast<int>(q.shading);
  P.blend = static_cast<int>(q.blend);
  const ValueRange source(src.valueMin, src.valueMax);
  if (q.averageRange[1] > q.averageRange[0] && source.spans())
  {
    P.avgLo = static_cast<float>(source.fraction(q.averageRange[0]));
    P.avgHi = static_cast<float>(source.fraction(q.averageRange[1]));
  }
  else
  {
    P.avgLo = 1.0f;
    P.avgHi = 0.0f;
  }
}

/// The light, the Phong terms, the sun's lobe, the phase function, bounces and the random streams' seed.
void setLighting(const RenderRequest& q, ray::Params& P)
{
  ray::V3 l = ray::mk(static_cast<float>(q.lightDirection[0]), static_cast<float>(q.lightDirection[1]),
    static_cast<float>(q.lightDirection[2]));
  P.lightW = ray::dot(l, l) > 0.0f ? ray::normalize(l) : ray::mk(0.0f, 0.0f, 1.0f);
  P.ambient = static_cast<float>(q.ambient);
  P.diffuse = static_cast<float>(q.diffuse);
  P.specular = static_cast<float>(q.specular);
  P.specularPower = static_cast<float>(q.specularPower);
  P.intensity = static_cast<float>(q.lightIntensity);
  // The sun's lobe max(0, cos)^n falls to half its peak at sunAngle: n = log(1/2) / log(cos(sunAngle)) (0 at 90
  // degrees: the whole lit hemisphere evenly).
  const double sun = std::min(90.0, std::max(0.1, q.sunAngle)) * 3.14159265358979 / 180.0;
  const double sunCos = std::cos(sun);
  P.sunExponent = sunCos > 1e-9 ? static_cast<float>(std::log(0.5) / std::log(sunCos)) : 0.0f;
  P.anisotropy = static_cast<float>(std::min(0.99, std::max(-0.99, q.anisotropy)));
  P.maxBounces = q.maxBounces;
  P.seed = static_cast<uint32_t>(q.seed ^ (q.seed >> 32));
  P.frame = 0;
}

/// The source's domain mask and a sparse source's occupancy (host memory here; the GPU renderer points them at its
/// device copies) and its background value.
void setDomain(const SourceInfo& src, ray::Params& P)
{
  const int64_t domainSamples = src.dims[0] * src.dims[1] * src.dims[2];
  const bool domain = !src.domain.empty() && int64_t(src.domain.size()) == (domainSamples + 31) / 32;
  P.domain = domain ? src.domain.data() : nullptr;
  for (int a = 0; a < 3; ++a)
    P.domainDims[a] = static_cast<int>(src.dims[a]);
  const bool occupancy = !src.occupancy.empty() && int64_t(src.occupancy.size()) == occupancyWords(src.dims);
  P.occupancy = occupancy ? src.occupancy.data() : nullptr;
  const ValueRange source(src.valueMin, src.valueMax);
  P.background = static_cast<float>(source.fraction(src.background));
}

/// The Decode path's grid size and Sample Streaming's K.
void setPathSizes(const RenderRequest& q, const SourceInfo& src, RenderSetup& s)
{
  for (int a = 0; a < 3; ++a)
    s.gridDims[a] = q.decodeResolution[a] > 0 ? q.decodeResolution[a] : std::max<int64_t>(1, src.dims[a]);
  if (q.decodeResolution[0] <= 0 || q.decodeResolution[1] <= 0 || q.decodeResolution[2] <= 0)
    for (int a = 0; a < 3; ++a)
      s.gridDims[a] = std::max<int64_t>(1, src.dims[a]);
  if (q.grid)
    for (int a = 0; a < 3; ++a)
      s.gridDims[a] = q.grid->dims[a];
  s.streamingSamples = q.streamingSamples > 0 ? q.streamingSamples : kDefaultStreamingSamples;
}
} // namespace

RenderSetup makeRenderSetup(const RenderRequest& q, const SourceInfo& src)
{
  validate(q);
  RenderSetup s;
  ray::Params& P = s.params;
  setCamera(q, P);
  setSampleDistances(q, src, P);
  setTransferFunction(q, src, s);
  setCellsAndModes(q, src, s);
  setLighting(q, P);
  setDomain(src, P);
  setPathSizes(q, src, s);

  s.key = renderKey(q);
  Hasher t;
  t.add(s.table.data(), s.table.size() * sizeof(float));
  t.add(P.tfScale);
  t.add(P.tfShift);
  s.tableKey = t.hash;
  return s;
}

} // namespace nv
