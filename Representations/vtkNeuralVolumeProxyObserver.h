/**
 * @class   vtkNeuralVolumeProxyObserver
 * @brief   client-side: makes "Neural Volume" behave like ParaView's own Volume representation
 *
 * Installed once per client process by the plugin's initializer (GUI, pvpython, pvbatch; see
 * vtkNeuralVolumePluginInitializer.h). It observes the server manager's proxy registrations and,
 * for every image-data representation (UniformGridRepresentation):
 * - colours by the network's array and rescales the colour map when the representation becomes
 *   "Neural Volume" without scalar colouring (ParaView does this itself only for Volume, Slice and
 *   NVIDIA IndeX), and shows the colour bar when the general settings' scalar bar mode shows bars
 *   automatically; a representation shown with Neural Volume right away is handled as soon as it
 *   joins its view; nothing is changed while a state file is being loaded. On the default Network-only output of
 *   Neural Compress the colour array is the network's: vtkNeuralVolumeRepresentation shows ParaView its range, so
 *   Rescale to Data Range and the automatic rescale modes use it;
 * - when a view's update (a time step, a re-execution) brings a Neural Volume representation a usable range while
 *   its colour map still has none (fitted to a constant or empty step: a single value widened by a few float steps,
 *   or nothing), fits the maps to the new range (unless the map's range is locked), so that later steps are never
 *   blank;
 * - keeps the active view when ParaView opens a chart for a Neural Compress training log (one per filter, on its
 *   first Apply): the render view stays active;
 * - refreshes Neural Compress's TrainingStatus and TotalStepsTrained on every re-execution, so that the panel's
 *   status line follows a background training;
 * - makes the stock "Volume Rendering" property group visible for Neural Volume and the lighting
 *   coefficients it uses (Ambient, Diffuse, Specular, Specular Power), and hides for Neural Volume
 *   only what the network renderer does not use: the surface groups (styling, scalar colouring of
 *   polygons, edges, backfaces, miscellaneous, ray-tracing materials), the other lighting
 *   properties, and the stock volume properties for 2D transfer functions, separate opacity arrays,
 *   the stock mappers' modes, isosurfaces, slices and cropping (panel hints only: nothing changes
 *   for the other representations);
 * - adds the blend modes the engine renders (maximum, minimum, average intensity, additive) to the
 *   stock BlendMode choices, which in ParaView 5.11 list only Composite, Isosurface and Slice
 *   (the stock volume mapper renders them too).
 */
#ifndef vtkNeuralVolumeProxyObserver_h
#define vtkNeuralVolumeProxyObserver_h

#include "NeuralVolumeRepresentationsModule.h" // for export macro
#include "vtkObject.h"

#include <memory> // for std::unique_ptr

class vtkSMProxy;

class NEURALVOLUMEREPRESENTATIONS_EXPORT vtkNeuralVolumeProxyObserver : public vtkObject
{
public:
  static vtkNeuralVolumeProxyObserver* New();
  vtkTypeMacro(vtkNeuralVolumeProxyObserver, vtkObject);

  /// Observe the proxy manager of this process (once; later calls do nothing), and handle the
  /// representations already registered.
  void Install();

  /// Text of the representation type that this class supports.
  static const char* RepresentationName() { return "Neural Volume"; }

  /// Colour `representation` by the network's array if it shows "Neural Volume" without scalar
  /// colouring; show the colour bar in `view` (may be null: the representation's view). Returns
  /// true when it coloured.
  /// `rangeFound` (optional): whether the maps got a usable range (false for a constant or empty field).
  static bool ColorByNetwork(vtkSMProxy* representation, vtkSMProxy* view, bool* rangeFound = nullptr);

protected:
  vtkNeuralVolumeProxyObserver();
  ~vtkNeuralVolumeProxyObserver() override;

private:
  vtkNeuralVolumeProxyObserver(const vtkNeuralVolumeProxyObserver&) = delete;
  void operator=(const vtkNeuralVolumeProxyObserver&) = delete;

  void OnRegister(vtkObject*, unsigned long, void* info);
  void OnUnRegister(vtkObject*, unsigned long, void* info);
  void OnRepresentationModified(vtkObject* caller, unsigned long, void* propertyName);
  void OnViewModified(vtkObject* caller, unsigned long, void* propertyName);
  void OnViewUpdated(vtkObject* caller, unsigned long, void*);
  /// Fits the maps of a Neural Volume representation whose map has no usable range yet to its data's range.
  void FitUnsetRange(vtkSMProxy* representation);
  void OnSourceUpdated(vtkObject* caller, unsigned long, void*);
  void AddProxy(const char* group, vtkSMProxy* proxy, bool registering);
  void AddRepresentation(vtkSMProxy* representation);
  void AddView(vtkSMProxy* view, bool registering);
  void AddSource(vtkSMProxy* source);
  /// ColorByNetwork, remembering a representation coloured without a usable range.
  bool Color(vtkSMProxy* representation, vtkSMProxy* view);
  /// Gives the active view back to `previous` when `view` was just created for a training log.
  void KeepActiveView(vtkSMProxy* view, vtkSMProxy* previous);

  struct vtkInternals;
  std::unique_ptr<vtkInternals> Internals;
};

#endif
