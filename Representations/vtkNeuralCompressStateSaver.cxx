#include "vtkNeuralCompressStateSaver.h"

#include "vtkCommand.h"
#include "vtkNew.h"
#include "vtkObjectFactory.h"
#include "vtkPVXMLElement.h"
#include "vtkSMPropertyHelper.h"
#include "vtkSMProxy.h"
#include "vtkSMProxyIterator.h"
#include "vtkSMProxyManager.h"
#include "vtkSMSessionProxyManager.h"

#include <cstring>
#include <map>
#include <string>

vtkStandardNewMacro(vtkNeuralCompressStateSaver);

vtkNeuralCompressStateSaver::~vtkNeuralCompressStateSaver()
{
  if (this->Tag && vtkSMProxyManager::IsInitialized())
  {
    vtkSMProxyManager::GetProxyManager()->RemoveObserver(this->Tag);
  }
}

void vtkNeuralCompressStateSaver::Install()
{
  if (this->Tag || !vtkSMProxyManager::IsInitialized())
  {
    return;
  }
  // Session proxy managers forward their events through the global one.
  this->Tag = vtkSMProxyManager::GetProxyManager()->AddObserver(
    vtkCommand::SaveStateEvent, this, &vtkNeuralCompressStateSaver::OnSaveState);
}

namespace
{
/// The <Property name="..."> element of a proxy's state element.
vtkPVXMLElement* PropertyElement(vtkPVXMLElement* proxyElement, const char* name)
{
  for (unsigned int i = 0; i < proxyElement->GetNumberOfNestedElements(); ++i)
  {
    vtkPVXMLElement* child = proxyElement->GetNestedElement(i);
    const char* n = child->GetAttribute("name");
    if (child->GetName() && std::strcmp(child->GetName(), "Property") == 0 && n && std::strcmp(n, name) == 0)
    {
      return child;
    }
  }
  return nullptr;
}

void CollectProxyElements(vtkPVXMLElement* element, std::map<std::string, vtkPVXMLElement*>& byId)
{
  if (!element)
    return;
  const char* type = element->GetAttribute("type");
  const char* id = element->GetAttribute("id");
  if (element->GetName() && std::strcmp(element->GetName(), "Proxy") == 0 && type &&
    std::strcmp(type, "NeuralCompress") == 0 && id)
  {
    byId[id] = element;
  }
  for (unsigned int i = 0; i < element->GetNumberOfNestedElements(); ++i)
    CollectProxyElements(element->GetNestedElement(i), byId);
}
} // namespace

void vtkNeuralCompressStateSaver::OnSaveState(vtkObject*, unsigned long, void* data)
{
  auto* info = static_cast<vtkSMProxyManager::LoadStateInformation*>(data);
  if (!info || !info->RootElement)
  {
    return;
  }
  std::map<std::string, vtkPVXMLElement*> elements;
  CollectProxyElements(info->RootElement, elements);
  if (elements.empty())
  {
    return;
  }
  vtkSMSessionProxyManager* pxm = vtkSMProxyManager::GetProxyManager()->GetActiveSessionProxyManager();
  if (!pxm)
  {
    return;
  }
  vtkNew<vtkSMProxyIterator> it;
  it->SetSessionProxyManager(pxm);
  it->SetModeToOneGroup();
  for (it->Begin("sources"); !it->IsAtEnd(); it->Next())
  {
    vtkSMProxy* proxy = it->GetProxy();
    if (!proxy || !proxy->GetXMLName() || std::strcmp(proxy->GetXMLName(), "NeuralCompress") != 0)
      continue;
    auto found = elements.find(std::to_string(proxy->GetGlobalID()));
    vtkPVXMLElement* property = found == elements.end() ? nullptr : PropertyElement(found->second, "TrainedNetworks");
    if (!property)
      continue;
    proxy->UpdatePropertyInformation(proxy->GetProperty("TrainedNetworksInfo"));
    const char* networks = vtkSMPropertyHelper(proxy, "TrainedNetworksInfo").GetAsString(0);
    vtkPVXMLElement* value = property->FindNestedElementByName("Element");
    if (!value)
    {
      vtkNew<vtkPVXMLElement> element;
      element->SetName("Element");
      element->AddAttribute("index", "0");
      property->AddNestedElement(element);
      value = element;
      property->SetAttribute("number_of_elements", "1");
    }
    value->SetAttribute("value", networks ? networks : "");
  }
}
