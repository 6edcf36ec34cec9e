// Minimal NRRD detached-header (.nhdr) reader for the benchmarks (raw encoding, little endian).
#pragma once

#include "Core/Model.h"
#include "Core/Volume.h"

#include <algorithm>
#include <cstdlib>

#include <cstdint>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace nvbench
{
struct RawVolume
{
  nv::VolumeView view;
  std::vector<uint8_t> bytes;
  std::string name;
};

inline RawVolume loadNhdr(const std::string& path)
{
  std::ifstream h(path);
  if (!h)
    throw std::runtime_error("cannot open " + path);
  std::string line, type, file;
  int64_t dims[3] = { 0, 0, 0 };
  while (std::getline(h, line))
  {
    const auto c = line.find(':');
    if (line.empty() || line[0] == '#' || c == std::string::npos)
      continue;
    std::string k = line.substr(0, c), v = line.substr(c + 1);
    while (!v.empty() && (v[0] == ' ' || v[0] == '='))
      v.erase(0, 1);
    if (k == "sizes")
      std::istringstream(v) >> dims[0] >> dims[1] >> dims[2];
    else if (k == "type")
      type = v;
    else if (k == "data file" || k == "datafile")
      file = v;
  }
  RawVolume r;
  r.name = path.substr(path.find_last_of('/') + 1);
  nv::ScalarType t;
  if (type == "uchar" || type == "unsigned char" || type == "uint8")
    t = nv::ScalarType::UInt8;
  else if (type == "short" || type == "int16")
    t = nv::ScalarType::Int16;
  else if (type == "ushort" || type == "unsigned short" || type == "uint16")
    t = nv::ScalarType::UInt16;
  else if (type == "float")
    t = nv::ScalarType::Float32;
  else
    throw std::runtime_error("unsupported nhdr type " + type);
  const std::string dir = path.substr(0, path.find_last_of('/') + 1);
  std::ifstream f(dir + file, std::ios::binary);
  if (!f)
    throw std::runtime_error("cannot open " + dir + file);
  const size_t n = size_t(dims[0] * dims[1] * dims[2]) * nv::scalarSize(t);
  r.bytes.resize(n);
  f.read(reinterpret_cast<char*>(r.bytes.data()), std::streamsize(n));
  if (size_t(f.gcount()) != n)
    throw std::runtime_error("short raw file for " + path);
  r.view.data = r.bytes.data();
  r.view.type = t;
  for (int i = 0; i < 3; ++i)
    r.view.dims[i] = dims[i];
  const nv::VolumeStats s = nv::computeStats(r.view);
  r.view.valueMin = s.min;
  r.view.valueMax = s.max;
  return r;
}

/// `raw` resampled to f times its samples per axis minus f - 1 (trilinear, float32): a larger volume with the same
/// content for scaling measurements. Named "<name>@<f>x".
inline RawVolume upsample(const RawVolume& raw, int f)
{
  RawVolume r;
  int64_t d[3];
  for (int a = 0; a < 3; ++a)
    d[a] = (raw.view.dims[a] - 1) * f + 1;
  r.bytes.resize(size_t(d[0] * d[1] * d[2]) * sizeof(float));
  float* out = reinterpret_cast<float*>(r.bytes.data());
  const int64_t* s = raw.view.dims;
  for (int64_t z = 0; z < d[2]; ++z)
    for (int64_t y = 0; y < d[1]; ++y)
      for (int64_t x = 0; x < d[0]; ++x)
      {
        const int64_t c[3] = { x, y, z };
        int64_t i0[3];
        double w[3];
        for (int a = 0; a < 3; ++a)
        {
          i0[a] = std::min<int64_t>(c[a] / f, s[a] - 2 < 0 ? 0 : s[a] - 2);
          w[a] = double(c[a] - i0[a] * f) / f;
        }
        double v = 0.0;
        for (int k = 0; k < 8; ++k)
        {
          const int64_t ix = std::min(i0[0] + (k & 1), s[0] - 1), iy = std::min(i0[1] + ((k >> 1) & 1), s[1] - 1),
                        iz = std::min(i0[2] + ((k >> 2) & 1), s[2] - 1);
          const double wk = ((k & 1) ? w[0] : 1 - w[0]) * ((k & 2) ? w[1] : 1 - w[1]) * ((k & 4) ? w[2] : 1 - w[2]);
          v += wk * raw.view.at((iz * s[1] + iy) * s[0] + ix);
        }
        out[(z * d[1] + y) * d[0] + x] = float(v);
      }
  r.view.data = r.bytes.data();
  r.view.type = nv::ScalarType::Float32;
  for (int a = 0; a < 3; ++a)
    r.view.dims[a] = d[a];
  r.view.valueMin = raw.view.valueMin;
  r.view.valueMax = raw.view.valueMax;
  r.name = raw.name + "@" + std::to_string(f) + "x";
  return r;
}

/// "path.nhdr" or "path.nhdr@2x" (upsampled twice per axis, see upsample()).
inline RawVolume loadVolume(const std::string& spec)
{
  const auto at = spec.find('@');
  if (at == std::string::npos)
    return loadNhdr(spec);
  return upsample(loadNhdr(spec.substr(0, at)), std::atoi(spec.c_str() + at + 1));
}

/// The method's model for a volume: 16x4 levels, base 16, finest = twice the largest dimension, 64x4 MLP,
/// initialised with `seed`, source range from the volume.
inline nv::Model modelFor(const RawVolume& raw, int log2T, uint64_t seed)
{
  nv::ModelConfig c;
  c.encoding.log2TableSize = log2T;
  c.encoding.finestResolution =
    int(2 * std::max(raw.view.dims[0], std::max(raw.view.dims[1], raw.view.dims[2])));
  nv::Model m(c);
  m.initialize(seed);
  m.source.valueMin = raw.view.valueMin;
  m.source.valueMax = raw.view.valueMax;
  // Voxel i at world coordinate i (spacing 1, origin 0), as the render benchmarks place the volume.
  for (int a = 0; a < 3; ++a)
  {
    m.source.dims[a] = raw.view.dims[a];
    m.source.origin[a] = 0.0;
    m.source.spacing[a] = 1.0;
    m.source.bounds[2 * a] = 0.0;
    m.source.bounds[2 * a + 1] = double(raw.view.dims[a] - 1);
  }
  return m;
}

/// "250,500,1000" -> {250, 500, 1000}
inline std::vector<int> parseSteps(const std::string& list)
{
  std::vector<int> marks;
  std::stringstream ss(list);
  for (std::string t; std::getline(ss, t, ',');)
    marks.push_back(std::atoi(t.c_str()));
  return marks;
}
} // namespace nvbench
