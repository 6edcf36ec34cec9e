// Private to NeuralVolume::Representations: the properties panel of an image's representation adapted for Neural
// Volume -- the stock groups and properties it does not use hidden while it is the chosen representation (visibility
// decorators), the Volume Rendering group shown for it, the scattering anisotropy shown for path tracing, and the
// blend modes the engine renders added to the list.
#include "vtkNeuralVolumePanel.h"

#include "vtkPVXMLElement.h"
#include "vtkSMEnumerationDomain.h"
#include "vtkSMProperty.h"
#include "vtkSMPropertyGroup.h"
#include "vtkSMProxy.h"
#include "vtkSmartPointer.h"

#include <cstring>
#include <string>

namespace
{
const char* const kNeuralVolume = "Neural Volume";

/// Panel groups of the stock representation whose properties do nothing for a network (surface styling, scalar
/// mapping of polygons, ray-tracing materials, miscellaneous polygon settings): hidden as a whole for Neural Volume.
const char* const kGroupsUnusedByNeuralVolume[] = { "Scalar Coloring", "Styling", "Edge Styling",
  "Backface Styling", "Miscellaneous", "Ray Tracing" };

/// Properties of the groups Neural Volume shows that it does not use: in "Volume Rendering" the 2D transfer
/// functions, separate opacity arrays, the stock mappers' modes and scattering model, isosurface and slice
/// blending and cropping; in "Transforming" the coordinate shift. In "Lighting" everything but kLightingUsed.
const char* const kUnusedByNeuralVolume[] = { "TransferFunction2D", "UseSeparateOpacityArray",
  "OpacityArrayName", "OpacityComponent", "UseTransfer2D", "UseGradientForTransfer2D", "ColorArray2Name",
  "ColorArray2Component", "VolumeRenderingMode", "GlobalIlluminationReach", "VolumetricScatteringBlending",
  "IsosurfaceValues", "SliceFunction", "UseCropping", "CoordinateShiftScaleMethod" };
const char* const kLightingUsed[] = { "Ambient", "Diffuse", "Specular", "SpecularPower" };

/// Blend modes of vtkVolumeMapper that the engine renders and ParaView 5.11 does not list.
const struct
{
  const char* Text;
  int Value;
} kEngineBlendModes[] = { { "Maximum Intensity", 1 }, { "Minimum Intensity", 2 }, { "Average Intensity", 3 },
  { "Additive", 4 } };


vtkSmartPointer<vtkPVXMLElement> VisibilityDecorator(const char* property, const char* value, bool inverse)
{
  auto e = vtkSmartPointer<vtkPVXMLElement>::New();
  e->SetName("PropertyWidgetDecorator");
  e->AddAttribute("type", "GenericDecorator");
  e->AddAttribute("mode", "visibility");
  e->AddAttribute("property", property);
  e->AddAttribute("value", value);
  if (inverse)
  {
    e->AddAttribute("inverse", "1");
  }
  return e;
}

/// True when `parent` has a direct GenericDecorator child on Representation == Neural Volume.
bool HasNeuralDecorator(vtkPVXMLElement* parent)
{
  for (unsigned int i = 0; parent && i < parent->GetNumberOfNestedElements(); ++i)
  {
    vtkPVXMLElement* e = parent->GetNestedElement(i);
    const char* property = e->GetAttribute("property");
    const char* value = e->GetAttribute("value");
    if (property && value && std::strcmp(property, "Representation") == 0 &&
      std::strcmp(value, kNeuralVolume) == 0)
    {
      return true;
    }
  }
  return false;
}

/// The stock group's decorator is "Representation is Volume or NVIDIA IndeX": add Neural Volume to the "or".
void ShowVolumeRenderingGroup(vtkSMProxy* representation)
{
  for (size_t g = 0; g < representation->GetNumberOfPropertyGroups(); ++g)
  {
    vtkSMPropertyGroup* group = representation->GetPropertyGroup(g);
    const char* label = group ? group->GetXMLLabel() : nullptr;
    vtkPVXMLElement* hints = group ? group->GetHints() : nullptr;
    if (!label || std::strcmp(label, "Volume Rendering") != 0 || !hints)
    {
      continue;
    }
    for (unsigned int i = 0; i < hints->GetNumberOfNestedElements(); ++i)
    {
      vtkPVXMLElement* decorator = hints->GetNestedElement(i);
      const char* type = decorator->GetAttribute("type");
      vtkPVXMLElement* expression = decorator->FindNestedElementByName("Expression");
      const char* op = expression ? expression->GetAttribute("type") : nullptr;
      if (type && std::strcmp(type, "CompositeDecorator") == 0 && op && std::strcmp(op, "or") == 0 &&
        !HasNeuralDecorator(expression))
      {
        expression->AddNestedElement(VisibilityDecorator("Representation", kNeuralVolume, false));
      }
    }
  }
}

/// The Hints element of a property or property group, created when it has none.
template <typename T>
vtkPVXMLElement* HintsOf(T* owner)
{
  if (!owner->GetHints())
  {
    auto created = vtkSmartPointer<vtkPVXMLElement>::New();
    created->SetName("Hints");
    owner->SetHints(created);
  }
  return owner->GetHints();
}

/// Hide a whole panel group while the representation is Neural Volume (every decorator must agree to show a
/// widget, so this one adds to the group's own).
void HideGroupForNeuralVolume(vtkSMPropertyGroup* group)
{
  vtkPVXMLElement* hints = HintsOf(group);
  if (!HasNeuralDecorator(hints))
  {
    hints->AddNestedElement(VisibilityDecorator("Representation", kNeuralVolume, true));
  }
}

bool Contains(const char* const* list, size_t n, const char* name)
{
  for (size_t i = 0; i < n; ++i)
    if (name && std::strcmp(list[i], name) == 0)
      return true;
  return false;
}

/// Hide a property's widget while the representation is Neural Volume.
void HideForNeuralVolume(vtkSMProperty* property)
{
  vtkPVXMLElement* hints = HintsOf(property);
  if (!HasNeuralDecorator(hints))
  {
    hints->AddNestedElement(VisibilityDecorator("Representation", kNeuralVolume, true));
  }
}

/// VolumeAnisotropy (Henyey-Greenstein g) matters to Neural Volume only when path tracing.
void ShowAnisotropyForPathTracing(vtkSMProperty* property)
{
  vtkPVXMLElement* hints = HintsOf(property);
  for (unsigned int i = 0; i < hints->GetNumberOfNestedElements(); ++i)
  {
    const char* marker = hints->GetNestedElement(i)->GetAttribute("neural_volume");
    if (marker)
    {
      return;
    }
  }
  auto composite = vtkSmartPointer<vtkPVXMLElement>::New();
  composite->SetName("PropertyWidgetDecorator");
  composite->AddAttribute("type", "CompositeDecorator");
  composite->AddAttribute("neural_volume", "1");
  auto any = vtkSmartPointer<vtkPVXMLElement>::New();
  any->SetName("Expression");
  any->AddAttribute("type", "or");
  any->AddNestedElement(VisibilityDecorator("Representation", kNeuralVolume, true));
  any->AddNestedElement(VisibilityDecorator("ShadingMode", "3", false));
  any->AddNestedElement(VisibilityDecorator("ShadingMode", "4", false));
  composite->AddNestedElement(any);
  hints->AddNestedElement(composite);
}

void AddEngineBlendModes(vtkSMProxy* representation)
{
  vtkSMProperty* blend = representation->GetProperty("BlendMode");
  auto* domain = blend ? blend->FindDomain<vtkSMEnumerationDomain>() : nullptr;
  if (!domain)
  {
    return;
  }
  for (const auto& mode : kEngineBlendModes)
  {
    unsigned int index = 0;
    if (!domain->HasEntryText(mode.Text) && !domain->IsInDomain(mode.Value, index))
    {
      domain->AddEntry(mode.Text, mode.Value);
    }
  }
}

} // namespace

namespace vtkNeuralVolumePanel
{
void Adapt(vtkSMProxy* representation)
{
  ShowVolumeRenderingGroup(representation);
  for (size_t g = 0; g < representation->GetNumberOfPropertyGroups(); ++g)
  {
    vtkSMPropertyGroup* group = representation->GetPropertyGroup(g);
    const char* label = group ? group->GetXMLLabel() : nullptr;
    if (!label)
    {
      continue;
    }
    if (Contains(kGroupsUnusedByNeuralVolume, sizeof(kGroupsUnusedByNeuralVolume) / sizeof(char*), label))
    {
      HideGroupForNeuralVolume(group);
    }
    else if (std::strcmp(label, "Lighting") == 0)
    {
      for (unsigned int i = 0; i < group->GetNumberOfProperties(); ++i)
      {
        if (!Contains(kLightingUsed, sizeof(kLightingUsed) / sizeof(char*), group->GetPropertyName(i)))
        {
          HideForNeuralVolume(group->GetProperty(i));
        }
      }
    }
  }
  for (const char* name : kUnusedByNeuralVolume)
  {
    if (vtkSMProperty* property = representation->GetProperty(name))
    {
      HideForNeuralVolume(property);
    }
  }
  if (vtkSMProperty* anisotropy = representation->GetProperty("VolumeAnisotropy"))
  {
    ShowAnisotropyForPathTracing(anisotropy);
  }
  AddEngineBlendModes(representation);
}
} // namespace vtkNeuralVolumePanel
