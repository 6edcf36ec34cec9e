#include "vtkNeuralVolumeColorRange.h"

#include "vtkPVArrayInformation.h"
#include "vtkPVDataInformation.h"
#include "vtkPVDataSetAttributesInformation.h"
#include "vtkSMCoreUtilities.h"
#include "vtkSMPVRepresentationProxy.h"
#include "vtkSMPropertyHelper.h"
#include "vtkSMSourceProxy.h"
#include "vtkSMTransferFunctionManager.h"
#include "vtkSMTransferFunctionProxy.h"

#include <algorithm>
#include <cfloat>
#include <cmath>

//------------------------------------------------------------------------------
bool vtkNeuralVolumeColorRange::NetworkValueRange(vtkSMProxy* representation, double range[2])
{
  vtkSMPropertyHelper input(representation, "Input", /*quiet=*/true);
  auto* producer = vtkSMSourceProxy::SafeDownCast(input.GetAsProxy());
  vtkPVDataInformation* info = producer ? producer->GetDataInformation(input.GetOutputPort()) : nullptr;
  vtkPVDataSetAttributesInformation* fields = info ? info->GetFieldDataInformation() : nullptr;
  vtkPVArrayInformation* values = fields ? fields->GetArrayInformation("NeuralValueRange") : nullptr;
  if (!values)
  {
    return false;
  }
  values->GetComponentRange(0, range);
  return std::isfinite(range[0]) && std::isfinite(range[1]) && range[0] <= range[1];
}

bool vtkNeuralVolumeColorRange::Degenerate(const double range[2])
{
  if (!(range[0] <= range[1]) || !std::isfinite(range[1] - range[0]))
  {
    return true; // also a range wider than the largest double, which ParaView 5.11 cannot rescale a map to
  }
  const double magnitude = std::max(std::fabs(range[0]), std::fabs(range[1]));
  return range[1] - range[0] <= std::max(4096.0 * FLT_EPSILON * magnitude, 1e-30);
}

bool vtkNeuralVolumeColorRange::ColorArrayRange(vtkSMProxy* representation, double range[2])
{
  vtkPVArrayInformation* info = vtkSMPVRepresentationProxy::GetArrayInformationForColorArray(representation);
  vtkSMProxy* lut = vtkSMPropertyHelper(representation, "LookupTable", /*quiet=*/true).GetAsProxy();
  int component = -1;
  if (lut && vtkSMPropertyHelper(lut, "VectorMode", true).GetAsInt() != 0)
  {
    component = vtkSMPropertyHelper(lut, "VectorComponent", true).GetAsInt();
  }
  if (!info || component >= info->GetNumberOfComponents())
  {
    return false;
  }
  info->GetComponentFiniteRange(component, range);
  return range[0] <= range[1];
}

//------------------------------------------------------------------------------
bool vtkNeuralVolumeColorRange::FitToNetwork(vtkSMProxy* representation)
{
  double range[2];
  if (ColorArrayRange(representation, range))
  {
    vtkSMPVRepresentationProxy::RescaleTransferFunctionToDataRange(representation, true);
    return !Degenerate(range);
  }
  if (!NetworkValueRange(representation, range))
  {
    return false;
  }
  vtkSMCoreUtilities::AdjustRange(range);
  if (!std::isfinite(range[1] - range[0]))
  {
    return false; // ParaView 5.11 aborts on a map over such a range (the representation refuses the network)
  }
  vtkSMPropertyHelper lut(representation, "LookupTable", /*quiet=*/true);
  if (vtkSMProxy* colors = lut.GetAsProxy())
  {
    vtkSMTransferFunctionProxy::RescaleTransferFunction(colors, range);
    vtkSMPropertyHelper opacity(colors, "ScalarOpacityFunction", /*quiet=*/true);
    if (opacity.GetAsProxy())
      vtkSMTransferFunctionProxy::RescaleTransferFunction(opacity.GetAsProxy(), range);
  }
  return !Degenerate(range);
}

bool vtkNeuralVolumeColorRange::FitUnsetRange(vtkSMProxy* representation, bool awaiting)
{
  // A map fitted to a time step without a usable range (constant: a single value widened by a few float steps;
  // empty: none) maps no later value: every later step would be blank, whatever the automatic rescale mode.
  if (!vtkSMPVRepresentationProxy::GetUsingScalarColoring(representation))
  {
    return false;
  }
  vtkSMProxy* lut = vtkSMPropertyHelper(representation, "LookupTable", /*quiet=*/true).GetAsProxy();
  double current[2], data[2];
  if (!lut ||
    vtkSMPropertyHelper(lut, "AutomaticRescaleRangeMode", true).GetAsInt() == vtkSMTransferFunctionManager::NEVER ||
    !vtkSMTransferFunctionProxy::GetRange(lut, current))
  {
    return false;
  }
  if ((awaiting || Degenerate(current)) && ColorArrayRange(representation, data) && !Degenerate(data))
  {
    return vtkSMPVRepresentationProxy::RescaleTransferFunctionToDataRange(
      representation, /*extend=*/false, /*force=*/false);
  }
  return false;
}
