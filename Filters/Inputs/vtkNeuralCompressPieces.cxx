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
void SampleRange(const int ext[6], bool cells, int lo[3], int hi[3])
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
  geometry->SetName(kPieceGeometryName);
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
  found->SetName(kPieceFoundName);
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

std::string RankList(const std::vector<int>& ranks)
{
  std::ostringstream s;
  s << (ranks.size() == 1 ? "rank " : "ranks ");
  for (size_t i = 0; i < ranks.size(); ++i)
    s << (i ? ", " : "") << ranks[i];
  return s.str();
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

/// The leaves of a composite, empty nodes included.
static int LeafCount(vtkCompositeDataSet* cd)
{
  vtkSmartPointer<vtkCompositeDataIterator> it;
  it.TakeReference(cd->NewIterator());
  it->SkipEmptyNodesOff();
  int n = 0;
  for (it->InitTraversal(); !it->IsDoneWithTraversal(); it->GoToNextItem())
    ++n;
  return n;
}

/// Every piece is a composite of the reference's class and number of leaves.
static bool SameStructure(const std::vector<vtkSmartPointer<vtkDataObject>>& pieces, vtkCompositeDataSet* ref)
{
  bool same = true;
  const int leaves = LeafCount(ref);
  for (const auto& p : pieces)
  {
    auto* cd = vtkCompositeDataSet::SafeDownCast(p);
    same &= cd && std::string(cd->GetClassName()) == ref->GetClassName() && LeafCount(cd) == leaves;
  }
  return same;
}

/// Same structure on every rank (ParaView's distributed composites): the pieces of each block merged in place; null
/// when an AMR block does not merge into a uniform grid.
static vtkSmartPointer<vtkCompositeDataSet> MergeBlocks(const std::vector<vtkSmartPointer<vtkDataObject>>& pieces,
  vtkCompositeDataSet* ref, const Selection& sel, std::vector<std::string>& warnings)
{
  const bool amr = vtkUniformGridAMR::SafeDownCast(ref) != nullptr;
  vtkSmartPointer<vtkCompositeDataSet> whole;
  whole.TakeReference(ref->NewInstance());
  whole->CopyStructure(ref);
  vtkSmartPointer<vtkCompositeDataIterator> it;
  it.TakeReference(whole->NewIterator());
  it->SkipEmptyNodesOff();
  for (it->InitTraversal(); !it->IsDoneWithTraversal(); it->GoToNextItem())
  {
    std::vector<vtkDataSet*> parts;
    for (const auto& p : pieces)
      parts.push_back(vtkDataSet::SafeDownCast(vtkCompositeDataSet::SafeDownCast(p)->GetDataSet(it)));
    vtkSmartPointer<vtkDataSet> merged =
      MergePieces(parts, sel, " of block " + std::to_string(it->GetCurrentFlatIndex()), warnings);
    if (!merged)
      continue;
    // AMR blocks are uniform grids, never split between ranks; anything else: the flat union.
    if (amr && !vtkUniformGrid::SafeDownCast(merged))
      return nullptr;
    whole->SetDataSet(it, merged);
  }
  return whole;
}

/// Different structures: one multiblock of every rank's non-empty leaves (one network over their union).
static vtkSmartPointer<vtkMultiBlockDataSet> FlatUnion(const std::vector<vtkSmartPointer<vtkDataObject>>& pieces)
{
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
  if (SameStructure(pieces, refComposite))
  {
    if (vtkSmartPointer<vtkCompositeDataSet> whole = MergeBlocks(pieces, refComposite, sel, warnings))
      return whole;
  }
  return FlatUnion(pieces);
}

bool ValidExtent(const int* e)
{
  return e && e[0] <= e[1] && e[2] <= e[3] && e[4] <= e[5];
}

} // namespace vtkNeuralCompressInternals
