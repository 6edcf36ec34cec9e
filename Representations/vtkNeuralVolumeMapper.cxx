#include "vtkNeuralVolumeMapper.h"

#include "Core/Engine.h"
#include "Core/Error.h"
#include "Core/Model.h"
#include "Core/NetworkSession.h"
#include "Core/Serialization.h"

#include "vtkFieldData.h"
#include "vtkFloatArray.h"
#include "vtkImageData.h"
#include "vtkMatrix3x3.h"
#include "vtkObjectFactory.h"
#include "vtkPointData.h"
#include "vtkRenderWindow.h"
#include "vtkRenderer.h"
#include "vtkSmartPointer.h"
#include "vtkMultiBlockVolumeMapper.h"
#include "vtkUnsignedCharArray.h"
#include "vtkVolume.h"

#include <algorithm>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

vtkStandardNewMacro(vtkNeuralVolumeMapper);

struct vtkNeuralVolumeMapper::vtkInternals
{
  // Cache key: the network's size and stored CRC-32, and the requested resolution.
  size_t NetworkSize = 0;
  uint32_t NetworkCrc = 0;
  int Resolution[3] = { -1, -1, -1 };
  bool KeyValid = false;

  bool HaveModel = false;
  nv::Model Model;
  std::unique_ptr<nv::NetworkSession> Session;
  nv::Device Device = nv::Device::Cpu;
  int64_t Dims[3] = { 0, 0, 0 };
  int64_t Decoded = 0; // z-slices decoded
  std::vector<float> Grid;
  int DecodeCount = 0;
  std::string LastError;
  bool ReportedMissing = false;

  vtkNew<vtkMultiBlockVolumeMapper> RenderMapper;
  vtkSmartPointer<vtkImageData> Shown;
  int64_t ShownSlices = -1;
};

//------------------------------------------------------------------------------
vtkNeuralVolumeMapper::vtkNeuralVolumeMapper()
  : Internals(new vtkInternals)
{
  std::string note;
  try
  {
    this->Internals->Device = nv::resolveDevice(nv::Device::Auto, &note);
  }
  catch (const std::exception&)
  {
    this->Internals->Device = nv::Device::Cpu;
  }
}

vtkNeuralVolumeMapper::~vtkNeuralVolumeMapper()
{
  delete this->Internals;
}

//------------------------------------------------------------------------------
void vtkNeuralVolumeMapper::SetDecodeResolution(int x, int y, int z)
{
  if (x != this->DecodeResolution[0] || y != this->DecodeResolution[1] ||
    z != this->DecodeResolution[2])
  {
    this->DecodeResolution[0] = std::max(0, x);
    this->DecodeResolution[1] = std::max(0, y);
    this->DecodeResolution[2] = std::max(0, z);
    this->Modified();
  }
}

int vtkNeuralVolumeMapper::GetDecodedSlices() const
{
  return static_cast<int>(this->Internals->Decoded);
}

int vtkNeuralVolumeMapper::GetTotalSlices() const
{
  return static_cast<int>(this->Internals->Dims[2]);
}

int vtkNeuralVolumeMapper::GetDecodeCount() const
{
  return this->Internals->DecodeCount;
}

bool vtkNeuralVolumeMapper::HasNetwork() const
{
  return this->Internals->HaveModel;
}

const char* vtkNeuralVolumeMapper::GetLastError() const
{
  return this->Internals->LastError.c_str();
}

vtkMultiBlockVolumeMapper* vtkNeuralVolumeMapper::GetRenderMapper()
{
  return this->Internals->RenderMapper;
}

void vtkNeuralVolumeMapper::ReleaseGraphicsResources(vtkWindow* w)
{
  this->Internals->RenderMapper->ReleaseGraphicsResources(w);
}

//------------------------------------------------------------------------------
void vtkNeuralVolumeMapper::Render(vtkRenderer* ren, vtkVolume* vol)
{
  vtkInternals& in = *this->Internals;
  if (this->GetInputAlgorithm())
  {
    this->GetInputAlgorithm()->Update();
  }
  vtkImageData* input = vtkImageData::SafeDownCast(this->GetInput());
  if (!input)
  {
    return;
  }
  vtkUnsignedCharArray* network = vtkUnsignedCharArray::SafeDownCast(
    input->GetFieldData()->GetAbstractArray("NeuralNetwork"));
  if (!network || network->GetNumberOfComponents() != 1 || network->GetNumberOfTuples() < 8)
  {
    in.HaveModel = false;
    in.KeyValid = false;
    in.Decoded = 0;
    in.Dims[0] = in.Dims[1] = in.Dims[2] = 0;
    in.LastError = "the input has no 'NeuralNetwork' field data array";
    if (!in.ReportedMissing)
    {
      // The representation reports this to the user; keep the mapper quiet but traceable.
      vtkDebugMacro(<< in.LastError);
      in.ReportedMissing = true;
    }
    return;
  }
  in.ReportedMissing = false;

  // Cache check: the serialized format ends with the CRC-32 of everything before it.
  const size_t size = static_cast<size_t>(network->GetNumberOfTuples());
  const unsigned char* bytes = network->GetPointer(0);
  uint32_t crc = 0;
  std::memcpy(&crc, bytes + size - 4, 4);
  const bool sameKey = in.KeyValid && in.NetworkSize == size && in.NetworkCrc == crc &&
    std::equal(this->DecodeResolution, this->DecodeResolution + 3, in.Resolution);
  if (!sameKey)
  {
    in.KeyValid = true;
    in.NetworkSize = size;
    in.NetworkCrc = crc;
    std::copy(this->DecodeResolution, this->DecodeResolution + 3, in.Resolution);
    in.HaveModel = false;
    in.Decoded = 0;
    in.ShownSlices = -1;
    try
    {
      in.Model = nv::deserialize(bytes, size);
      in.Session = nv::NetworkSession::create(in.Device, in.Model);
      in.HaveModel = true;
      in.LastError.clear();
    }
    catch (const std::exception& e)
    {
      in.LastError = std::string("cannot read the NeuralNetwork array: ") + e.what();
      vtkErrorMacro("Neural Volume: " << in.LastError);
      return;
    }
    const bool useSource = this->DecodeResolution[0] <= 0 || this->DecodeResolution[1] <= 0 ||
      this->DecodeResolution[2] <= 0;
    for (int d = 0; d < 3; ++d)
    {
      in.Dims[d] = useSource ? in.Model.source.dims[d] : this->DecodeResolution[d];
    }
    in.Grid.assign(static_cast<size_t>(in.Dims[0] * in.Dims[1] * in.Dims[2]), 0.0f);
    ++in.DecodeCount;
  }
  if (!in.HaveModel)
  {
    return;
  }

  // Progressive decode.
  const int64_t nx = in.Dims[0], ny = in.Dims[1], nz = in.Dims[2];
  const int64_t remaining = nz - in.Decoded;
  if (remaining > 0)
  {
    vtkRenderWindow* win = ren ? ren->GetRenderWindow() : nullptr;
    const bool interactive = win && win->GetDesiredUpdateRate() > 1.0;
    const int64_t count = interactive && this->SlicesPerRender > 0
      ? std::min<int64_t>(this->SlicesPerRender, remaining)
      : remaining;
    try
    {
      nv::decodeGridValues(*in.Session, nx, ny, nz, in.Decoded, in.Decoded + count,
        in.Grid.data() + in.Decoded * nx * ny);
    }
    catch (const std::exception& e)
    {
      in.LastError = std::string("decoding failed: ") + e.what();
      vtkErrorMacro("Neural Volume: " << in.LastError);
      in.HaveModel = false;
      return;
    }
    in.Decoded += count;
  }

  // The slices decoded so far, as an image sharing the grid's memory.
  const int64_t slices = in.Decoded;
  if (slices < std::min<int64_t>(2, nz))
  {
    return;
  }
  if (slices != in.ShownSlices || !in.Shown)
  {
    const nv::SourceInfo& src = in.Model.source;
    vtkNew<vtkImageData> shown;
    shown->SetExtent(0, static_cast<int>(nx - 1), 0, static_cast<int>(ny - 1), 0,
      static_cast<int>(slices - 1));
    double origin[3], spacing[3];
    for (int d = 0; d < 3; ++d)
    {
      const double lo = src.bounds[2 * d], hi = src.bounds[2 * d + 1];
      const int64_t n = in.Dims[d];
      spacing[d] = n > 1 ? (hi - lo) / static_cast<double>(n - 1) : std::max(src.spacing[d], 1e-12);
      if (!(spacing[d] > 0.0))
      {
        spacing[d] = 1.0;
      }
      origin[d] = n > 1 ? lo : 0.5 * (lo + hi);
    }
    shown->SetOrigin(origin);
    shown->SetSpacing(spacing);
    shown->SetDirectionMatrix(input->GetDirectionMatrix());
    vtkNew<vtkFloatArray> values;
    values->SetName(src.arrayName.empty() ? "NeuralField" : src.arrayName.c_str());
    values->SetArray(in.Grid.data(), nx * ny * slices, /*save=*/1);
    shown->GetPointData()->SetScalars(values);
    in.Shown = shown;
    in.ShownSlices = slices;
    in.RenderMapper->SetInputData(in.Shown);
  }

  vtkMultiBlockVolumeMapper* rm = in.RenderMapper;
  rm->SetBlendMode(this->BlendMode);
  rm->SetAverageIPScalarRange(this->AverageIPScalarRange);
  rm->SetCropping(this->Cropping);
  rm->SetCroppingRegionPlanes(this->CroppingRegionPlanes);
  rm->SetCroppingRegionFlags(this->CroppingRegionFlags);
  rm->Render(ren, vol);
}

//------------------------------------------------------------------------------
void vtkNeuralVolumeMapper::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "DecodeResolution: " << this->DecodeResolution[0] << " "
     << this->DecodeResolution[1] << " " << this->DecodeResolution[2] << "\n";
  os << indent << "SlicesPerRender: " << this->SlicesPerRender << "\n";
  os << indent << "DecodedSlices: " << this->GetDecodedSlices() << " / " << this->GetTotalSlices()
     << "\n";
}
