// Private to NeuralVolume::Representations: what vtkNeuralVolumeMapper reads from VTK's render state (renderer,
// camera, lights, volume, volume property) to fill an nv::RenderRequest. Free functions, no state.
#ifndef vtkNeuralRenderRequest_h
#define vtkNeuralRenderRequest_h

#include "Core/Model.h"
#include "Core/Render.h"

#include <memory>
#include <string>

class vtkImageData;
class vtkRenderer;
class vtkVolume;
class vtkVolumeProperty;

namespace vtkNeuralRenderRequest
{

/// World -> clip matrix (row-major, OpenGL NDC) of the renderer's active camera for its tiled viewport: the matrix
/// VTK itself rendered the opaque geometry with, so that depth values and volume samples agree.
void ViewProjection(vtkRenderer* ren, double out[16]);

/// World -> network coordinates [0,1]^3: the inverse of the volume's matrix, the image's direction about its
/// origin, then the trained field's bounds (an axis with one sample gets one voxel of thickness around it).
/// False (and a message) when the transform is singular.
bool WorldToUnit(vtkVolume* volume, vtkImageData* image, const nv::SourceInfo& source, double out[16],
  std::string& message);

/// The box rays march in network coordinates: [0,1]^3, or under MPI (a network trained on a rank's piece with
/// ghost layers around it) the piece's own bounds -- field data NeuralPieceBounds, in the image's index-aligned
/// frame -- so that neighbouring ranks' pictures meet without overlap.
void PieceClipBox(vtkImageData* image, const nv::SourceInfo& source, double clip[6]);

/// MPI: the coarse grid of the whole field that Neural Compress gave every rank's piece (field data
/// NeuralSurroundings, NeuralSurroundingsDimensions, NeuralSurroundingsBounds in the image's index-aligned frame;
/// Filters/Inputs/vtkNeuralCompressSurroundings.h), placed in network coordinates (the network's source bounds map to
/// [0,1]^3): the engine's secondary rays continue through it beyond the piece. Null when the image has none.
std::shared_ptr<const nv::SurroundingsGrid> PieceSurroundings(vtkImageData* image, const nv::SourceInfo& source);

/// The colour and scalar opacity functions of component 0 sampled into `entries` uniform entries over the union
/// of their ranges, with the property's scalar opacity unit distance.
void SampleTransferFunction(vtkVolumeProperty* property, int entries, nv::TransferFunction& tf);

/// Direction towards the renderer's first switched-on light in world space (ParaView's light kit puts its key
/// light first); the camera's direction towards the viewer when no light is on. Returns false in that case.
bool ViewLightDirection(vtkRenderer* ren, double direction[3]);

/// True when the renderer shows opaque geometry besides the volumes (a visible 3D prop other than a vtkVolume):
/// only then can something in the depth buffer hide part of `volume`.
bool ShowsOpaqueGeometry(vtkRenderer* ren, vtkVolume* volume);

} // namespace vtkNeuralRenderRequest

#endif
