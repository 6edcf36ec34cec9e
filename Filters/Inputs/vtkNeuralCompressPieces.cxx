// MPI (private): a rank's piece of Neural Compress's input, and the whole input assembled from the pieces on rank 0
// (vtkNeuralCompressPieces.h). The communication is in vtkNeuralCompressDistributed.cxx.
#include "vtkNeuralCompressPieces.h"

#include "vtkNeuralCompressInternals.h"
#include "vtkNeuralCompressResample.h"

#include "vtkAlgorithm.h"
#include "vtkAlgorithmOutput.h"
#include "vtkAppendDataSets.h"
#include "vtkCellData.h"
#include "vtkCompositeDataIterator.h"
#include "vtkCompositeDataSet.h"
#include "vtkDataArray.h"
#include "vtkDataObject.h"
#include "vtkDataSet.h"
#include "vtkDataSetAttributes.h"
#include "vtkDemandDrivenPipeline.h"
#include "vtkDoubleArray.h"
#include "vtkDummyController.h"
#include "vtkFieldData.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkInformationDoubleKey.h"
#include "vtkInformationVector.h"
#include "vtkIntArray.h"
#include "vtkMatrix3x3.h"
#include "vtkMultiBlockDataSet.h"
#include "vtkMultiProcessController.h"
#include "vtkMultiProcessStream.h"
#include "vtkNew.h"
#include "vtkPointData.h"
#include "vtkPolyData.h"
#include "vtkStreamingDemandDrivenPipeline.h"
#include "vtkUniformGrid.h"
#include "vtkUniformGridAMR.h"
#include "vtkUnsignedCharArray.h"

#include <algorithm>
#include <cstdint>
#include <sstream>
#include <vector>

namespace vtkNeuralCompressInternals
{
// Field-data arrays of an image piece: its geometry (origin, spacing, direction: the legacy format that carries
// data objects between processes writes the geometry as text) and what the rank found.
const char* const kGeometryName = "vtkNeuralCompressPieceGeometry";
const char* const kFoundName = "vtkNeuralCompressPieceArray";


Selection Selected(vtkAlgorithm* self)
{
  Selection s;
  vtkInformation* ai = self->GetInputArrayInformation(0);
  if (!ai)
    return s;
  if (ai->Has(vtkDataObject::FIELD_NAME()) && ai->Get(vtkDataObject::FIELD_NAME()))
    s.Name = ai->Get(vtkDataObject::FIELD_NAME());
  if (ai->Has(vtkDataObject::FIELD_ASSOCIATION()))
    s.Association = ai->Get(vtkDataObject::FIELD_ASSOCIATION());
  if (ai->Has(vtkDataObject::FIELD_ATTRIBUTE_TYPE()))
    s.AttributeType = ai->Get(vtkDataObject::FIELD_ATTRIBUTE_TYPE());
  return s;
}

static bool IsEmpty(vtkDataSet* ds)
{
  return !ds || ds->GetNumberOfPoints() + ds->GetNumberOfCells() == 0;
}

static vtkDataArray* FieldArray(vtkDataSet* ds, const std::string& name, int association)
{
  return association == vtkDataObject::FIELD_ASSOCIATION_CELLS ? ds->GetCellData()->GetArray(name.c_str())
                                                                : ds->GetPointData()->GetArray(name.c_str());
}

/// The selected array of an image piece (as vtkAlgorithm::GetInputArrayToProcess finds it) and its association.
static vtkDataArray* ImageArray(vtkImageData* image, const Selection& sel, int& association)
{
  auto find = [&](int a) -> vtkDataArray* {
    vtkDataSetAttributes* attributes =
      a == vtkDataObject::FIELD_ASSOCIATION_CELLS ? static_cast<vtkDataSetAttributes*>(image->GetCellData())
                                                   : static_cast<vtkDataSetAttributes*>(image->GetPointData());
    if (!sel.Name.empty())
      return attributes->GetArray(sel.Name.c_str());
    if (sel.AttributeType >= 0)
      return attributes->GetAttribute(sel.AttributeType);
    return nullptr;
  };
  association = -1;
  if (sel.Association == vtkDataObject::FIELD_ASSOCIATION_POINTS_THEN_CELLS)
  {
    if (vtkDataArray* a = find(vtkDataObject::FIELD_ASSOCIATION_POINTS))
    {
      association = vtkDataObject::FIELD_ASSOCIATION_POINTS;
      return a;
    }
    association = vtkDataObject::FIELD_ASSOCIATION_CELLS;
    return find(association);
  }
  if (sel.Association == vtkDataObject::FIELD_ASSOCIATION_POINTS ||
    sel.Association == vtkDataObject::FIELD_ASSOCIATION_CELLS)
  {
    association = sel.Association;
    return find(association);
  }
  return nullptr;
}

/// Index ranges of an image's samples along each axis: points, or cells (a flat axis keeps its one index).
static void SampleRange(const int ext[6], bool cells, int lo[3], int hi[3])
{
  for (int a = 0; a < 3; ++a)
  {
    lo[a] = ext[2 * a];
    hi[a] = cells && ext[2 * a + 1] > ext[2 * a] ? ext[2 * a + 1] - 1 : ext[2 * a + 1];
  }
}

/// This rank's image piece: its extent and geometry, the selected array and the ghost arrays.
static vtkSmartPointer<vtkDataObject> ImagePiece(vtkImageData* image, const Selection& sel)
{
  auto piece = vtkSmartPointer<vtkImageData>::New();
  piece->SetExtent(image->GetExtent());
  piece->SetOrigin(image->GetOrigin());
  piece->SetSpacing(image->GetSpacing());
  vtkNew<vtkDoubleArray> geometry;
  geometry->SetName(kGeometryName);
  geometry->SetNumberOfTuples(15);
  for (int i = 0; i < 3; ++i)
  {
    geometry->SetValue(i, image->GetOrigin()[i]);
    geometry->SetValue(3 + i, image->GetSpacing()[i]);
  }
  for (int i = 0; i < 9; ++i)
    geometry->SetValue(6 + i, image->GetDirectionMatrix()->GetData()[i]);
  piece->GetFieldData()->AddArray(geometry);

  int association = -1;
  vtkDataArray* array = ImageArray(image, sel, association);
  vtkNew<vtkIntArray> found;
  found->SetName(kFoundName);
  found->SetNumberOfTuples(2);
  found->SetValue(0, array ? 1 : 0);
  found->SetValue(1, association);
  piece->GetFieldData()->AddArray(found);
  if (array)
  {
    const bool cells = association == vtkDataObject::FIELD_ASSOCIATION_CELLS;
    (cells ? static_cast<vtkDataSetAttributes*>(piece->GetCellData())
           : static_cast<vtkDataSetAttributes*>(piece->GetPointData()))
      ->AddArray(array);
  }
  for (vtkDataSetAttributes* from : { static_cast<vtkDataSetAttributes*>(image->GetPointData()),
         static_cast<vtkDataSetAttributes*>(image->GetCellData()) })
  {
    if (vtkAbstractArray* ghost = from->GetAbstractArray(vtkDataSetAttributes::GhostArrayName()))
    {
      (from == image->GetPointData() ? static_cast<vtkDataSetAttributes*>(piece->GetPointData())
                                     : static_cast<vtkDataSetAttributes*>(piece->GetCellData()))
        ->AddArray(ghost);
    }
  }
  return piece;
}

/// A shallow copy of a dataset with only the arrays the gather needs: the selected array, ghost arrays, global ids.
static vtkSmartPointer<vtkDataSet> Stripped(vtkDataSet* ds, const Selection& sel)
{
  vtkSmartPointer<vtkDataSet> copy;
  copy.TakeReference(ds->NewInstance());
  copy->ShallowCopy(ds);
  copy->GetFieldData()->Initialize();
  for (int assoc : { vtkDataObject::FIELD_ASSOCIATION_POINTS, vtkDataObject::FIELD_ASSOCIATION_CELLS })
  {
    vtkDataSetAttributes* attributes = assoc == vtkDataObject::FIELD_ASSOCIATION_CELLS
      ? static_cast<vtkDataSetAttributes*>(copy->GetCellData())
      : static_cast<vtkDataSetAttributes*>(copy->GetPointData());
    const bool selected = sel.Association == assoc ||
      sel.Association == vtkDataObject::FIELD_ASSOCIATION_POINTS_THEN_CELLS;
    vtkAbstractArray* globalIds = attributes->GetGlobalIds();
    for (int i = attributes->GetNumberOfArrays() - 1; i >= 0; --i)
    {
      vtkAbstractArray* a = attributes->GetAbstractArray(i);
      const char* name = a ? a->GetName() : nullptr;
      const bool keep = a &&
        ((selected && name && sel.Name == name) || a == globalIds ||
          (name && std::string(name) == vtkDataSetAttributes::GhostArrayName()));
      if (!keep)
        attributes->RemoveArray(i);
    }
  }
  return copy;
}

/// This rank's piece of the input, reduced to what training needs.
vtkSmartPointer<vtkDataObject> MakePiece(vtkDataObject* local, const Selection& sel)
{
  if (auto* image = vtkImageData::SafeDownCast(local))
    return ImagePiece(image, sel);
  if (auto* ds = vtkDataSet::SafeDownCast(local))
    return Stripped(ds, sel);
  if (auto* cd = vtkCompositeDataSet::SafeDownCast(local))
  {
    vtkSmartPointer<vtkCompositeDataSet> copy;
    copy.TakeReference(cd->NewInstance());
    copy->CopyStructure(cd);
    vtkSmartPointer<vtkCompositeDataIterator> it;
    it.TakeReference(cd->NewIterator());
    for (it->InitTraversal(); !it->IsDoneWithTraversal(); it->GoToNextItem())
    {
      if (auto* leaf = vtkDataSet::SafeDownCast(it->GetCurrentDataObject()))
        copy->SetDataSet(it, Stripped(leaf, sel));
    }
    return copy;
  }
  return nullptr;
}

static std::string RankList(const std::vector<int>& ranks)
{
  std::ostringstream s;
  s << (ranks.size() == 1 ? "rank " : "ranks ");
  for (size_t i = 0; i < ranks.size(); ++i)
    s << (i ? ", " : "") << ranks[i];
  return s.str();
}

/// Rank 0: the image pieces stitched into one image of `wholeExtent` (null: the union of the pieces' extents).
vtkSmartPointer<vtkImageData> StitchImages(
  const std::vector<vtkSmartPointer<vtkDataObject>>& pieces, const int* wholeExtent, std::string& problem)
{
  // The reference piece (the first with the array) gives the array's name, type, components and association.
  int ref = -1, firstData = -1;
  std::vector<int> missing;
  for (size_t r = 0; r < pieces.size(); ++r)
  {
    auto* image = vtkImageData::SafeDownCast(pieces[r]);
    if (!image || image->GetNumberOfPoints() == 0)
      continue;
    if (firstData < 0)
      firstData = int(r);
    auto* found = vtkIntArray::SafeDownCast(image->GetFieldData()->GetArray(kFoundName));
    if (found && found->GetValue(0) == 1)
    {
      if (ref < 0)
        ref = int(r);
    }
    else
    {
      missing.push_back(int(r));
    }
  }
  auto out = vtkSmartPointer<vtkImageData>::New();
  // Geometry: of the first piece with points (the origin is the whole image's on every piece), else rank 0's.
  auto* geometrySource = vtkImageData::SafeDownCast(pieces[firstData >= 0 ? size_t(firstData) : 0]);
  if (!geometrySource)
  {
    problem = "rank 0 has no image piece of the input";
    return nullptr;
  }
  if (auto* g = vtkDoubleArray::SafeDownCast(geometrySource->GetFieldData()->GetArray(kGeometryName)))
  {
    out->SetOrigin(g->GetValue(0), g->GetValue(1), g->GetValue(2));
    out->SetSpacing(g->GetValue(3), g->GetValue(4), g->GetValue(5));
    double direction[9];
    for (int i = 0; i < 9; ++i)
      direction[i] = g->GetValue(6 + i);
    out->SetDirectionMatrix(direction);
  }
  if (firstData < 0)
  {
    // No rank has a point: an empty image, which the filter reports as in serial.
    out->SetExtent(geometrySource->GetExtent());
    return out;
  }
  int whole[6];
  if (wholeExtent && wholeExtent[0] <= wholeExtent[1] && wholeExtent[2] <= wholeExtent[3] &&
    wholeExtent[4] <= wholeExtent[5])
  {
    std::copy(wholeExtent, wholeExtent + 6, whole);
  }
  else
  {
    whole[0] = whole[2] = whole[4] = VTK_INT_MAX;
    whole[1] = whole[3] = whole[5] = VTK_INT_MIN;
    for (const auto& p : pieces)
    {
      auto* image = vtkImageData::SafeDownCast(p);
      if (!image || image->GetNumberOfPoints() == 0)
        continue;
      const int* e = image->GetExtent();
      for (int a = 0; a < 3; ++a)
      {
        whole[2 * a] = std::min(whole[2 * a], e[2 * a]);
        whole[2 * a + 1] = std::max(whole[2 * a + 1], e[2 * a + 1]);
      }
    }
  }
  out->SetExtent(whole);
  if (ref < 0)
  {
    // No piece has the array: the whole image without it (the filter reports the missing array as in serial).
    return out;
  }
  auto* refImage = vtkImageData::SafeDownCast(pieces[size_t(ref)]);
  const int association = vtkIntArray::SafeDownCast(refImage->GetFieldData()->GetArray(kFoundName))->GetValue(1);
  const bool cells = association == vtkDataObject::FIELD_ASSOCIATION_CELLS;
  auto attributesOf = [cells](vtkImageData* image) -> vtkDataSetAttributes* {
    return cells ? static_cast<vtkDataSetAttributes*>(image->GetCellData())
                 : static_cast<vtkDataSetAttributes*>(image->GetPointData());
  };
  vtkDataArray* refArray = nullptr;
  for (int i = 0; i < attributesOf(refImage)->GetNumberOfArrays() && !refArray; ++i)
  {
    vtkDataArray* a = attributesOf(refImage)->GetArray(i);
    if (a && !(a->GetName() && std::string(a->GetName()) == vtkDataSetAttributes::GhostArrayName()))
      refArray = a;
  }
  if (!refArray)
  {
    problem = "the image piece of rank " + std::to_string(ref) + " lost its array in transit";
    return nullptr;
  }
  const std::string name = refArray->GetName() ? refArray->GetName() : "";
  if (!missing.empty())
  {
    problem = "the input array '" + name + "' is missing on the piece of " + RankList(missing) +
      " (every rank's piece of the image needs it)";
    return nullptr;
  }

  int wlo[3], whi[3];
  SampleRange(whole, cells, wlo, whi);
  const vtkIdType n0 = whi[0] - wlo[0] + 1, n1 = whi[1] - wlo[1] + 1, n2 = whi[2] - wlo[2] + 1;
  const vtkIdType count = n0 * n1 * n2;
  vtkSmartPointer<vtkDataArray> values;
  values.TakeReference(refArray->NewInstance());
  values->SetName(refArray->GetName());
  values->SetNumberOfComponents(refArray->GetNumberOfComponents());
  for (int c = 0; c < refArray->GetNumberOfComponents(); ++c)
  {
    if (refArray->GetComponentName(c))
      values->SetComponentName(c, refArray->GetComponentName(c));
  }
  values->SetNumberOfTuples(count);
  std::vector<uint8_t> covered(size_t(count), 0);
  const unsigned char duplicate = cells ? static_cast<unsigned char>(vtkDataSetAttributes::DUPLICATECELL)
                                        : static_cast<unsigned char>(vtkDataSetAttributes::DUPLICATEPOINT);

  for (size_t r = 0; r < pieces.size(); ++r)
  {
    auto* image = vtkImageData::SafeDownCast(pieces[r]);
    if (!image || image->GetNumberOfPoints() == 0)
      continue;
    vtkDataArray* a = attributesOf(image)->GetArray(name.c_str());
    if (!a || a->GetDataType() != values->GetDataType() ||
      a->GetNumberOfComponents() != values->GetNumberOfComponents())
    {
      problem = "the input array '" + name + "' of rank " + std::to_string(r) +
        (a ? " differs in type or components from rank " + std::to_string(ref) + "'s"
           : " is not a " + std::string(cells ? "cell" : "point") + " array like rank " + std::to_string(ref) + "'s");
      return nullptr;
    }
    const int* e = image->GetExtent();
    int lo[3], hi[3];
    SampleRange(e, cells, lo, hi);
    bool inside = true;
    for (int ax = 0; ax < 3; ++ax)
    {
      inside &= lo[ax] >= wlo[ax] && hi[ax] <= whi[ax];
      // A piece one point thick along an axis of the whole image has no cells of it.
      if (cells && e[2 * ax] == e[2 * ax + 1] && whole[2 * ax] < whole[2 * ax + 1])
        inside = false;
    }
    if (!inside)
    {
      if (cells)
        continue;
      std::ostringstream s;
      s << "the piece of rank " << r << " (extent " << e[0] << " " << e[1] << " " << e[2] << " " << e[3] << " "
        << e[4] << " " << e[5] << ") lies outside the whole extent";
      problem = s.str();
      return nullptr;
    }
    const vtkIdType l0 = hi[0] - lo[0] + 1, l1 = hi[1] - lo[1] + 1, l2 = hi[2] - lo[2] + 1;
    if (a->GetNumberOfTuples() != l0 * l1 * l2)
    {
      problem = "the input array '" + name + "' of rank " + std::to_string(r) + " has " +
        std::to_string(a->GetNumberOfTuples()) + " tuples for " + std::to_string(l0 * l1 * l2) +
        (cells ? " cells" : " points");
      return nullptr;
    }
    auto* ghost = vtkUnsignedCharArray::SafeDownCast(
      attributesOf(image)->GetAbstractArray(vtkDataSetAttributes::GhostArrayName()));
    if (ghost && ghost->GetNumberOfTuples() != a->GetNumberOfTuples())
      ghost = nullptr;
    for (vtkIdType k = 0; k < l2; ++k)
    {
      for (vtkIdType j = 0; j < l1; ++j)
      {
        const vtkIdType src = (k * l1 + j) * l0;
        const vtkIdType dst = ((lo[2] - wlo[2] + k) * n1 + (lo[1] - wlo[1] + j)) * n0 + (lo[0] - wlo[0]);
        // Runs of the row that this piece owns (ghost points or cells belong to a neighbour).
        vtkIdType i = 0;
        while (i < l0)
        {
          if (ghost && (ghost->GetValue(src + i) & duplicate))
          {
            ++i;
            continue;
          }
          vtkIdType end = i + 1;
          while (end < l0 && !(ghost && (ghost->GetValue(src + end) & duplicate)))
            ++end;
          values->InsertTuples(dst + i, end - i, src + i, a);
          std::fill(covered.begin() + (dst + i), covered.begin() + (dst + end), uint8_t(1));
          i = end;
        }
      }
    }
  }
  const vtkIdType done = std::count(covered.begin(), covered.end(), uint8_t(1));
  if (done != count)
  {
    problem = "the pieces of the " + std::to_string(pieces.size()) + " ranks cover " + std::to_string(done) +
      " of the " + std::to_string(count) + (cells ? " cells" : " points") + " of the whole extent";
    return nullptr;
  }
  vtkDataSetAttributes* attributes = attributesOf(out);
  attributes->AddArray(values);
  // Found by name as on the pieces; by the active attribute when the filter selects one instead of a name.
  const int type = vtkDataSetAttributes::SCALARS;
  attributes->SetActiveAttribute(attributes->GetNumberOfArrays() - 1, type);
  return out;
}

/// Rank 0: the pieces of one dataset (or one block) merged into one: the only non-empty piece as it is, else
/// vtkAppendDataSets with merged points (by global ids where present). Pieces without the array are left out.
static vtkSmartPointer<vtkDataSet> MergePieces(const std::vector<vtkDataSet*>& parts, const Selection& sel,
  const std::string& where, std::vector<std::string>& warnings)
{
  std::vector<vtkDataSet*> keep;
  std::vector<int> missing;
  vtkDataSet* firstNonNull = nullptr;
  for (size_t r = 0; r < parts.size(); ++r)
  {
    vtkDataSet* ds = parts[r];
    if (ds && !firstNonNull)
      firstNonNull = ds;
    if (IsEmpty(ds))
      continue;
    if (!sel.Name.empty() && !FieldArray(ds, sel.Name, sel.Association))
    {
      missing.push_back(int(r));
      continue;
    }
    keep.push_back(ds);
  }
  if (!missing.empty() && !keep.empty())
  {
    warnings.push_back("the piece" + where + " of " + RankList(missing) + " has no array '" + sel.Name +
      "' (which the other ranks' pieces have); it is left out");
  }
  if (keep.empty())
  {
    // Nothing with the array: the first non-empty piece (the filter then reports as in serial) or an empty one.
    for (vtkDataSet* ds : parts)
      if (!IsEmpty(ds))
        return ds;
    return firstNonNull;
  }
  if (keep.size() == 1)
    return keep[0];
  bool allPoly = true;
  for (vtkDataSet* ds : keep)
    allPoly &= vtkPolyData::SafeDownCast(ds) != nullptr;
  vtkNew<vtkAppendDataSets> append;
  append->SetMergePoints(true);
  append->SetOutputDataSetType(allPoly ? VTK_POLY_DATA : VTK_UNSTRUCTURED_GRID);
  for (vtkDataSet* ds : keep)
    append->AddInputData(ds);
  append->Update();
  vtkSmartPointer<vtkDataSet> merged = vtkDataSet::SafeDownCast(append->GetOutputDataObject(0));
  return merged;
}

/// Rank 0: the whole input from the pieces of a dataset or composite input.
vtkSmartPointer<vtkDataObject> Assemble(const std::vector<vtkSmartPointer<vtkDataObject>>& pieces,
  const Selection& sel, std::vector<std::string>& warnings, std::string& problem)
{
  vtkDataObject* ref = pieces.empty() ? nullptr : pieces[0].GetPointer();
  if (!ref)
  {
    problem = "rank 0's piece of the input did not arrive";
    return nullptr;
  }
  if (vtkDataSet::SafeDownCast(ref))
  {
    std::vector<vtkDataSet*> parts;
    for (const auto& p : pieces)
      parts.push_back(vtkDataSet::SafeDownCast(p));
    return MergePieces(parts, sel, "", warnings);
  }
  auto* refComposite = vtkCompositeDataSet::SafeDownCast(ref);
  if (!refComposite)
  {
    problem = std::string("cannot gather a ") + ref->GetClassName() + " input";
    return nullptr;
  }
  // Same structure on every rank (ParaView's distributed composites): the pieces of each block merged in place.
  auto leafCount = [](vtkCompositeDataSet* cd) {
    vtkSmartPointer<vtkCompositeDataIterator> it;
    it.TakeReference(cd->NewIterator());
    it->SkipEmptyNodesOff();
    int n = 0;
    for (it->InitTraversal(); !it->IsDoneWithTraversal(); it->GoToNextItem())
      ++n;
    return n;
  };
  bool same = true;
  const int leaves = leafCount(refComposite);
  for (const auto& p : pieces)
  {
    auto* cd = vtkCompositeDataSet::SafeDownCast(p);
    same &= cd && std::string(cd->GetClassName()) == ref->GetClassName() && leafCount(cd) == leaves;
  }
  const bool amr = vtkUniformGridAMR::SafeDownCast(ref) != nullptr;
  if (same)
  {
    vtkSmartPointer<vtkCompositeDataSet> whole;
    whole.TakeReference(refComposite->NewInstance());
    whole->CopyStructure(refComposite);
    vtkSmartPointer<vtkCompositeDataIterator> it;
    it.TakeReference(whole->NewIterator());
    it->SkipEmptyNodesOff();
    bool fits = true;
    for (it->InitTraversal(); !it->IsDoneWithTraversal() && fits; it->GoToNextItem())
    {
      std::vector<vtkDataSet*> parts;
      for (const auto& p : pieces)
        parts.push_back(vtkDataSet::SafeDownCast(vtkCompositeDataSet::SafeDownCast(p)->GetDataSet(it)));
      vtkSmartPointer<vtkDataSet> merged =
        MergePieces(parts, sel, " of block " + std::to_string(it->GetCurrentFlatIndex()), warnings);
      if (!merged)
        continue;
      // AMR blocks are uniform grids, never split between ranks; anything else: the flat union below.
      if (amr && !vtkUniformGrid::SafeDownCast(merged))
      {
        fits = false;
        break;
      }
      whole->SetDataSet(it, merged);
    }
    if (fits)
      return whole;
  }
  // Different structures: one multiblock of every rank's non-empty leaves (one network over their union).
  auto flat = vtkSmartPointer<vtkMultiBlockDataSet>::New();
  unsigned int block = 0;
  for (const auto& p : pieces)
  {
    auto* cd = vtkCompositeDataSet::SafeDownCast(p);
    if (!cd)
      continue;
    vtkSmartPointer<vtkCompositeDataIterator> it;
    it.TakeReference(cd->NewIterator());
    for (it->InitTraversal(); !it->IsDoneWithTraversal(); it->GoToNextItem())
    {
      auto* ds = vtkDataSet::SafeDownCast(it->GetCurrentDataObject());
      if (!IsEmpty(ds))
        flat->SetBlock(block++, ds);
    }
  }
  return flat;
}

bool ValidExtent(const int* e)
{
  return e && e[0] <= e[1] && e[2] <= e[3] && e[4] <= e[5];
}

} // namespace vtkNeuralCompressInternals
