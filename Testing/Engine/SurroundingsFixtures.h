// Shared pieces of the surroundings tests (engine.Surroundings, gpu.Render): the blob on a grid split into two pieces
// along x as MPI ranks hold it -- each piece's own sub-grid with ghost layers is its "network" (the Decode path's
// explicit grid), mapped to [0,1]^3, its own part the clip box -- a coarse grid of the whole placed in each piece's
// coordinates (RenderRequest::surroundings), the composite of the pieces' pictures in visibility order, and the band
// of pixels along the split.
#pragma once

#include "RenderFixtures.h"

#include <cstdint>
#include <memory>
#include <vector>

namespace nvtest
{

/// The blob on n^3 samples over the world box [-1,1]^3 (n odd: the split plane x = 0 is a sample plane).
constexpr int kSplitGrid = 49;
/// Ghost layers of each piece beyond its own samples (as vtkNeuralCompressPartition's).
constexpr int kSplitGhosts = 3;

/// World x of sample index i of the n-sample axis.
inline double sampleX(int i, int n)
{
  return -1.0 + 2.0 * i / (n - 1);
}

/// One piece of the split blob: samples [first, last] along x (its own and its ghost layers), its model (the source
/// range of its own samples, as a rank's network has), the world-to-unit map of its padded box and its clip box.
struct SplitPiece
{
  std::vector<float> data;
  nv::VolumeView view;
  nv::Model model{ smallRenderConfig() };
  double worldToUnit[16] = {};
  double clip[6] = { 0, 1, 0, 1, 0, 1 };
  double wholeInUnit[6] = { 0, 1, 0, 1, 0, 1 }; ///< the world box [-1,1]^3 in this piece's coordinates
};

/// Samples [first, last] along x of the n^3 blob; owned samples [ownFirst, ownLast] are the clip box.
inline SplitPiece makeSplitPiece(const std::vector<float>& whole, int n, int first, int last, int ownFirst,
  int ownLast)
{
  SplitPiece p;
  const int nx = last - first + 1;
  p.data.resize(size_t(nx) * n * n);
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < nx; ++x)
        p.data[(size_t(z) * n + y) * nx + x] = whole[(size_t(z) * n + y) * n + x + first];
  p.view = viewOf(p.data, nx, n, n);
  p.model.initialize(1);
  p.model.source.dims[0] = nx;
  p.model.source.dims[1] = p.model.source.dims[2] = n;
  p.model.source.valueMin = p.view.valueMin;
  p.model.source.valueMax = p.view.valueMax;
  // u_x = (x - x0) / (x1 - x0) over the padded piece; y, z as unitBox.
  const double x0 = sampleX(first, n), x1 = sampleX(last, n), w = x1 - x0;
  unitBox(p.worldToUnit);
  p.worldToUnit[0] = 1.0 / w;
  p.worldToUnit[3] = -x0 / w;
  p.clip[0] = (sampleX(ownFirst, n) - x0) / w;
  p.clip[1] = (sampleX(ownLast, n) - x0) / w;
  p.wholeInUnit[0] = (-1.0 - x0) / w;
  p.wholeInUnit[1] = (1.0 - x0) / w;
  return p;
}

/// The whole grid as one "piece" (the serial picture) and the two halves x <= 0 and x >= 0 with ghost layers.
struct SplitScene
{
  SplitScene()
    : data(blobVolume(kSplitGrid))
  {
    const int n = kSplitGrid, mid = (n - 1) / 2;
    whole = makeSplitPiece(data, n, 0, n - 1, 0, n - 1);
    low = makeSplitPiece(data, n, 0, mid + kSplitGhosts, 0, mid);
    high = makeSplitPiece(data, n, mid - kSplitGhosts, n - 1, mid, n - 1);
  }
  std::vector<float> data;
  SplitPiece whole, low, high;
};

/// A coarse grid of the whole blob (m^3 samples of the field itself over the world box [-1,1]^3), placed at
/// `boxInUnit` (the world box in the network coordinates of the piece that renders with it).
inline std::shared_ptr<const nv::SurroundingsGrid> coarseSurroundings(const double boxInUnit[6], int m)
{
  auto g = std::make_shared<nv::SurroundingsGrid>();
  g->values.resize(size_t(m) * m * m);
  for (int z = 0; z < m; ++z)
    for (int y = 0; y < m; ++y)
      for (int x = 0; x < m; ++x)
        g->values[(size_t(z) * m + y) * m + x] =
          float(blobField(2.0 * x / (m - 1) - 1, 2.0 * y / (m - 1) - 1, 2.0 * z / (m - 1) - 1));
  for (int a = 0; a < 3; ++a)
  {
    g->dims[a] = m;
    g->box[2 * a] = boxInUnit[2 * a];
    g->box[2 * a + 1] = boxInUnit[2 * a + 1];
  }
  return g;
}

/// The coarse grid of the whole blob placed in `piece`'s coordinates.
inline std::shared_ptr<const nv::SurroundingsGrid> coarseSurroundings(const SplitPiece& piece, int m)
{
  return coarseSurroundings(piece.wholeInUnit, m);
}

/// A near-frontal view along -z, slightly from +x: the split plane x = 0 is a narrow band of the picture and the
/// piece x >= 0 is in front of the other for every pixel.
inline Mat4 splitCamera(int w, int h)
{
  const double eye[3] = { 0.45, 0.6, 4.5 }, c[3] = { 0, 0, 0 }, up[3] = { 0, 1, 0 };
  return mul(perspective(36.0, double(w) / h, 0.5, 20.0), lookAt(eye, c, up));
}

/// The request of `piece` (its grid through the Decode path, clipped to its own part): the whole blob's transfer
/// function and a light from -x (the half x < 0 shadows the half in front of it), a fixed sample distance.
inline nv::RenderRequest splitRequest(const SplitScene& scene, const SplitPiece& piece, nv::ShadingMode mode, int w,
  int h, int spp)
{
  nv::RenderRequest q = gridPathTracingRequest(piece.model, piece.view, mode, w, h);
  setCamera(q, splitCamera(w, h));
  std::copy(piece.worldToUnit, piece.worldToUnit + 16, q.worldToUnit);
  std::copy(piece.clip, piece.clip + 6, q.clipBox);
  q.transfer = blobTransfer(scene.whole.model.source.valueMin, scene.whole.model.source.valueMax);
  q.lightDirection[0] = -0.8;
  q.lightDirection[1] = 0.45;
  q.lightDirection[2] = 0.4;
  q.sampleDistance = 2.0 / (kSplitGrid - 1);
  q.samplesPerPixel = spp;
  q.seed = 7;
  return q;
}

/// Premultiplied "over": the front picture, then what it lets through of the back one.
inline std::vector<float> compositeOver(const std::vector<float>& front, const std::vector<float>& back)
{
  std::vector<float> out(front.size());
  for (size_t k = 0; k + 3 < front.size(); k += 4)
    for (int c = 0; c < 4; ++c)
      out[k + c] = front[k + c] + (1.0f - front[k + 3]) * back[k + c];
  return out;
}

/// Pixels within `dilate` pixels of the split plane x = 0 as the camera sees it inside the box (row 0 at the bottom).
inline std::vector<uint8_t> splitBand(const Mat4& vp, int w, int h, int dilate)
{
  std::vector<uint8_t> band(size_t(w) * h, 0);
  const int steps = 200;
  for (int i = 0; i <= steps; ++i)
    for (int j = 0; j <= steps; ++j)
    {
      const double p[3] = { 0.0, -1.0 + 2.0 * i / steps, -1.0 + 2.0 * j / steps };
      const double* m = vp.m;
      const double cx = m[0] * p[0] + m[1] * p[1] + m[2] * p[2] + m[3];
      const double cy = m[4] * p[0] + m[5] * p[1] + m[6] * p[2] + m[7];
      const double cw = m[12] * p[0] + m[13] * p[1] + m[14] * p[2] + m[15];
      const int px = int(std::floor((cx / cw * 0.5 + 0.5) * w)), py = int(std::floor((cy / cw * 0.5 + 0.5) * h));
      for (int y = py - dilate; y <= py + dilate; ++y)
        for (int x = px - dilate; x <= px + dilate; ++x)
          if (x >= 0 && x < w && y >= 0 && y < h)
            band[size_t(y) * w + x] = 1;
    }
  return band;
}

/// Mean absolute error per channel (colour and alpha, clamped to [0,1]) of the pixels in the band and of the others
/// where either picture draws something (alpha > 0.01); NaN for an empty set.
inline void bandErrors(const std::vector<float>& a, const std::vector<float>& b, const std::vector<uint8_t>& band,
  double& inBand, double& rest)
{
  double sum[2] = { 0, 0 }, count[2] = { 0, 0 };
  for (size_t i = 0; i < band.size(); ++i)
  {
    if (!(a[4 * i + 3] > 0.01f || b[4 * i + 3] > 0.01f))
      continue;
    double e = 0.0;
    for (int c = 0; c < 4; ++c)
      e += std::fabs(std::min(1.0f, std::max(0.0f, a[4 * i + c])) - std::min(1.0f, std::max(0.0f, b[4 * i + c])));
    sum[band[i]] += e / 4.0;
    count[band[i]] += 1.0;
  }
  inBand = count[1] > 0 ? sum[1] / count[1] : std::nan("");
  rest = count[0] > 0 ? sum[0] / count[0] : std::nan("");
}

} // namespace nvtest
