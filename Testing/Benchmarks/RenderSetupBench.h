// Camera, volume placement and transfer function of the render benchmarks, reproducing the rendering anchor
// (../shared/reference/rm_anchor.cu): world = voxel coordinates, a perspective camera with tan(fov_y / 2) = 0.5
// orbiting the volume's centre at 1.6 x its largest dimension and 0.3 of that above, one sample per voxel, and the
// CT-like transfer function (transparent below 0.25 of the value range, then extinction (s - 0.25) * 0.3 per voxel).
#pragma once

#include "Core/Render.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace nvbench
{

struct Vec
{
  double x, y, z;
};
inline Vec sub(Vec a, Vec b)
{
  return { a.x - b.x, a.y - b.y, a.z - b.z };
}
inline Vec crossv(Vec a, Vec b)
{
  return { a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x };
}
inline Vec unit(Vec a)
{
  const double l = std::sqrt(a.x * a.x + a.y * a.y + a.z * a.z);
  return { a.x / l, a.y / l, a.z / l };
}

/// out = a * b (row-major 4x4).
inline void mul4(const double* a, const double* b, double* out)
{
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
    {
      double s = 0.0;
      for (int k = 0; k < 4; ++k)
        s += a[4 * r + k] * b[4 * k + c];
      out[4 * r + c] = s;
    }
}

/// OpenGL-style world -> clip of a camera at eye looking at `at` (row-major).
inline void viewProjection(Vec eye, Vec at, Vec up, double fovyDeg, double aspect, double zNear, double zFar,
  double* out)
{
  const Vec f = unit(sub(at, eye));
  const Vec s = unit(crossv(f, up));
  const Vec u = crossv(s, f);
  const double view[16] = { s.x, s.y, s.z, -(s.x * eye.x + s.y * eye.y + s.z * eye.z), u.x, u.y, u.z,
    -(u.x * eye.x + u.y * eye.y + u.z * eye.z), -f.x, -f.y, -f.z, f.x * eye.x + f.y * eye.y + f.z * eye.z, 0, 0, 0,
    1 };
  const double t = 1.0 / std::tan(fovyDeg * 3.14159265358979 / 360.0);
  const double proj[16] = { t / aspect, 0, 0, 0, 0, t, 0, 0, 0, 0, (zFar + zNear) / (zNear - zFar),
    2 * zFar * zNear / (zNear - zFar), 0, 0, -1, 0 };
  mul4(proj, view, out);
}

/// The anchor's camera for frame `frame` of its orbit (angle 0.1 rad per frame).
inline void anchorCamera(const int64_t dims[3], int width, int height, int frame, double* vp)
{
  const Vec c{ dims[0] * 0.5, dims[1] * 0.5, dims[2] * 0.5 };
  const double R = 1.6 * std::max<double>(dims[0], std::max<double>(dims[1], dims[2]));
  const double ang = frame * 0.1;
  const Vec eye{ c.x + R * std::cos(ang), c.y + R * std::sin(ang), c.z + 0.3 * R };
  // The anchor's up vector is right x forward with right = (-f.y, f.x, 0): world z in the image plane.
  viewProjection(eye, c, Vec{ 0, 0, 1 }, 2.0 * std::atan(0.5) * 180.0 / 3.14159265358979,
    double(width) / height, 0.01 * R, 4.0 * R, vp);
}

/// Network coordinates of a source with voxel i at world coordinate i.
inline void voxelWorldToUnit(const int64_t dims[3], double* m)
{
  std::fill(m, m + 16, 0.0);
  for (int a = 0; a < 3; ++a)
    m[5 * a] = dims[a] > 1 ? 1.0 / double(dims[a] - 1) : 1.0;
  m[15] = 1.0;
}

/// The anchor's transfer function over [valueMin, valueMax] (opacity per voxel, unit distance 1).
inline nv::TransferFunction anchorTransfer(double valueMin, double valueMax, int entries = 256)
{
  nv::TransferFunction tf;
  tf.valueMin = valueMin;
  tf.valueMax = valueMax;
  tf.unitDistance = 1.0;
  tf.rgba.resize(size_t(entries) * 4);
  for (int i = 0; i < entries; ++i)
  {
    const double s = double(i) / (entries - 1);
    const double sigma = s < 0.25 ? 0.0 : (s - 0.25) * 0.3;
    tf.rgba[4 * i] = float(0.9 * s + 0.1);
    tf.rgba[4 * i + 1] = float(0.6 * s);
    tf.rgba[4 * i + 2] = float(0.4 * (1 - s));
    tf.rgba[4 * i + 3] = float(1.0 - std::exp(-sigma));
  }
  return tf;
}

} // namespace nvbench
