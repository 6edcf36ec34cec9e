/**
 * @class   vtkNeuralVolumeRefreshDriver
 * @brief   client-side: renders a view again while a Neural Volume in it is still refining
 *
 * The Decode path shows a coarse grid first and decodes the full one in the background, and path
 * tracing accumulates frames while the view is still. In the GUI a render must not wait for that
 * work (the GUI would freeze), so this driver, installed by the plugin's initializer in every
 * client process, turns the representations' ProgressiveRefinement on for views whose interactor
 * runs timers in an event loop (the GUI's QVTKInteractor) and, after each still render of such a
 * view, gathers whether a Neural Volume in it has work pending (vtkPVNeuralVolumeInformation, from
 * the render server) and schedules another still render (a one-shot timer of the view's interactor)
 * while any has: after IntervalMilliseconds at first, then after an eighth of the time the
 * refinement has run (at most MaxIntervalMilliseconds), so that a long refinement on the CPU is not
 * slowed by redrawing an unchanged picture. It needs no Qt code of its own: the timers are those of the interactor ParaView
 * created for the view, and it works the same in a client-server session.
 *
 * Without such an interactor (pvpython, pvbatch) nothing is changed: ProgressiveRefinement stays
 * off and a still render returns the final picture, so scripts stay deterministic.
 */
#ifndef vtkNeuralVolumeRefreshDriver_h
#define vtkNeuralVolumeRefreshDriver_h

#include "NeuralVolumeRepresentationsModule.h" // for export macro
#include "vtkObject.h"

#include <memory> // for std::unique_ptr

class vtkSMProxy;
class vtkSMViewProxy;

class NEURALVOLUMEREPRESENTATIONS_EXPORT vtkNeuralVolumeRefreshDriver : public vtkObject
{
public:
  static vtkNeuralVolumeRefreshDriver* New();
  vtkTypeMacro(vtkNeuralVolumeRefreshDriver, vtkObject);

  /// Observe the proxy manager of this process (once) and the views already registered.
  void Install();

  /// Milliseconds between a still render that left work pending and the next one: at least
  /// IntervalMilliseconds, at most MaxIntervalMilliseconds (see above).
  vtkSetClampMacro(IntervalMilliseconds, int, 1, 10000);
  vtkGetMacro(IntervalMilliseconds, int);
  vtkSetClampMacro(MaxIntervalMilliseconds, int, 1, 10000);
  vtkGetMacro(MaxIntervalMilliseconds, int);

protected:
  vtkNeuralVolumeRefreshDriver();
  ~vtkNeuralVolumeRefreshDriver() override;

private:
  vtkNeuralVolumeRefreshDriver(const vtkNeuralVolumeRefreshDriver&) = delete;
  void operator=(const vtkNeuralVolumeRefreshDriver&) = delete;

  void OnRegister(vtkObject*, unsigned long, void* info);
  void OnUnRegister(vtkObject*, unsigned long, void* info);
  void OnViewModified(vtkObject* caller, unsigned long, void* propertyName);
  void OnViewRendered(vtkObject* caller, unsigned long, void* interactive);
  void OnViewStarting(vtkObject* caller, unsigned long, void*);
  /// Once the view has an interactor that runs timers (the GUI's): its representations refine progressively.
  void MakeProgressive(vtkSMViewProxy* view);
  void OnTimer(vtkObject* caller, unsigned long, void* timerId);
  void AddView(vtkSMProxy* view);
  void RemoveView(vtkSMProxy* view);

  int IntervalMilliseconds = 30;
  int MaxIntervalMilliseconds = 250;

  struct vtkInternals;
  std::unique_ptr<vtkInternals> Internals;
};

#endif
