// Helper of the GPU tests: an engine view of an n^3 float32 test volume.
#pragma once

#include "Core/Volume.h"

#include <vector>

/// A float32 view of an n^3 volume (x fastest) with its value range.
inline nv::VolumeView floatCubeView(const std::vector<float>& data, int n)
{
  nv::VolumeView vol;
  vol.data = data.data();
  vol.dims[0] = vol.dims[1] = vol.dims[2] = n;
  const nv::VolumeStats st = nv::computeStats(vol);
  vol.valueMin = st.min;
  vol.valueMax = st.max;
  return vol;
}
