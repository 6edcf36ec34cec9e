/**
 * @class   vtkNeuralParticleField
 * @brief   the field a particle set defines, as Neural Compress trains it, on an image
 *
 * The engine's kernel reconstruction of a point array of particles (Particles/ParticleField.h, the same code and
 * settings Neural Compress uses: ParticleField, ParticleKernel, ParticleRadius, ParticleRadiusArray) evaluated at the
 * samples of an image over the particles' box (SamplingDimensions; 0 0 0 = Neural Compress's automatic dimensions),
 * NaN outside every particle's support, with a "vtkValidPointMask" char array (1 inside). For previewing the field a
 * network learns and for comparing it with VTK's SPH / Point Volume Interpolators.
 */
#ifndef vtkNeuralParticleField_h
#define vtkNeuralParticleField_h

#include "NeuralVolumeFiltersModule.h" // for export macro
#include "vtkImageAlgorithm.h"

#include <string>

class NEURALVOLUMEFILTERS_EXPORT vtkNeuralParticleField : public vtkImageAlgorithm
{
public:
  static vtkNeuralParticleField* New();
  vtkTypeMacro(vtkNeuralParticleField, vtkImageAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  /// As vtkNeuralCompress's properties of the same names.
  vtkSetClampMacro(ParticleField, int, 0, 1);
  vtkGetMacro(ParticleField, int);
  vtkSetClampMacro(ParticleKernel, int, 0, 2);
  vtkGetMacro(ParticleKernel, int);
  vtkSetMacro(ParticleRadius, double);
  vtkGetMacro(ParticleRadius, double);
  vtkSetStdStringFromCharMacro(ParticleRadiusArray);
  vtkGetCharFromStdStringMacro(ParticleRadiusArray);
  vtkSetVector3Macro(SamplingDimensions, int);
  vtkGetVector3Macro(SamplingDimensions, int);

  /// The reconstruction's description after an update ("200000 particles, cubic spline kernel, radius ...").
  const char* GetFieldDescription() { return this->Description.c_str(); }

protected:
  vtkNeuralParticleField();
  ~vtkNeuralParticleField() override;
  int FillInputPortInformation(int port, vtkInformation* info) override;
  int RequestInformation(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestUpdateExtent(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

private:
  vtkNeuralParticleField(const vtkNeuralParticleField&) = delete;
  void operator=(const vtkNeuralParticleField&) = delete;

  /// The selected point array's name; empty with an error when there is none.
  std::string ArrayName();

  int ParticleField = 0;
  int ParticleKernel = 1;
  double ParticleRadius = 0.0;
  std::string ParticleRadiusArray;
  int SamplingDimensions[3] = { 0, 0, 0 };
  std::string Description;
};

#endif
