#include "vtkNeuralVolumeProxyObserver.h"

#include "vtkNeuralVolumeColorRange.h"
#include "vtkNeuralVolumePanel.h"

#include "vtkCommand.h"
#include "vtkDataObject.h"
#include "vtkDataSetAttributes.h"
#include "vtkObjectFactory.h"
#include "vtkPVArrayInformation.h"
#include "vtkPVDataInformation.h"
#include "vtkPVDataSetAttributesInformation.h"
#include "vtkPVGeneralSettings.h"
#include "vtkPVXMLElement.h"
#include "vtkSMEnumerationDomain.h"
#include "vtkSMPVRepresentationProxy.h"
#include "vtkSMProperty.h"
#include "vtkSMPropertyGroup.h"
#include "vtkSMPropertyHelper.h"
#include "vtkSMProxyIterator.h"
#include "vtkSMProxyManager.h"
#include "vtkSMProxySelectionModel.h"
#include "vtkSMSessionProxyManager.h"
#include "vtkSMSourceProxy.h"
#include "vtkSMTransferFunctionProxy.h"
#include "vtkSMViewProxy.h"
#include "vtkSmartPointer.h"
#include "vtkNew.h"
#include "vtkWeakPointer.h"

#include <cstdlib>
#include <cstring>
#include <map>
#include <set>
#include <vector>
#include <string>
#include <utility>

vtkStandardNewMacro(vtkNeuralVolumeProxyObserver);

namespace
{
const char* const kNeuralVolume = "Neural Volume";

bool IsNeuralVolume(vtkSMProxy* representation)
{
  vtkSMProperty* type = representation ? representation->GetProperty("Representation") : nullptr;
  const char* text = type ? vtkSMPropertyHelper(type).GetAsString() : nullptr;
  return text && std::strcmp(text, kNeuralVolume) == 0;
}

bool LoadingState(vtkSMProxy* proxy)
{
  vtkSMSessionProxyManager* pxm = proxy ? proxy->GetSessionProxyManager() : nullptr;
  return pxm && pxm->GetInLoadXMLState();
}

/// The network's array: the active scalars of the points, else of the cells, else the first point or cell array.
bool NetworkArray(vtkSMProxy* representation, std::string& name, int& association)
{
  vtkSMPropertyHelper input(representation, "Input", /*quiet=*/true);
  auto* producer = vtkSMSourceProxy::SafeDownCast(input.GetAsProxy());
  if (!producer)
  {
    return false;
  }
  vtkPVDataInformation* info = producer->GetDataInformation(input.GetOutputPort());
  if (!info)
  {
    return false;
  }
  const int associations[2] = { vtkDataObject::POINT, vtkDataObject::CELL };
  for (int a : associations)
  {
    vtkPVDataSetAttributesInformation* attributes = info->GetAttributeInformation(a);
    vtkPVArrayInformation* scalars =
      attributes ? attributes->GetAttributeInformation(vtkDataSetAttributes::SCALARS) : nullptr;
    if (scalars && scalars->GetName())
    {
      name = scalars->GetName();
      association = a;
      return true;
    }
  }
  // A Neural Compress output without a decoded field (OutputMode "Network only"): the array it compressed -- for a
  // file trained out of core (the Neural Out Of Core Reader upstream), the file's field.
  if (producer->GetXMLName() && std::strcmp(producer->GetXMLName(), "NeuralCompress") == 0)
  {
    auto* upstream = vtkSMSourceProxy::SafeDownCast(vtkSMPropertyHelper(producer, "Input", true).GetAsProxy());
    if (upstream && upstream->GetXMLName() && std::strcmp(upstream->GetXMLName(), "ZNeuralOutOfCoreReader") == 0)
    {
      upstream->UpdatePropertyInformation();
      vtkSMPropertyHelper field(upstream, "FieldName", /*quiet=*/true);
      const char* fieldName = field.GetNumberOfElements() >= 1 ? field.GetAsString(0) : nullptr;
      if (fieldName && *fieldName)
      {
        name = fieldName;
        association = vtkDataObject::POINT;
        return true;
      }
    }
    vtkSMPropertyHelper selected(producer, "SelectInputScalars", /*quiet=*/true);
    const char* selectedName = selected.GetNumberOfElements() >= 5 ? selected.GetAsString(4) : nullptr;
    if (selectedName && *selectedName)
    {
      name = selectedName;
      association = std::atoi(selected.GetAsString(3)) == vtkDataObject::FIELD_ASSOCIATION_CELLS ? vtkDataObject::CELL
                                                                                                 : vtkDataObject::POINT;
      return true;
    }
  }
  // A NeuralVolume file read without decoding: the array its networks represent.
  if (producer->GetXMLName() && std::strcmp(producer->GetXMLName(), "NeuralVolumeReader") == 0)
  {
    producer->UpdatePropertyInformation();
    vtkSMPropertyHelper array(producer, "ArrayName", /*quiet=*/true);
    const char* arrayName = array.GetNumberOfElements() >= 1 ? array.GetAsString(0) : nullptr;
    if (arrayName && *arrayName)
    {
      name = arrayName;
      association = vtkSMPropertyHelper(producer, "ArrayAssociation", true).GetAsInt() == 1 ? vtkDataObject::CELL
                                                                                              : vtkDataObject::POINT;
      return true;
    }
  }
  for (int a : associations)
  {
    vtkPVDataSetAttributesInformation* attributes = info->GetAttributeInformation(a);
    vtkPVArrayInformation* first =
      attributes && attributes->GetNumberOfArrays() > 0 ? attributes->GetArrayInformation(0) : nullptr;
    if (first && first->GetName())
    {
      name = first->GetName();
      association = a;
      return true;
    }
  }
  return false;
}
} // namespace

//------------------------------------------------------------------------------
namespace
{
/// The observers this helper added to proxies it does not own, by proxy. ParaView deletes its proxies when it ends
/// (and on a session reset) without an UnRegisterEvent, before this helper -- a static of the plugin -- is destroyed:
/// each proxy is held by a weak pointer, so that removing the observers never touches a deleted proxy (issue 29: a
/// SIGSEGV in RemoveObserver at the exit of pvbatch), and a new proxy at a deleted one's address is observed anew.
class ObservedProxies
{
public:
  ObservedProxies() = default;
  ObservedProxies(const ObservedProxies&) = delete;
  ObservedProxies& operator=(const ObservedProxies&) = delete;
  ~ObservedProxies() { this->RemoveAll(); }

  /// Whether `proxy` is observed (the entry of a deleted proxy at that address is dropped).
  bool Has(vtkSMProxy* proxy)
  {
    auto it = this->Entries.find(proxy);
    if (it != this->Entries.end() && !it->second.Proxy)
      this->Entries.erase(it);
    return this->Entries.count(proxy) != 0;
  }
  void Add(vtkSMProxy* proxy, std::vector<unsigned long> tags)
  {
    this->Remove(proxy);
    Entry& entry = this->Entries[proxy];
    entry.Proxy = proxy;
    entry.Tags = std::move(tags);
  }
  /// Removes the observers from `proxy` when it still exists, and forgets it.
  void Remove(vtkSMProxy* proxy)
  {
    auto it = this->Entries.find(proxy);
    if (it == this->Entries.end())
      return;
    if (vtkSMProxy* alive = it->second.Proxy)
      for (unsigned long tag : it->second.Tags)
        alive->RemoveObserver(tag);
    this->Entries.erase(it);
  }
  void RemoveAll()
  {
    while (!this->Entries.empty())
      this->Remove(this->Entries.begin()->first);
  }

private:
  struct Entry
  {
    vtkWeakPointer<vtkSMProxy> Proxy;
    std::vector<unsigned long> Tags;
  };
  std::map<vtkSMProxy*, Entry> Entries;
};
} // namespace

struct vtkNeuralVolumeProxyObserver::vtkInternals
{
  vtkWeakPointer<vtkSMProxyManager> Manager;
  unsigned long RegisterTag = 0;
  unsigned long UnRegisterTag = 0;
  ObservedProxies Representations; // PropertyModifiedEvent
  ObservedProxies Views;           // PropertyModifiedEvent, UpdateDataEvent
  ObservedProxies Sources;         // Neural Compress filters: UpdateDataEvent
  std::set<vtkSMProxy*> AwaitingView;  // shown as Neural Volume before joining their view
  std::set<vtkSMProxy*> AwaitingRange; // coloured while the network had no usable range (constant or empty)
  /// Views registered but not yet given representations, with the view that was active before them (a view
  /// registered by ParaView becomes the active one).
  std::map<vtkSMProxy*, vtkWeakPointer<vtkSMProxy>> NewViews;
};

vtkNeuralVolumeProxyObserver::vtkNeuralVolumeProxyObserver()
  : Internals(new vtkInternals)
{
}

vtkNeuralVolumeProxyObserver::~vtkNeuralVolumeProxyObserver()
{
  vtkInternals& in = *this->Internals;
  for (ObservedProxies* observed : { &in.Representations, &in.Views, &in.Sources })
    observed->RemoveAll();
  if (in.Manager)
  {
    in.Manager->RemoveObserver(in.RegisterTag);
    in.Manager->RemoveObserver(in.UnRegisterTag);
  }
}

//------------------------------------------------------------------------------
void vtkNeuralVolumeProxyObserver::Install()
{
  vtkInternals& in = *this->Internals;
  if (in.Manager || !vtkSMProxyManager::IsInitialized())
  {
    return;
  }
  vtkSMProxyManager* manager = vtkSMProxyManager::GetProxyManager();
  in.Manager = manager;
  in.RegisterTag = manager->AddObserver(vtkCommand::RegisterEvent, this, &vtkNeuralVolumeProxyObserver::OnRegister);
  in.UnRegisterTag =
    manager->AddObserver(vtkCommand::UnRegisterEvent, this, &vtkNeuralVolumeProxyObserver::OnUnRegister);

  // Proxies registered before the plugin was loaded.
  if (vtkSMSessionProxyManager* pxm = manager->GetActiveSessionProxyManager())
  {
    vtkNew<vtkSMProxyIterator> it;
    it->SetSessionProxyManager(pxm);
    for (it->Begin(); !it->IsAtEnd(); it->Next())
    {
      this->AddProxy(it->GetGroup(), it->GetProxy(), /*registering=*/false);
    }
  }
}

void vtkNeuralVolumeProxyObserver::AddProxy(const char* group, vtkSMProxy* proxy, bool registering)
{
  if (!group || !proxy)
  {
    return;
  }
  if (std::strcmp(group, "views") == 0)
    this->AddView(proxy, registering);
  else if (std::strcmp(group, "representations") == 0)
    this->AddRepresentation(proxy);
  else if (std::strcmp(group, "sources") == 0)
    this->AddSource(proxy);
}

void vtkNeuralVolumeProxyObserver::OnRegister(vtkObject*, unsigned long, void* data)
{
  auto* info = static_cast<vtkSMProxyManager::RegisteredProxyInformation*>(data);
  if (!info || info->Type != vtkSMProxyManager::RegisteredProxyInformation::PROXY || !info->Proxy)
  {
    return;
  }
  this->AddProxy(info->GroupName, info->Proxy, /*registering=*/true);
}

void vtkNeuralVolumeProxyObserver::OnUnRegister(vtkObject*, unsigned long, void* data)
{
  auto* info = static_cast<vtkSMProxyManager::RegisteredProxyInformation*>(data);
  if (!info || info->Type != vtkSMProxyManager::RegisteredProxyInformation::PROXY || !info->Proxy)
  {
    return;
  }
  vtkInternals& in = *this->Internals;
  for (ObservedProxies* observed : { &in.Representations, &in.Views, &in.Sources })
    observed->Remove(info->Proxy);
  in.AwaitingView.erase(info->Proxy);
  in.AwaitingRange.erase(info->Proxy);
  in.NewViews.erase(info->Proxy);
}

//------------------------------------------------------------------------------
void vtkNeuralVolumeProxyObserver::AddRepresentation(vtkSMProxy* representation)
{
  vtkInternals& in = *this->Internals;
  const char* xmlName = representation->GetXMLName();
  if (!xmlName || std::strcmp(xmlName, "UniformGridRepresentation") != 0 ||
    in.Representations.Has(representation))
  {
    return;
  }
  vtkNeuralVolumePanel::Adapt(representation);
  in.Representations.Add(representation, { representation->AddObserver(vtkCommand::PropertyModifiedEvent, this,
                                              &vtkNeuralVolumeProxyObserver::OnRepresentationModified) });
  // Show() picks the representation type before registering the representation and adds it to its view
  // afterwards: colour once it is in the view.
  if (IsNeuralVolume(representation) && !LoadingState(representation) && !this->Color(representation, nullptr))
  {
    in.AwaitingView.insert(representation);
  }
}

void vtkNeuralVolumeProxyObserver::AddView(vtkSMProxy* view, bool registering)
{
  vtkInternals& in = *this->Internals;
  if (!vtkSMViewProxy::SafeDownCast(view) || in.Views.Has(view))
  {
    return;
  }
  // A view's update (a time step, a re-execution) runs before its render and before ParaView's automatic rescaling.
  in.Views.Add(view,
    { view->AddObserver(vtkCommand::PropertyModifiedEvent, this, &vtkNeuralVolumeProxyObserver::OnViewModified),
      view->AddObserver(vtkCommand::UpdateDataEvent, this, &vtkNeuralVolumeProxyObserver::OnViewUpdated) });
  vtkSMSessionProxyManager* pxm = view->GetSessionProxyManager();
  vtkSMProxySelectionModel* active = pxm ? pxm->GetSelectionModel("ActiveView") : nullptr;
  if (registering && active && !LoadingState(view))
  {
    in.NewViews[view] = active->GetCurrentProxy();
  }
}

void vtkNeuralVolumeProxyObserver::AddSource(vtkSMProxy* source)
{
  vtkInternals& in = *this->Internals;
  const char* xmlName = source->GetXMLName();
  if (!xmlName || std::strcmp(xmlName, "NeuralCompress") != 0 || in.Sources.Has(source))
  {
    return;
  }
  in.Sources.Add(
    source, { source->AddObserver(vtkCommand::UpdateDataEvent, this, &vtkNeuralVolumeProxyObserver::OnSourceUpdated) });
}

void vtkNeuralVolumeProxyObserver::OnSourceUpdated(vtkObject* caller, unsigned long, void*)
{
  // The panel reads information properties after Apply only: refresh the training status (and the steps) on every
  // re-execution, so that the panel follows a background training (ParaView's live-source timer updates the view).
  auto* source = vtkSMProxy::SafeDownCast(caller);
  for (const char* name : { "TrainingStatus", "TotalStepsTrained" })
  {
    if (vtkSMProperty* property = source ? source->GetProperty(name) : nullptr)
    {
      source->UpdatePropertyInformation(property);
    }
  }
}

void vtkNeuralVolumeProxyObserver::OnRepresentationModified(vtkObject* caller, unsigned long, void* name)
{
  auto* representation = vtkSMProxy::SafeDownCast(caller);
  const char* property = static_cast<const char*>(name);
  if (!representation || !property || std::strcmp(property, "Representation") != 0 ||
    LoadingState(representation))
  {
    return;
  }
  if (IsNeuralVolume(representation) && !this->Color(representation, nullptr))
  {
    this->Internals->AwaitingView.insert(representation);
  }
}

void vtkNeuralVolumeProxyObserver::OnViewUpdated(vtkObject* caller, unsigned long, void*)
{
  auto* view = vtkSMProxy::SafeDownCast(caller);
  if (!view || !view->GetProperty("Representations"))
  {
    return;
  }
  vtkSMPropertyHelper members(view, "Representations");
  std::vector<vtkSMProxy*> representations;
  for (unsigned int i = 0; i < members.GetNumberOfElements(); ++i)
  {
    vtkSMProxy* representation = members.GetAsProxy(i);
    if (representation && this->Internals->Representations.Has(representation))
    {
      representations.push_back(representation);
    }
  }
  for (vtkSMProxy* representation : representations)
  {
    this->FitUnsetRange(representation);
  }
}

void vtkNeuralVolumeProxyObserver::FitUnsetRange(vtkSMProxy* representation)
{
  vtkInternals& in = *this->Internals;
  if (!LoadingState(representation) && IsNeuralVolume(representation) &&
    vtkSMPropertyHelper(representation, "Visibility", true).GetAsInt() != 0 &&
    vtkNeuralVolumeColorRange::FitUnsetRange(representation, in.AwaitingRange.count(representation) != 0))
  {
    in.AwaitingRange.erase(representation);
  }
}

void vtkNeuralVolumeProxyObserver::OnViewModified(vtkObject* caller, unsigned long, void* name)
{
  vtkInternals& in = *this->Internals;
  auto* view = vtkSMProxy::SafeDownCast(caller);
  const char* property = static_cast<const char*>(name);
  if (!view || !property || std::strcmp(property, "Representations") != 0)
  {
    return;
  }
  auto created = in.NewViews.find(view);
  if (created != in.NewViews.end())
  {
    vtkSMProxy* previous = created->second;
    in.NewViews.erase(created);
    this->KeepActiveView(view, previous);
  }
  if (in.AwaitingView.empty())
  {
    return;
  }
  vtkSMPropertyHelper members(view, "Representations");
  for (unsigned int i = 0; i < members.GetNumberOfElements(); ++i)
  {
    vtkSMProxy* representation = members.GetAsProxy(i);
    if (in.AwaitingView.erase(representation) && !LoadingState(representation))
    {
      this->Color(representation, view);
    }
  }
}

void vtkNeuralVolumeProxyObserver::KeepActiveView(vtkSMProxy* view, vtkSMProxy* previous)
{
  // A training log shown in a chart that ParaView created for it (the filter's first Apply opens one per filter):
  // the chart is a side view. The view that was active stays active, so that the next filter's output and the eye
  // of the pipeline browser go to the render view, not into the chart.
  vtkSMPropertyHelper members(view, "Representations");
  bool trainingLog = false;
  for (unsigned int i = 0; i < members.GetNumberOfElements(); ++i)
  {
    vtkSMProxy* representation = members.GetAsProxy(i);
    const char* xmlName = representation ? representation->GetXMLName() : nullptr;
    trainingLog = trainingLog || (xmlName && std::strcmp(xmlName, "NeuralTrainingLogChartRepresentation") == 0);
  }
  vtkSMSessionProxyManager* pxm = view->GetSessionProxyManager();
  vtkSMProxySelectionModel* active = pxm ? pxm->GetSelectionModel("ActiveView") : nullptr;
  if (trainingLog && previous && active && active->GetCurrentProxy() == view &&
    pxm->GetProxyName("views", previous))
  {
    active->SetCurrentProxy(previous, vtkSMProxySelectionModel::CLEAR_AND_SELECT);
  }
}

//------------------------------------------------------------------------------
bool vtkNeuralVolumeProxyObserver::Color(vtkSMProxy* representation, vtkSMProxy* view)
{
  bool rangeFound = false;
  if (!ColorByNetwork(representation, view, &rangeFound))
  {
    return false;
  }
  if (rangeFound)
    this->Internals->AwaitingRange.erase(representation);
  else
    this->Internals->AwaitingRange.insert(representation);
  return true;
}

bool vtkNeuralVolumeProxyObserver::ColorByNetwork(vtkSMProxy* representation, vtkSMProxy* view, bool* rangeFound)
{
  if (rangeFound)
  {
    *rangeFound = false;
  }
  if (!IsNeuralVolume(representation) || vtkSMPVRepresentationProxy::GetUsingScalarColoring(representation))
  {
    return false;
  }
  view = view ? view : vtkSMViewProxy::FindView(representation);
  if (!view)
  {
    return false; // colour with the colour bar once the representation is in its view
  }
  std::string array;
  int association = vtkDataObject::POINT;
  if (!NetworkArray(representation, array, association) ||
    !vtkSMPVRepresentationProxy::SetScalarColoring(representation, array.c_str(), association))
  {
    return false;
  }
  // As if the user picked the array: fit the maps to its range (vtkNeuralVolumeColorRange.h).
  const bool fitted = vtkNeuralVolumeColorRange::FitToNetwork(representation);
  if (rangeFound)
  {
    *rangeFound = fitted;
  }
  // The GUI's default; scripts (pvpython, pvbatch) run with manual colour bars, as for the stock Volume.
  if (vtkPVGeneralSettings::GetInstance()->GetScalarBarMode() ==
    vtkPVGeneralSettings::AUTOMATICALLY_SHOW_AND_HIDE_SCALAR_BARS)
  {
    vtkSMPVRepresentationProxy::SetScalarBarVisibility(representation, view, true);
  }
  return true;
}
