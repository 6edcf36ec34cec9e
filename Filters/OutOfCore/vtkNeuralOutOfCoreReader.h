/**
 * @class   vtkNeuralOutOfCoreReader
 * @brief   names a volume file for Neural Compress without loading it (out-of-core training, issue 22)
 *
 * Reads the header of a raw NRRD (.nhdr with its detached data file, or a .nrrd with raw encoding), a Brick of
 * Values (.bov) or a VTK XML image (.vti with a raw appended point array) and checks it against the data file's
 * size. The output is an image with the file's extent, spacing and origin and NO samples: one field-data string array,
 * named after the file's field, names the file and describes it (vtkNeuralOutOfCoreInput.h).
 * Neural Compress on this output trains from the file through a random block buffer within its MemoryBudget and
 * measures its figures in streamed passes over the file. The output has the extent asked of it (the whole file by
 * default; under MPI each rank's Neural Compress asks for its padded piece, and reads only that part). Sample types: uint8, int16, uint16, int32, float32,
 * float64, either byte order. A header the reader cannot use, or a data file shorter than the header says, gives
 * one error and an empty output.
 */
#ifndef vtkNeuralOutOfCoreReader_h
#define vtkNeuralOutOfCoreReader_h

#include "NeuralVolumeFiltersModule.h" // for export macro
#include "vtkImageAlgorithm.h"

#include <string>

class NEURALVOLUMEFILTERS_EXPORT vtkNeuralOutOfCoreReader : public vtkImageAlgorithm
{
public:
  static vtkNeuralOutOfCoreReader* New();
  vtkTypeMacro(vtkNeuralOutOfCoreReader, vtkImageAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  vtkSetStringMacro(FileName);
  vtkGetStringMacro(FileName);

  /// The point array of a .vti file (empty: its active scalars, else its first single-component array).
  vtkSetStringMacro(ArrayName);
  vtkGetStringMacro(ArrayName);

  /// 1 when the header reads and its samples can be streamed (for ParaView's reader factory).
  int CanReadFile(const char* name);

  /// "NRRD (detached header), 64 x 64 x 64 uint16, little endian, 524 kB ('density')" after UpdateInformation; the
  /// error otherwise.
  const char* GetFileSummary() { return this->Summary.c_str(); }
  /// The name of the file's field (the header's, else the file's stem) after UpdateInformation: what the network
  /// represents, and what the Neural Volume of Neural Compress colours by.
  const char* GetFieldName() { return this->FieldName.c_str(); }

protected:
  vtkNeuralOutOfCoreReader();
  ~vtkNeuralOutOfCoreReader() override;
  int RequestInformation(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

private:
  vtkNeuralOutOfCoreReader(const vtkNeuralOutOfCoreReader&) = delete;
  void operator=(const vtkNeuralOutOfCoreReader&) = delete;

  char* FileName = nullptr;
  char* ArrayName = nullptr;
  bool LayoutRead = false; ///< the last RequestInformation read the header
  std::string Summary;
  std::string FieldName;
};

#endif
