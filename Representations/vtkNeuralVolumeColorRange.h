/**
 * @class   vtkNeuralVolumeColorRange
 * @brief   client-side: the colour and opacity maps of a Neural Volume fitted to the network's value range
 *
 * Used by vtkNeuralVolumeProxyObserver. ParaView's rescaling (Rescale to Data Range, the automatic rescale modes)
 * finds the range of the colour array in the representation's input, else in its represented data: on a Neural
 * Compress output without a decoded field (Network only), vtkNeuralVolumeRepresentation::GetRenderedDataObject puts
 * the network's range (NeuralValueRange) there under the array's name. This class fits the maps when a
 * representation starts colouring by the network, and again when a map fitted to a constant or empty time step (no
 * usable range) meets a step that has one.
 */
#ifndef vtkNeuralVolumeColorRange_h
#define vtkNeuralVolumeColorRange_h

#include "NeuralVolumeRepresentationsModule.h" // for export macro

class vtkSMProxy;

class NEURALVOLUMEREPRESENTATIONS_EXPORT vtkNeuralVolumeColorRange
{
public:
  /// A range that maps no field: reversed, wider than the largest double, or no wider than the few float steps by
  /// which ParaView widens a single value (vtkSMCoreUtilities::AdjustRange: a constant 0 gives [0, 1.2e-38]).
  static bool Degenerate(const double range[2]);

  /// The range ParaView's rescaling sees for the representation's colour array (component or magnitude as the
  /// colour map says); false when it sees none.
  static bool ColorArrayRange(vtkSMProxy* representation, double range[2]);

  /// NeuralValueRange of the representation's input (field data); false when absent or not finite.
  static bool NetworkValueRange(vtkSMProxy* representation, double range[2]);

  /// Fit the maps to the colour array's range, or to NeuralValueRange before the representation has updated
  /// (widened as ParaView widens a single value). Returns true when the range was usable (not Degenerate).
  static bool FitToNetwork(vtkSMProxy* representation);

  /// When the map's range is not locked (mode Never) and is Degenerate or `awaiting` (coloured without a usable
  /// range), and the data's range is usable: fit the maps to it. Returns true when it fitted.
  static bool FitUnsetRange(vtkSMProxy* representation, bool awaiting);

private:
  vtkNeuralVolumeColorRange() = delete;
};

#endif
