// Private to NeuralVolume::Filters (NV_HAVE_HDF5 builds): what the out-of-core HDF5 code shares -- an identifier
// closed when it goes out of scope, HDF5's error printing silenced while the plugin reports the reason itself, the
// innermost message of HDF5's error stack, and the lock every HDF5 call of the plugin holds (the HDF5 library ParaView
// uses, Debian's parallel build, is not thread-safe, and the block buffer reads from several threads).
#ifndef vtkNeuralHdf5Handle_h
#define vtkNeuralHdf5Handle_h

#include <hdf5.h>

#include <mutex>
#include <string>

namespace vtkNeuralCompressInternals
{

/// Closes an HDF5 identifier when it goes out of scope.
class Hdf5Handle
{
public:
  Hdf5Handle(hid_t id, herr_t (*close)(hid_t))
    : Id(id)
    , Close(close)
  {
  }
  ~Hdf5Handle()
  {
    if (this->Id >= 0)
      this->Close(this->Id);
  }
  Hdf5Handle(const Hdf5Handle&) = delete;
  Hdf5Handle& operator=(const Hdf5Handle&) = delete;
  hid_t get() const { return this->Id; }
  bool valid() const { return this->Id >= 0; }
  hid_t release()
  {
    const hid_t id = this->Id;
    this->Id = -1;
    return id;
  }

private:
  hid_t Id;
  herr_t (*Close)(hid_t);
};

/// The plugin's HDF5 calls, one at a time (held by every function that calls HDF5).
std::recursive_mutex& Hdf5Mutex();

/// While it lives: the plugin's HDF5 lock held and HDF5's automatic error printing off (restored after).
class Hdf5Section
{
public:
  Hdf5Section();
  ~Hdf5Section();
  Hdf5Section(const Hdf5Section&) = delete;
  Hdf5Section& operator=(const Hdf5Section&) = delete;

private:
  std::lock_guard<std::recursive_mutex> Lock;
  H5E_auto2_t Function = nullptr;
  void* Data = nullptr;
};

/// The innermost message of HDF5's current error stack (": truncated file: eof = ..."), or an empty string.
std::string Hdf5LastError();

} // namespace vtkNeuralCompressInternals

#endif
