// Private to NeuralVolume::Filters: where a 3-D HDF5 dataset's samples lie in its file (.h5, .hdf5), for the
// out-of-core reader and Neural Compress (vtkNeuralOutOfCoreInput.h). A contiguous dataset without filters is a raw
// block of the file (H5Dget_offset): the engine's VolumeFileReader streams it with pread like any raw layout. A chunked
// dataset (compressed or not) is read by hyperslabs through the HDF5 library (vtkNeuralHdf5Chunks.h, the layout's
// boxSource). Compact datasets, filters the library cannot decode, other types and ranks are refused with the reason.
// Built with the HDF5 library ParaView's VTK uses (NV_HAVE_HDF5); without it an .h5 file gives one error saying so.
#ifndef vtkNeuralHdf5Layout_h
#define vtkNeuralHdf5Layout_h

#include "OutOfCore/VolumeFileLayout.h"

#include <string>

namespace vtkNeuralCompressInternals
{

/// True for the extensions read by ReadHdf5Layout (.h5, .hdf5).
bool IsHdf5Path(const std::string& path);

/// The layout of dataset `datasetPath` of `path` (empty: the first 3-D dataset of a supported type, depth first).
/// The dataset's dimensions are z, y, x (C order: x fastest); its geometry comes from the dataset's attributes
/// "spacing" and "origin" (3 numbers each, x first) when present, else 1 and 0. Throws nv::Error.
nv::VolumeFileLayout ReadHdf5Layout(const std::string& path, const std::string& datasetPath);

/// ReadHdf5Layout for .h5 / .hdf5 files, nv::readVolumeFileLayout for the others.
nv::VolumeFileLayout ReadOutOfCoreLayout(const std::string& path, const std::string& arrayName);

} // namespace vtkNeuralCompressInternals

#endif
