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
