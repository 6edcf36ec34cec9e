// NeuralVolume engine: the CPU renderer (placeholder until the cpu-render branch lands: render() throws).
#pragma once

#include "Core/Model.h"
#include "Core/Render.h"

#include <cstdint>

namespace nv
{

class ThreadPool;

class CpuRenderer
{
public:
  explicit CpuRenderer(ThreadPool& pool);
  void render(const Model& model, uint64_t version, const RenderRequest& request, RenderResult& result);
  bool workPending() const { return false; }

private:
  ThreadPool& Pool;
};

} // namespace nv
