// vtkNeuralCompress's SizeForPSNR: the job's table size searched by training candidates (nv::searchSizeForPsnr), in
// its run's prologue (vtkNeuralCompressJob.h).
#include "vtkNeuralCompressJob.h"

#include "Core/Error.h"
#include "Core/ResourceEstimate.h"
#include "Core/SizeSearch.h"

#include <algorithm>

namespace vtkNeuralCompressInternals
{

void Job::SearchSizeForPsnr(const std::function<bool()>& abort)
{
  if (this->SearchMaxLog2 <= 0)
    return;
  NV_CHECK(this->Data->Field.View.data && this->Data->BankValues.empty() && !this->Data->Batches,
    "Size For PSNR searches the size on a dense image field; this input is resampled from points, sparse or "
    "streamed from a file: set Log2 Table Size or a Target Compression Ratio instead");
  nv::SizeSearchRequest request;
  request.device = this->Session->device();
  request.session = this->SessionOptions;
  request.field = this->Data->Field.View;
  request.source = this->Source;
  request.config = this->Layout();
  request.train = this->Train;
  request.steps = this->TrainingSettings.TrainingSteps;
  request.targetPsnr = this->TrainingSettings.SizeForPsnr;
  request.storage = this->Storage;
  request.minLog2 = std::min(request.config.encoding.log2TableSize, this->SearchMaxLog2);
  // A candidate the machine cannot train is no candidate: the largest tried is the largest whose training fits.
  request.maxLog2 = this->SearchMaxLog2;
  const int64_t hostLimit = nv::hostMemoryLimit();
  for (nv::ModelConfig largest = request.config; request.maxLog2 > request.minLog2; --request.maxLog2)
  {
    largest.encoding.log2TableSize = request.maxLog2;
    if (nv::trainingMemory(largest, request.train, request.device).hostBytes <= hostLimit)
      break;
  }
  const nv::SizeSearchResult result = nv::searchSizeForPsnr(request, abort);
  std::lock_guard<std::mutex> lock(this->Mutex);
  this->NetworkConfig.encoding.log2TableSize = result.log2TableSize;
  this->SizeNote = result.describe(request);
}

} // namespace vtkNeuralCompressInternals
