#include "CpuSession.h"

#include "Core/Backends.h"
#include "Core/Error.h"
#include "CpuTrainer.h"

#include <cstring>

namespace nv
{

std::unique_ptr<NetworkSession> createCpuSession(const Model& model, const SessionOptions& options)
{
  return std::unique_ptr<NetworkSession>(new CpuSession(model, options));
}

CpuSession::CpuSession(const Model& model, const SessionOptions& options)
  : Options(options)
  , SessionModel(model)
  , Corrections(sharedCorrections(model))
  , Pool(options.threads, options.lowPriority)
  , Renderer(new CpuRenderer(Pool))
{
}

CpuSession::~CpuSession() = default;

uint64_t CpuSession::version() const
{
  return Version.load();
}

void CpuSession::setModel(const Model& model)
{
  validate(model.config());
  std::lock_guard<std::mutex> lock(Mutex);
  SessionModel = model;
  Corrections = sharedCorrections(model);
  ++Version;
}

std::shared_ptr<const ErrorCorrections> CpuSession::errorCorrections() const
{
  std::lock_guard<std::mutex> lock(Mutex);
  return Corrections;
}

Model CpuSession::currentModel()
{
  std::lock_guard<std::mutex> lock(Mutex);
  return SessionModel;
}

CpuSession::Snapshot CpuSession::snapshot()
{
  std::lock_guard<std::mutex> lock(Mutex);
  const uint64_t current = Version.load();
  if (!LastSnapshot.model || LastSnapshot.version != current)
  {
    LastSnapshot.model = std::make_shared<const Model>(SessionModel);
    LastSnapshot.version = current;
  }
  return LastSnapshot;
}

const CpuInference& CpuSession::evaluator(const std::shared_ptr<const Model>& model)
{
  if (!Evaluator || EvaluatorModel != model)
  {
    Evaluator.reset(new CpuInference(*model));
    EvaluatorModel = model;
  }
  return *Evaluator;
}

CpuTrainer::PublishFn CpuSession::publisher()
{
  // The trainer must not outlive the session (documented in NetworkSession::createTrainer).
  return [this](const std::vector<float>& p) {
    std::lock_guard<std::mutex> guard(Mutex);
    NV_CHECK(p.size() == SessionModel.params().size(), "publish: the trainer's network has a different configuration");
    SessionModel.params() = p;
    SessionModel.corrections = ErrorCorrections(); // computed for the parameters replaced
    Corrections.reset();
    ++Version;
  };
}

std::unique_ptr<Trainer> CpuSession::createTrainer(const VolumeView& volume, const TrainConfig& config)
{
  const TrainConfig c = trainerConfig(volume, config, Options);
  std::lock_guard<std::mutex> lock(Mutex);
  return std::unique_ptr<Trainer>(new CpuTrainer(SessionModel, volume, TrainingPoints(), c, publisher()));
}

std::unique_ptr<Trainer> CpuSession::createTrainer(const TrainingPoints& points, const TrainConfig& config)
{
  const TrainConfig c = trainerConfig(points, config, Options);
  std::lock_guard<std::mutex> lock(Mutex);
  return std::unique_ptr<Trainer>(new CpuTrainer(SessionModel, VolumeView(), points, c, publisher()));
}

std::unique_ptr<Trainer> CpuSession::createTrainer(BatchSource& source, const TrainConfig& config)
{
  const TrainConfig c = trainerConfig(source, config, Options);
  std::lock_guard<std::mutex> lock(Mutex);
  std::unique_ptr<CpuTrainer> trainer(new CpuTrainer(SessionModel, VolumeView(), TrainingPoints(), c, publisher()));
  trainer->setBatchSource(&source);
  return std::unique_ptr<Trainer>(trainer.release());
}

void CpuSession::inferPoints(const float* xyz, int64_t n, float* out, Memory where)
{
  NV_CHECK(where == Memory::Host, "the CPU backend has no device memory");
  NV_CHECK(n >= 0 && (n == 0 || (xyz && out)), "inferPoints: invalid arguments");
  if (n == 0)
    return;
  std::lock_guard<std::mutex> work(WorkMutex);
  evaluator(snapshot().model).inferPoints(Pool, xyz, n, out);
}

void CpuSession::decodeGrid(int64_t nx, int64_t ny, int64_t nz, int64_t z0, int64_t z1, float* out, Memory where)
{
  NV_CHECK(where == Memory::Host, "the CPU backend has no device memory");
  NV_CHECK(nx >= 1 && ny >= 1 && nz >= 1, "decodeGrid: grid dimensions must be >= 1");
  NV_CHECK(z0 >= 0 && z0 <= z1 && z1 <= nz, "decodeGrid: invalid slice range");
  NV_CHECK(out != nullptr || z0 == z1, "decodeGrid: null output");
  if (z0 == z1)
    return;
  std::lock_guard<std::mutex> work(WorkMutex);
  const Snapshot now = snapshot();
  // The grid the Decode path rendered last (same network, same dims: the same values, decoded by the same code) is
  // copied instead of decoded again -- a script that renders a restored network, then asks for the decoded field.
  // Not on the source's own grid of a network with error corrections: the renderer's grid holds the corrected field,
  // and decodeGrid gives the network's own values (decodeGridValues corrects them; copied, they were corrected twice,
  // and the filter measured the network's own error beside its corrections when the GUI rendered the Decode path
  // between the phase end's corrections and its measurement).
  const int64_t dims[3] = { nx, ny, nz };
  const int64_t* source = now.model->source.dims;
  const bool correctedGrid =
    now.model->corrections.enabled() && nx == source[0] && ny == source[1] && nz == source[2];
  if (const std::shared_ptr<const DecodedGrid> grid =
        correctedGrid ? nullptr : Renderer->decodedGrid(now.version, dims))
  {
    std::memcpy(out, grid->values.data() + z0 * nx * ny, static_cast<size_t>((z1 - z0) * nx * ny) * sizeof(float));
    return;
  }
  evaluator(now.model).decodeGrid(Pool, nx, ny, nz, z0, z1, out);
}

void CpuSession::render(const RenderRequest& request, RenderResult& result, Memory where)
{
  NV_CHECK(where == Memory::Host, "the CPU backend renders into host memory");
  std::lock_guard<std::mutex> work(WorkMutex);
  const Snapshot now = snapshot();
  Renderer->render(*now.model, now.version, request, result);
}

bool CpuSession::workPending() const
{
  return Renderer->workPending(); // atomics only: answers while a render holds Mutex
}

} // namespace nv
