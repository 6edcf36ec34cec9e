// NeuralVolume engine: the smallest network that reaches a PSNR (SizeSearch.h).
#include "SizeSearch.h"

#include "Engine.h"
#include "Error.h"
#include "NetworkSession.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <sstream>

namespace nv
{
namespace
{
/// Steps trained between two polls of the abort function.
constexpr int64_t kStepsPerPoll = 16;

bool reaches(const SizeTrial& trial, double target)
{
  return std::isfinite(trial.psnr) && trial.psnr >= target; // NaN (diverged) never reaches
}
} // namespace

SizeTrial trainSizeCandidate(const SizeSearchRequest& request, int log2TableSize, const std::function<bool()>& abort)
{
  ModelConfig config = request.config;
  config.encoding.log2TableSize = log2TableSize;
  Model model(config);
  model.source = request.source;
  model.initialize(request.train.seed);
  std::unique_ptr<NetworkSession> session = NetworkSession::create(request.device, model, request.session);
  {
    // As a TrainingRun plans it (TrainingRun::planSchedule): an annealed schedule ends at the last step.
    std::unique_ptr<Trainer> trainer = session->createTrainer(request.field, request.train);
    if (request.train.optimizer.schedule != LearningRateSchedule::StepDecay)
      trainer->setPlannedSteps(static_cast<double>(request.steps));
    for (int64_t done = 0; done < request.steps; done += kStepsPerPoll)
    {
      if (abort && abort())
        NV_THROW("the search for the size that reaches the target PSNR was aborted");
      trainer->steps(std::min(kStepsPerPoll, request.steps - done), nullptr);
    }
    trainer->publish();
  }
  Model stored = session->currentModel();
  stored.quantize(request.storage);
  session->setModel(stored);
  SizeTrial trial;
  trial.log2TableSize = log2TableSize;
  trial.psnr = compareToSource(*session, request.field).psnr;
  trial.storedBytes = stored.storedBytes();
  return trial;
}

SizeSearchResult searchSizeForPsnr(const SizeSearchRequest& request, const std::function<bool()>& abort)
{
  NV_CHECK(request.field.data != nullptr, "the size search needs a dense training field");
  NV_CHECK(request.steps > 0, "the size search needs a step count (TrainingSteps > 0)");
  NV_CHECK(request.targetPsnr > 0.0 && std::isfinite(request.targetPsnr), "the size search needs a target PSNR > 0");
  NV_CHECK(request.minLog2 >= 1 && request.minLog2 <= request.maxLog2 && request.maxLog2 <= 30,
    "the size search needs a range of table sizes");
  SizeSearchResult result;
  const auto started = std::chrono::steady_clock::now();
  auto train = [&](int log2) {
    result.trials.push_back(trainSizeCandidate(request, log2, abort));
    result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    return reaches(result.trials.back(), request.targetPsnr);
  };
  // The largest two first (the PSNR of the largest tables levels off, and the largest may miss by a few tenths where
  // the one below reaches): when both miss, no smaller one is worth training, and the better of the two is kept.
  int high = request.maxLog2;
  result.reached = train(high);
  if (!result.reached && high > request.minLog2)
    result.reached = train(--high);
  if (!result.reached)
  {
    const SizeTrial& first = result.trials.front();
    const SizeTrial& last = result.trials.back();
    result.log2TableSize = std::isfinite(last.psnr) && !(first.psnr >= last.psnr) ? last.log2TableSize
                                                                                   : first.log2TableSize;
    return result;
  }
  // Bisection for the smallest that reaches it: `high` reaches, everything below `low` does not.
  int low = request.minLog2;
  while (low < high)
  {
    const int middle = low + (high - low) / 2;
    if (train(middle))
      high = middle;
    else
      low = middle + 1;
  }
  result.log2TableSize = high;
  return result;
}

std::string SizeSearchResult::describe(const SizeSearchRequest& request) const
{
  std::ostringstream s;
  s.precision(4);
  s << "sized for PSNR " << request.targetPsnr << " dB: 2^" << this->log2TableSize << " "
    << precisionName(request.storage);
  if (this->reached)
    s << ", the smallest of 2^" << request.minLog2 << "..2^" << request.maxLog2 << " to reach it in " << request.steps
      << " steps";
  else
    s << ", the better of the two largest that compress: no candidate reached it in " << request.steps
      << " steps (their own PSNR, before any Max Error correction)";
  s << " (trained in " << this->seconds << " s:";
  for (size_t i = 0; i < this->trials.size(); ++i)
    s << (i ? ", 2^" : " 2^") << this->trials[i].log2TableSize << " " << this->trials[i].psnr << " dB";
  s << ")";
  return s.str();
}

} // namespace nv
