#include "vtkNeuralRenderRequest.h"

#include "Core/ValueRange.h"

#include "vtkCamera.h"
#include "vtkColorTransferFunction.h"
#include "vtkDataArray.h"
#include "vtkFieldData.h"
#include "vtkImageData.h"
#include "vtkLight.h"
#include "vtkLightCollection.h"
#include "vtkMath.h"
#include "vtkMatrix3x3.h"
#include "vtkMatrix4x4.h"
#include "vtkNew.h"
#include "vtkOpenGLCamera.h"
#include "vtkPiecewiseFunction.h"
#include "vtkProp.h"
#include "vtkPropCollection.h"
#include "vtkRenderer.h"
#include "vtkVolume.h"
#include "vtkVolumeProperty.h"

#include <algorithm>
#include <cmath>

namespace vtkNeuralRenderRequest
{

void ViewProjection(vtkRenderer* ren, double out[16])
{
  vtkCamera* camera = ren->GetActiveCamera();
  vtkNew<vtkMatrix4x4> m;
  if (auto* glCamera = vtkOpenGLCamera::SafeDownCast(camera))
  {
    // The key matrices are stored transposed for OpenGL: WCDC = (projection * view)^T.
    vtkMatrix4x4 *wcvc = nullptr, *vcdc = nullptr, *wcdc = nullptr;
    vtkMatrix3x3* normal = nullptr;
    glCamera->GetKeyMatrices(ren, wcvc, normal, vcdc, wcdc);
    vtkMatrix4x4::Transpose(wcdc, m);
  }
  else
  {
    m->DeepCopy(camera->GetCompositeProjectionTransformMatrix(ren->GetTiledAspectRatio(), -1, 1));
  }
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
      out[4 * r + c] = m->GetElement(r, c);
}

bool WorldToUnit(vtkVolume* volume, vtkImageData* image, const nv::SourceInfo& source, double out[16],
  std::string& message)
{
  // world -> model (the prop's own transform)
  vtkNew<vtkMatrix4x4> worldToModel;
  worldToModel->DeepCopy(volume->GetMatrix());
  if (worldToModel->Determinant() == 0.0)
  {
    message = "the volume's transform is singular (zero scale?)";
    return false;
  }
  worldToModel->Invert();

  // model -> index-aligned frame of the image: p = origin + D^-1 (x - origin)
  vtkNew<vtkMatrix4x4> modelToAligned;
  double origin[3] = { 0.0, 0.0, 0.0 };
  if (image)
  {
    image->GetOrigin(origin);
    vtkNew<vtkMatrix3x3> inverse;
    vtkMatrix3x3::Invert(image->GetDirectionMatrix(), inverse);
    for (int r = 0; r < 3; ++r)
    {
      double shift = origin[r];
      for (int c = 0; c < 3; ++c)
      {
        modelToAligned->SetElement(r, c, inverse->GetElement(r, c));
        shift -= inverse->GetElement(r, c) * origin[c];
      }
      modelToAligned->SetElement(r, 3, shift);
    }
  }

  // aligned -> [0,1]^3 over the trained field's bounds
  vtkNew<vtkMatrix4x4> alignedToUnit;
  for (int a = 0; a < 3; ++a)
  {
    double lo = source.bounds[2 * a], hi = source.bounds[2 * a + 1];
    if (!(hi > lo))
    {
      // One sample on this axis: it sits at the network coordinate 0.5, one voxel thick.
      const double half = 0.5 * (std::fabs(source.spacing[a]) > 0.0 ? std::fabs(source.spacing[a]) : 1.0);
      const double centre = 0.5 * (lo + hi);
      lo = centre - half;
      hi = centre + half;
    }
    alignedToUnit->SetElement(a, a, 1.0 / (hi - lo));
    alignedToUnit->SetElement(a, 3, -lo / (hi - lo));
  }

  vtkNew<vtkMatrix4x4> worldToAligned, result;
  vtkMatrix4x4::Multiply4x4(modelToAligned, worldToModel, worldToAligned);
  vtkMatrix4x4::Multiply4x4(alignedToUnit, worldToAligned, result);
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
    {
      out[4 * r + c] = result->GetElement(r, c);
      if (!std::isfinite(out[4 * r + c]))
      {
        message = "the volume transform is not finite";
        return false;
      }
    }
  return true;
}

void PieceClipBox(vtkImageData* image, const nv::SourceInfo& source, double clip[6])
{
  for (int a = 0; a < 3; ++a)
  {
    clip[2 * a] = 0.0;
    clip[2 * a + 1] = 1.0;
  }
  vtkDataArray* piece =
    image ? vtkDataArray::SafeDownCast(image->GetFieldData()->GetAbstractArray("NeuralPieceBounds")) : nullptr;
  if (!piece || piece->GetNumberOfValues() != 6)
    return;
  for (int a = 0; a < 3; ++a)
  {
    const double lo = source.bounds[2 * a], hi = source.bounds[2 * a + 1];
    if (!(hi > lo))
      continue; // one sample on this axis: the whole (one-voxel) box
    const double u0 = (piece->GetComponent(2 * a, 0) - lo) / (hi - lo);
    const double u1 = (piece->GetComponent(2 * a + 1, 0) - lo) / (hi - lo);
    if (std::isfinite(u0) && std::isfinite(u1) && u0 < u1 && u1 > 0.0 && u0 < 1.0)
    {
      clip[2 * a] = std::max(0.0, u0);
      clip[2 * a + 1] = std::min(1.0, u1);
    }
  }
}

std::shared_ptr<const nv::SurroundingsGrid> PieceSurroundings(vtkImageData* image, const nv::SourceInfo& source)
{
  vtkFieldData* fd = image ? image->GetFieldData() : nullptr;
  vtkDataArray* values = fd ? vtkDataArray::SafeDownCast(fd->GetAbstractArray("NeuralSurroundings")) : nullptr;
  vtkDataArray* dims = fd ? vtkDataArray::SafeDownCast(fd->GetAbstractArray("NeuralSurroundingsDimensions")) : nullptr;
  vtkDataArray* bounds = fd ? vtkDataArray::SafeDownCast(fd->GetAbstractArray("NeuralSurroundingsBounds")) : nullptr;
  if (!values || !dims || !bounds || dims->GetNumberOfValues() != 3 || bounds->GetNumberOfValues() != 6)
    return nullptr;
  auto grid = std::make_shared<nv::SurroundingsGrid>();
  grid->values.resize(static_cast<size_t>(values->GetNumberOfValues()));
  for (vtkIdType i = 0; i < values->GetNumberOfValues(); ++i)
    grid->values[static_cast<size_t>(i)] = static_cast<float>(values->GetComponent(i, 0));
  for (int a = 0; a < 3; ++a)
  {
    const double d = dims->GetComponent(a, 0);
    grid->dims[a] = std::isfinite(d) && d >= 0.0 && d <= 1e9 ? static_cast<int>(d) : 0; // the engine checks them
    const double lo = source.bounds[2 * a], hi = source.bounds[2 * a + 1];
    if (hi > lo)
    {
      grid->box[2 * a] = (bounds->GetComponent(2 * a, 0) - lo) / (hi - lo);
      grid->box[2 * a + 1] = (bounds->GetComponent(2 * a + 1, 0) - lo) / (hi - lo);
    }
    // else one sample on this axis: the network's one-voxel box is the whole's too ([0,1]).
  }
  return grid;
}

void SampleTransferFunction(vtkVolumeProperty* property, int entries, nv::TransferFunction& tf)
{
  vtkColorTransferFunction* color = property->GetRGBTransferFunction(0);
  vtkPiecewiseFunction* opacity = property->GetScalarOpacity(0);
  double lo = 0.0, hi = 1.0;
  bool have = false;
  auto unite = [&](const double r[2]) {
    if (!(r[1] >= r[0]))
      return;
    lo = have ? std::min(lo, r[0]) : r[0];
    hi = have ? std::max(hi, r[1]) : r[1];
    have = true;
  };
  if (color && color->GetSize() > 0)
    unite(color->GetRange());
  if (opacity && opacity->GetSize() > 0)
    unite(opacity->GetRange());
  if (!(hi > lo))
    hi = lo + 1.0;
  tf.valueMin = lo;
  tf.valueMax = hi;
  tf.unitDistance = property->GetScalarOpacityUnitDistance(0);
  tf.rgba.resize(static_cast<size_t>(entries) * 4);
  // Evaluated one value at a time (not GetTable, which samples logarithmically for log-scaled maps): the engine
  // expects entries uniform in value. A range wider than the largest double steps on halves (ValueRange.h).
  const nv::ValueRange range(lo, hi);
  for (int i = 0; i < entries; ++i)
  {
    const double v = range.denormalize(static_cast<double>(i) / static_cast<double>(entries - 1));
    double rgb[3] = { 1.0, 1.0, 1.0 };
    if (color)
      color->GetColor(v, rgb);
    const double a = opacity ? opacity->GetValue(v) : 1.0;
    float* e = tf.rgba.data() + 4 * i;
    for (int k = 0; k < 3; ++k)
      e[k] = static_cast<float>(rgb[k]);
    e[3] = static_cast<float>(a);
  }
}

bool ViewLightDirection(vtkRenderer* ren, double direction[3])
{
  vtkLightCollection* lights = ren->GetLights();
  vtkCollectionSimpleIterator it;
  lights->InitTraversal(it);
  while (vtkLight* light = lights->GetNextLight(it))
  {
    if (!light->GetSwitch() || light->GetIntensity() <= 0.0)
      continue;
    double p[3], f[3];
    light->GetTransformedPosition(p);
    light->GetTransformedFocalPoint(f);
    const double d[3] = { p[0] - f[0], p[1] - f[1], p[2] - f[2] };
    const double len = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    if (len > 0.0 && std::isfinite(len))
    {
      for (int k = 0; k < 3; ++k)
        direction[k] = d[k] / len;
      return true;
    }
  }
  // No light: light from the viewer.
  vtkCamera* camera = ren->GetActiveCamera();
  double dop[3];
  camera->GetDirectionOfProjection(dop);
  for (int k = 0; k < 3; ++k)
    direction[k] = -dop[k];
  return false;
}

//------------------------------------------------------------------------------
bool ShowsOpaqueGeometry(vtkRenderer* ren, vtkVolume* volume)
{
  vtkPropCollection* props = ren->GetViewProps();
  vtkCollectionSimpleIterator it;
  props->InitTraversal(it);
  while (vtkProp* prop = props->GetNextProp(it))
  {
    // Volumes (this one, others) write no depth; 2D props are drawn in the overlay, after the volumes.
    if (prop == volume || !prop->GetVisibility() || prop->IsA("vtkVolume") || prop->IsA("vtkActor2D"))
    {
      continue;
    }
    // A prop with no bounds draws nothing (ParaView keeps empty actors visible, e.g. a selection's).
    const double* bounds = prop->GetBounds();
    if (bounds && vtkMath::AreBoundsInitialized(bounds) && prop->HasOpaqueGeometry())
    {
      return true;
    }
  }
  return false;
}

} // namespace vtkNeuralRenderRequest
