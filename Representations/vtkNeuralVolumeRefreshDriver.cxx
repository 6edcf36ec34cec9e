#include "vtkNeuralVolumeRefreshDriver.h"

#include "vtkCommand.h"
#include "vtkNew.h"
#include "vtkObjectFactory.h"
#include "vtkPVNeuralVolumeInformation.h"
#include "vtkPVSession.h"
#include "vtkRenderWindowInteractor.h"
#include "vtkSMProperty.h"
#include "vtkSMPropertyHelper.h"
#include "vtkSMProxyIterator.h"
#include "vtkSMProxyManager.h"
#include "vtkSMSession.h"
#include "vtkSMSessionProxyManager.h"
#include "vtkSMViewProxy.h"
#include "vtkWeakPointer.h"

#include <algorithm>
#include <chrono>
#include <cstring>
#include <map>

vtkStandardNewMacro(vtkNeuralVolumeRefreshDriver);

namespace
{
bool IsNeuralVolume(vtkSMProxy* representation)
{
  const char* xmlName = representation ? representation->GetXMLName() : nullptr;
  vtkSMProperty* type = representation ? representation->GetProperty("Representation") : nullptr;
  const char* text = type ? vtkSMPropertyHelper(type).GetAsString() : nullptr;
  return xmlName && std::strcmp(xmlName, "UniformGridRepresentation") == 0 && text &&
    std::strcmp(text, "Neural Volume") == 0;
}

/// An interactor whose timers fire from an event loop that runs anyway (the GUI's).
bool DrivesTimers(vtkRenderWindowInteractor* interactor)
{
  return interactor && interactor->IsA("QVTKInteractor");
}
} // namespace

struct vtkNeuralVolumeRefreshDriver::vtkInternals
{
  struct View
  {
    /// ParaView deletes its views when it ends without an UnRegisterEvent, before this driver (a static of the
    /// plugin) is destroyed: held weakly, a deleted view is never touched (issue 29: a SIGSEGV in RemoveObserver at
    /// the exit of pvbatch), and a new view at a deleted one's address is observed anew.
    vtkWeakPointer<vtkSMProxy> Proxy;
    vtkWeakPointer<vtkRenderWindowInteractor> Interactor;
    unsigned long ModifiedTag = 0;
    unsigned long RenderedTag = 0;
    unsigned long StartingTag = 0;
    unsigned long TimerTag = 0;
    int TimerId = -1;
    bool Refreshing = false; ///< the render in progress is one this driver asked for
    bool Pending = false;    ///< the last still render left work pending
    std::chrono::steady_clock::time_point PendingSince;
  };
  vtkWeakPointer<vtkSMProxyManager> Manager;
  unsigned long RegisterTag = 0;
  unsigned long UnRegisterTag = 0;
  std::map<vtkSMProxy*, View> Views;
};

vtkNeuralVolumeRefreshDriver::vtkNeuralVolumeRefreshDriver()
  : Internals(new vtkInternals)
{
}

vtkNeuralVolumeRefreshDriver::~vtkNeuralVolumeRefreshDriver()
{
  while (!this->Internals->Views.empty())
  {
    this->RemoveView(this->Internals->Views.begin()->first);
  }
  if (this->Internals->Manager)
  {
    this->Internals->Manager->RemoveObserver(this->Internals->RegisterTag);
    this->Internals->Manager->RemoveObserver(this->Internals->UnRegisterTag);
  }
}

void vtkNeuralVolumeRefreshDriver::Install()
{
  vtkInternals& in = *this->Internals;
  if (in.Manager || !vtkSMProxyManager::IsInitialized())
  {
    return;
  }
  vtkSMProxyManager* manager = vtkSMProxyManager::GetProxyManager();
  in.Manager = manager;
  in.RegisterTag = manager->AddObserver(vtkCommand::RegisterEvent, this, &vtkNeuralVolumeRefreshDriver::OnRegister);
  in.UnRegisterTag =
    manager->AddObserver(vtkCommand::UnRegisterEvent, this, &vtkNeuralVolumeRefreshDriver::OnUnRegister);
  if (vtkSMSessionProxyManager* pxm = manager->GetActiveSessionProxyManager())
  {
    vtkNew<vtkSMProxyIterator> it;
    it->SetSessionProxyManager(pxm);
    it->SetModeToOneGroup();
    for (it->Begin("views"); !it->IsAtEnd(); it->Next())
    {
      this->AddView(it->GetProxy());
    }
  }
}

void vtkNeuralVolumeRefreshDriver::OnRegister(vtkObject*, unsigned long, void* data)
{
  auto* info = static_cast<vtkSMProxyManager::RegisteredProxyInformation*>(data);
  if (info && info->Type == vtkSMProxyManager::RegisteredProxyInformation::PROXY && info->GroupName &&
    std::strcmp(info->GroupName, "views") == 0)
  {
    this->AddView(info->Proxy);
  }
}

void vtkNeuralVolumeRefreshDriver::OnUnRegister(vtkObject*, unsigned long, void* data)
{
  auto* info = static_cast<vtkSMProxyManager::RegisteredProxyInformation*>(data);
  if (info && info->Type == vtkSMProxyManager::RegisteredProxyInformation::PROXY && info->Proxy)
  {
    this->RemoveView(info->Proxy);
  }
}

void vtkNeuralVolumeRefreshDriver::AddView(vtkSMProxy* proxy)
{
  vtkInternals& in = *this->Internals;
  auto* view = vtkSMViewProxy::SafeDownCast(proxy);
  auto known = in.Views.find(proxy);
  if (known != in.Views.end() && !known->second.Proxy)
  {
    this->RemoveView(proxy); // a deleted view's entry at this address
  }
  if (!view || in.Views.count(proxy) || !view->GetProperty("Representations"))
  {
    return;
  }
  vtkInternals::View& v = in.Views[proxy];
  v.Proxy = proxy;
  v.ModifiedTag =
    proxy->AddObserver(vtkCommand::PropertyModifiedEvent, this, &vtkNeuralVolumeRefreshDriver::OnViewModified);
  v.RenderedTag = proxy->AddObserver(vtkCommand::EndEvent, this, &vtkNeuralVolumeRefreshDriver::OnViewRendered);
  v.StartingTag = proxy->AddObserver(vtkCommand::StartEvent, this, &vtkNeuralVolumeRefreshDriver::OnViewStarting);
}

void vtkNeuralVolumeRefreshDriver::RemoveView(vtkSMProxy* proxy)
{
  vtkInternals& in = *this->Internals;
  auto it = in.Views.find(proxy);
  if (it == in.Views.end())
  {
    return;
  }
  vtkInternals::View& v = it->second;
  if (vtkSMProxy* alive = v.Proxy)
  {
    alive->RemoveObserver(v.ModifiedTag);
    alive->RemoveObserver(v.RenderedTag);
    alive->RemoveObserver(v.StartingTag);
  }
  if (v.Interactor)
  {
    if (v.TimerId >= 0)
    {
      v.Interactor->DestroyTimer(v.TimerId);
    }
    v.Interactor->RemoveObserver(v.TimerTag);
  }
  in.Views.erase(it);
}

//------------------------------------------------------------------------------
void vtkNeuralVolumeRefreshDriver::OnViewModified(vtkObject* caller, unsigned long, void* name)
{
  auto* view = vtkSMViewProxy::SafeDownCast(caller);
  const char* property = static_cast<const char*>(name);
  if (!view || !property || std::strcmp(property, "Representations") != 0)
  {
    return;
  }
  this->MakeProgressive(view);
}

void vtkNeuralVolumeRefreshDriver::OnViewStarting(vtkObject* caller, unsigned long, void*)
{
  // A state file sets a view's representations before the GUI gives the view its interactor: the first render
  // (the one that ends LoadState) must not be the blocking full-quality one either.
  if (auto* view = vtkSMViewProxy::SafeDownCast(caller))
  {
    this->MakeProgressive(view);
  }
}

void vtkNeuralVolumeRefreshDriver::MakeProgressive(vtkSMViewProxy* view)
{
  vtkInternals::View& v = this->Internals->Views[view];
  if (!v.Interactor)
  {
    vtkRenderWindowInteractor* interactor = view->GetRenderWindow() ? view->GetInteractor() : nullptr;
    if (!DrivesTimers(interactor))
    {
      return; // a script: still renders stay blocking
    }
    v.Interactor = interactor;
    v.TimerTag = interactor->AddObserver(vtkCommand::TimerEvent, this, &vtkNeuralVolumeRefreshDriver::OnTimer);
  }
  // A parallel render server composites its ranks' pictures in every still render: progressive pictures would each
  // stand at their own rank's stage (the GUI showed an empty or cut view). There still renders stay blocking.
  vtkSMSession* session = view->GetSession();
  if (session && session->GetNumberOfProcesses(vtkPVSession::RENDER_SERVER) > 1)
  {
    return;
  }
  // Representations of image data in this view render progressively (Neural Volume uses it; the others ignore it).
  vtkSMPropertyHelper members(view, "Representations");
  for (unsigned int i = 0; i < members.GetNumberOfElements(); ++i)
  {
    vtkSMProxy* representation = members.GetAsProxy(i);
    vtkSMProperty* progressive = representation ? representation->GetProperty("ProgressiveRefinement") : nullptr;
    if (progressive && vtkSMPropertyHelper(progressive).GetAsInt() == 0)
    {
      vtkSMPropertyHelper(progressive).Set(1);
      representation->UpdateVTKObjects();
    }
  }
}

void vtkNeuralVolumeRefreshDriver::OnViewRendered(vtkObject* caller, unsigned long, void* data)
{
  auto* view = vtkSMViewProxy::SafeDownCast(caller);
  auto it = view ? this->Internals->Views.find(view) : this->Internals->Views.end();
  if (it == this->Internals->Views.end() || !it->second.Interactor || it->second.TimerId >= 0)
  {
    return;
  }
  vtkInternals::View& v = it->second;
  const bool refresh = v.Refreshing;
  v.Refreshing = false;
  const int* interactive = static_cast<const int*>(data);
  if (interactive && *interactive)
  {
    v.Pending = false;
    return; // the still render that ends the interaction comes next
  }
  bool pending = false;
  vtkSMPropertyHelper members(view, "Representations");
  for (unsigned int i = 0; i < members.GetNumberOfElements() && !pending; ++i)
  {
    vtkSMProxy* representation = members.GetAsProxy(i);
    if (!IsNeuralVolume(representation) || vtkSMPropertyHelper(representation, "Visibility").GetAsInt() == 0)
    {
      continue;
    }
    // From the render server (information properties would be read on the client).
    vtkSMProperty* work = representation->GetProperty("WorkPending");
    vtkSMProxy* neural = work ? work->GetParent() : nullptr;
    vtkNew<vtkPVNeuralVolumeInformation> information;
    if (neural)
    {
      // (A client-server session's GatherInformation returns false even when it gathered: check Valid.)
      neural->GatherInformation(information, vtkPVSession::RENDER_SERVER);
      pending = information->GetValid() && information->GetWorkPending();
    }
  }
  if (!pending)
  {
    v.Pending = false;
    return;
  }
  // A refinement's images come ever more slowly (each level has four times the pixels of the one before): render
  // again after an eighth of the time it has run so far, between IntervalMilliseconds and MaxIntervalMilliseconds,
  // so that a long refinement does not spend the CPU it needs on redrawing the same picture. A render this driver did
  // not ask for (an edit, the end of an interaction) starts the count again.
  const auto now = std::chrono::steady_clock::now();
  if (!v.Pending || !refresh)
  {
    v.PendingSince = now;
  }
  v.Pending = true;
  const double elapsed = std::chrono::duration<double, std::milli>(now - v.PendingSince).count();
  const int interval = static_cast<int>(std::max<double>(this->IntervalMilliseconds,
    std::min<double>(this->MaxIntervalMilliseconds, elapsed / 8.0)));
  v.TimerId = v.Interactor->CreateOneShotTimer(interval);
}

void vtkNeuralVolumeRefreshDriver::OnTimer(vtkObject* caller, unsigned long, void* data)
{
  const int id = data ? *static_cast<int*>(data) : -1;
  for (auto& entry : this->Internals->Views)
  {
    vtkInternals::View& v = entry.second;
    if (v.Interactor == caller && v.TimerId >= 0 && v.TimerId == id)
    {
      v.TimerId = -1;
      v.Refreshing = true;
      if (auto* view = vtkSMViewProxy::SafeDownCast(v.Proxy))
      {
        view->StillRender();
      }
      return;
    }
  }
}
