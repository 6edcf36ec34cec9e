/**
 * @class   vtkNeuralVolumeWriter
 * @brief   writes the trained network of a Neural Compress output to a NeuralVolume (.nvol) file
 *
 * The input is an image carrying a `NeuralNetwork` field-data array (the output of vtkNeuralCompress,
 * in any OutputMode). The file holds the network (the engine's format, bit for bit) and the geometry
 * of the output image, so that vtkNeuralVolumeReader gives the same representation back. With
 * WriteAllTimeSteps every time step of the input goes to the one file (one entry each). The format
 * is described in vtkNeuralVolumeFile.h and the README. Errors are reported with vtkErrorMacro.
 */
#ifndef vtkNeuralVolumeWriter_h
#define vtkNeuralVolumeWriter_h

#include "NeuralVolumeFiltersModule.h" // for export macro
#include "vtkAlgorithm.h"

#include <memory>

class NEURALVOLUMEFILTERS_EXPORT vtkNeuralVolumeWriter : public vtkAlgorithm
{
public:
  static vtkNeuralVolumeWriter* New();
  vtkTypeMacro(vtkNeuralVolumeWriter, vtkAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  vtkSetStringMacro(FileName);
  vtkGetStringMacro(FileName);

  /// Write every time step of the input (one entry each) instead of the current one.
  vtkSetMacro(WriteAllTimeSteps, bool);
  vtkGetMacro(WriteAllTimeSteps, bool);

  /// Writes the file; returns 1 on success (ParaView's writer proxies call this).
  int Write();

  vtkTypeBool ProcessRequest(vtkInformation* request, vtkInformationVector** inInfo,
    vtkInformationVector* outInfo) override;

protected:
  vtkNeuralVolumeWriter();
  ~vtkNeuralVolumeWriter() override;
  int FillInputPortInformation(int port, vtkInformation* info) override;

private:
  vtkNeuralVolumeWriter(const vtkNeuralVolumeWriter&) = delete;
  void operator=(const vtkNeuralVolumeWriter&) = delete;

  struct vtkInternals;
  std::unique_ptr<vtkInternals> Internals;
  char* FileName = nullptr;
  bool WriteAllTimeSteps = false;
};

#endif
