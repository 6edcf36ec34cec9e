/**
 * @class   vtkNeuralCudaDevice
 * @brief   the CUDA device of this process's network sessions (not wrapped)
 *
 * Under MPI every rank runs its sessions on the GPU given by its local rank: its index among the ranks on its host
 * (found once by a collective of hostnames, vtkNeuralCompressPartition.h), modulo the CUDA devices the process
 * sees. Two ranks on a host with 2 GPUs use devices 0 and 1; four ranks use 0, 1, 0, 1. A launcher that gives each
 * rank one GPU through CUDA_VISIBLE_DEVICES (read by the CUDA runtime, not by NeuralVolume) leaves each rank one
 * device, its device 0. Without MPI, or before the choice, it is -1: the CUDA runtime's current device (device 0).
 * A rank whose device is not usable (or a host without GPUs) falls back to the CPU under Device Auto, as a serial
 * run does. Every session the plugin creates (Neural Compress's, the Neural Volume Reader's, the representation's
 * session from network bytes) sets nv::SessionOptions::cudaDevice to Get(). Thread-safe.
 */
#ifndef vtkNeuralCudaDevice_h
#define vtkNeuralCudaDevice_h

#include "NeuralVolumeFiltersModule.h" // for export macro

class NEURALVOLUMEFILTERS_EXPORT vtkNeuralCudaDevice
{
public:
  /// The device ordinal of this process's sessions; -1: the CUDA runtime's current device.
  static int Get();

  /// Chooses the device of a rank that is `localRank` of the ranks on its host: localRank modulo the devices the
  /// process sees (-1 when it sees none). Returns the choice.
  static int ChooseForLocalRank(int localRank);

  /// Serial runs (one process): creates the CUDA context of Get()'s device on a background thread, once per
  /// process, so that a state being loaded (its networks come back without training) does not wait for it when the
  /// first session is made. Under MPI it does nothing: a rank's device is chosen later, in its first execution.
  static void CreateContextInBackground();

  vtkNeuralCudaDevice() = delete;
};

#endif
