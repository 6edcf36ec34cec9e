/**
 * @class   vtkNeuralVolumeReader
 * @brief   reads a NeuralVolume (.nvol) file: the network of a Neural Compress output and its image
 *
 * The output is the image that vtkNeuralCompress gave when the file was written: the same geometry,
 * the `NeuralNetwork` field data bit for bit (so the Neural Volume representation draws it), the value
 * range and the training figures stored with the network. OutputMode adds the decoded field (decoded
 * by the engine on Device, as the filter does: on the same device, bit for bit the filter's). A file of
 * several entries is a time series (TIME_STEPS). Corrupt, truncated or newer-version files give a clear
 * error and an empty output.
 */
#ifndef vtkNeuralVolumeReader_h
#define vtkNeuralVolumeReader_h

#include "NeuralVolumeFiltersModule.h" // for export macro
#include "vtkImageAlgorithm.h"

#include <memory>

namespace vtkNeuralCompressInternals
{
struct VolumeFileEntry;
}

class NEURALVOLUMEFILTERS_EXPORT vtkNeuralVolumeReader : public vtkImageAlgorithm
{
public:
  static vtkNeuralVolumeReader* New();
  vtkTypeMacro(vtkNeuralVolumeReader, vtkImageAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  vtkSetStringMacro(FileName);
  vtkGetStringMacro(FileName);

  /// Same values as vtkNeuralCompress::OutputMode: 0 network only, 1 decoded in the source's type, 2 float32.
  vtkSetClampMacro(OutputMode, int, 0, 2);
  vtkGetMacro(OutputMode, int);

  /// Decoding device: 0 Auto, 1 CPU, 2 CUDA (vtkNeuralCompress::Device values).
  vtkSetClampMacro(Device, int, 0, 2);
  vtkGetMacro(Device, int);

  /// 1 when the file looks like a NeuralVolume file (magic); for ParaView's reader factory.
  int CanReadFile(const char* name);

  /// The array the file's networks represent and its association (0 point, 1 cell), after
  /// UpdateInformation: the Neural Volume colours a "Network only" output by it.
  const char* GetArrayName();
  int GetArrayAssociation();
  /// 1 when this process has a GPU the engine can use (the panel hides Device otherwise).
  int GetGpuUsable();

protected:
  vtkNeuralVolumeReader();
  ~vtkNeuralVolumeReader() override;
  int RequestInformation(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

private:
  vtkNeuralVolumeReader(const vtkNeuralVolumeReader&) = delete;
  void operator=(const vtkNeuralVolumeReader&) = delete;
  /// The output of one entry: its network, geometry and (OutputMode) decoded field; under MPI its piece.
  void ReadPiece(const vtkNeuralCompressInternals::VolumeFileEntry& entry, vtkImageData* output);

  struct vtkInternals;
  std::unique_ptr<vtkInternals> Internals;
  char* FileName = nullptr;
  int OutputMode = 0;
  int Device = 0;
};

#endif
