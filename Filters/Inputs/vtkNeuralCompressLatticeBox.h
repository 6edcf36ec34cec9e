// Boxes of lattice points (private header): point extents {i0, i1, j0, j1, k0, k1} of one lattice, as the per-rank
// dataset path uses them (vtkNeuralCompressDataSetPiece.h); empty when a lower index exceeds its upper one.
#ifndef vtkNeuralCompressLatticeBox_h
#define vtkNeuralCompressLatticeBox_h

#include <algorithm>
#include <array>
#include <cstdint>

namespace vtkNeuralCompressInternals
{
using LatticeBox = std::array<int, 6>;

inline bool IsEmptyBox(const LatticeBox& b)
{
  return b[0] > b[1] || b[2] > b[3] || b[4] > b[5];
}

inline LatticeBox IntersectBoxes(const LatticeBox& a, const LatticeBox& b)
{
  LatticeBox o;
  for (size_t i = 0; i < 3; ++i)
  {
    o[2 * i] = std::max(a[2 * i], b[2 * i]);
    o[2 * i + 1] = std::min(a[2 * i + 1], b[2 * i + 1]);
  }
  return o;
}

/// The smallest box holding both (an empty one adds nothing).
inline LatticeBox HullOfBoxes(const LatticeBox& a, const LatticeBox& b)
{
  if (IsEmptyBox(a))
    return b;
  if (IsEmptyBox(b))
    return a;
  LatticeBox o;
  for (size_t i = 0; i < 3; ++i)
  {
    o[2 * i] = std::min(a[2 * i], b[2 * i]);
    o[2 * i + 1] = std::max(a[2 * i + 1], b[2 * i + 1]);
  }
  return o;
}

/// `b` grown by `layers` on every side, within `whole`.
inline LatticeBox GrowBox(const LatticeBox& b, int layers, const LatticeBox& whole)
{
  LatticeBox g = b;
  for (size_t i = 0; i < 3; ++i)
  {
    g[2 * i] -= layers;
    g[2 * i + 1] += layers;
  }
  return IntersectBoxes(g, whole);
}

inline int64_t BoxPoints(const LatticeBox& b)
{
  return IsEmptyBox(b) ? 0 : int64_t(b[1] - b[0] + 1) * (b[3] - b[2] + 1) * (b[5] - b[4] + 1);
}

/// Index of lattice point (i, j, k) in an image of point extent `ext` (x fastest).
inline int64_t IndexInBox(const LatticeBox& ext, int i, int j, int k)
{
  return (int64_t(k - ext[4]) * (ext[3] - ext[2] + 1) + (j - ext[2])) * (ext[1] - ext[0] + 1) + (i - ext[0]);
}

} // namespace vtkNeuralCompressInternals

#endif
