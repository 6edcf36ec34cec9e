// MPI (private): rank 0 stitches the image pieces of every rank into the whole image (vtkNeuralCompressPieces.h):
// each piece's owned samples (ghosts left out) copied by extent, after its array and extent are checked.
#include "vtkNeuralCompressPieces.h"

#include "vtkCellData.h"
#include "vtkDataArray.h"
#include "vtkDataObject.h"
#include "vtkDataSetAttributes.h"
#include "vtkDoubleArray.h"
#include "vtkFieldData.h"
#include "vtkImageData.h"
#include "vtkIntArray.h"
#include "vtkPointData.h"
#include "vtkUnsignedCharArray.h"

#include <algorithm>
#include <cstdint>
#include <sstream>
#include <string>
#include <vector>

namespace vtkNeuralCompressInternals
{

/// The pieces with points: the first of them (`firstData`), the first with the array (`ref`), those without it.
struct PieceSurvey
{
  int Ref = -1, FirstData = -1;
  std::vector<int> Missing;
};
static PieceSurvey SurveyPieces(const std::vector<vtkSmartPointer<vtkDataObject>>& pieces)
{
  PieceSurvey survey;
  for (size_t r = 0; r < pieces.size(); ++r)
  {
    auto* image = vtkImageData::SafeDownCast(pieces[r]);
    if (!image || image->GetNumberOfPoints() == 0)
      continue;
    if (survey.FirstData < 0)
      survey.FirstData = int(r);
    auto* found = vtkIntArray::SafeDownCast(image->GetFieldData()->GetArray(kPieceFoundName));
    if (found && found->GetValue(0) == 1)
    {
      if (survey.Ref < 0)
        survey.Ref = int(r);
    }
    else
    {
      survey.Missing.push_back(int(r));
    }
  }
  return survey;
}

/// The origin, spacing and direction a piece carries in its field data, given to `out`.
static void CopyPieceGeometry(vtkImageData* piece, vtkImageData* out)
{
  if (auto* g = vtkDoubleArray::SafeDownCast(piece->GetFieldData()->GetArray(kPieceGeometryName)))
  {
    out->SetOrigin(g->GetValue(0), g->GetValue(1), g->GetValue(2));
    out->SetSpacing(g->GetValue(3), g->GetValue(4), g->GetValue(5));
    double direction[9];
    for (int i = 0; i < 9; ++i)
      direction[i] = g->GetValue(6 + i);
    out->SetDirectionMatrix(direction);
  }
}

/// `wholeExtent` when it is valid, else the union of the extents of the pieces with points.
static void StitchedExtent(const std::vector<vtkSmartPointer<vtkDataObject>>& pieces, const int* wholeExtent, int whole[6])
{
  if (wholeExtent && wholeExtent[0] <= wholeExtent[1] && wholeExtent[2] <= wholeExtent[3] &&
    wholeExtent[4] <= wholeExtent[5])
  {
    std::copy(wholeExtent, wholeExtent + 6, whole);
    return;
  }
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

static vtkDataSetAttributes* AttributesOf(vtkImageData* image, bool cells)
{
  return cells ? static_cast<vtkDataSetAttributes*>(image->GetCellData())
               : static_cast<vtkDataSetAttributes*>(image->GetPointData());
}

/// The reference piece's array (its first that is not the ghost array), or null.
static vtkDataArray* ReferenceArray(vtkImageData* refImage, bool cells)
{
  vtkDataArray* refArray = nullptr;
  for (int i = 0; i < AttributesOf(refImage, cells)->GetNumberOfArrays() && !refArray; ++i)
  {
    vtkDataArray* a = AttributesOf(refImage, cells)->GetArray(i);
    if (a && !(a->GetName() && std::string(a->GetName()) == vtkDataSetAttributes::GhostArrayName()))
      refArray = a;
  }
  return refArray;
}

/// The stitched array being filled: its values, which of them a piece gave, and the whole image's samples.
struct StitchTarget
{
  vtkSmartPointer<vtkDataArray> Values;
  std::vector<uint8_t> Covered;
  std::string Name;
  bool Cells = false;
  int Ref = -1;
  int Whole[6];
  int WholeLo[3], WholeHi[3];
  vtkIdType SamplesX = 0, SamplesY = 0, Count = 0; ///< samples along x, along y, in all
};

/// The target for `refArray` (its type, name, components) over the whole extent.
static void PrepareStitchTarget(vtkDataArray* refArray, const int whole[6], StitchTarget& t)
{
  std::copy(whole, whole + 6, t.Whole);
  SampleRange(whole, t.Cells, t.WholeLo, t.WholeHi);
  t.SamplesX = t.WholeHi[0] - t.WholeLo[0] + 1;
  t.SamplesY = t.WholeHi[1] - t.WholeLo[1] + 1;
  const vtkIdType n2 = t.WholeHi[2] - t.WholeLo[2] + 1;
  t.Count = t.SamplesX * t.SamplesY * n2;
  t.Values.TakeReference(refArray->NewInstance());
  t.Values->SetName(refArray->GetName());
  t.Values->SetNumberOfComponents(refArray->GetNumberOfComponents());
  for (int c = 0; c < refArray->GetNumberOfComponents(); ++c)
  {
    if (refArray->GetComponentName(c))
      t.Values->SetComponentName(c, refArray->GetComponentName(c));
  }
  t.Values->SetNumberOfTuples(t.Count);
  t.Covered.assign(size_t(t.Count), 0);
}

/// The samples of piece `r` that its rank owns (not ghosts) copied into the target, row by row in runs.
static void CopyOwnedSamples(vtkImageData* image, vtkDataArray* a, const int lo[3], const int hi[3], StitchTarget& t)
{
  const unsigned char duplicate = t.Cells ? static_cast<unsigned char>(vtkDataSetAttributes::DUPLICATECELL)
                                          : static_cast<unsigned char>(vtkDataSetAttributes::DUPLICATEPOINT);
  const vtkIdType l0 = hi[0] - lo[0] + 1, l1 = hi[1] - lo[1] + 1, l2 = hi[2] - lo[2] + 1;
  auto* ghost = vtkUnsignedCharArray::SafeDownCast(
    AttributesOf(image, t.Cells)->GetAbstractArray(vtkDataSetAttributes::GhostArrayName()));
  if (ghost && ghost->GetNumberOfTuples() != a->GetNumberOfTuples())
    ghost = nullptr;
  for (vtkIdType k = 0; k < l2; ++k)
  {
    for (vtkIdType j = 0; j < l1; ++j)
    {
      const vtkIdType src = (k * l1 + j) * l0;
      const vtkIdType dst =
        ((lo[2] - t.WholeLo[2] + k) * t.SamplesY + (lo[1] - t.WholeLo[1] + j)) * t.SamplesX + (lo[0] - t.WholeLo[0]);
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
        t.Values->InsertTuples(dst + i, end - i, src + i, a);
        std::fill(t.Covered.begin() + (dst + i), t.Covered.begin() + (dst + end), uint8_t(1));
        i = end;
      }
    }
  }
}

/// Piece `r` into the target after checking its array and extent; false with `problem` set when it does not fit.
static bool StitchPiece(vtkImageData* image, size_t r, StitchTarget& t, std::string& problem)
{
  vtkDataArray* a = AttributesOf(image, t.Cells)->GetArray(t.Name.c_str());
  if (!a || a->GetDataType() != t.Values->GetDataType() ||
    a->GetNumberOfComponents() != t.Values->GetNumberOfComponents())
  {
    problem = "the input array '" + t.Name + "' of rank " + std::to_string(r) +
      (a ? " differs in type or components from rank " + std::to_string(t.Ref) + "'s"
         : " is not a " + std::string(t.Cells ? "cell" : "point") + " array like rank " + std::to_string(t.Ref) + "'s");
    return false;
  }
  const int* e = image->GetExtent();
  int lo[3], hi[3];
  SampleRange(e, t.Cells, lo, hi);
  bool inside = true;
  for (int ax = 0; ax < 3; ++ax)
  {
    inside &= lo[ax] >= t.WholeLo[ax] && hi[ax] <= t.WholeHi[ax];
    // A piece one point thick along an axis of the whole image has no cells of it.
    if (t.Cells && e[2 * ax] == e[2 * ax + 1] && t.Whole[2 * ax] < t.Whole[2 * ax + 1])
      inside = false;
  }
  if (!inside)
  {
    if (t.Cells)
      return true;
    std::ostringstream s;
    s << "the piece of rank " << r << " (extent " << e[0] << " " << e[1] << " " << e[2] << " " << e[3] << " "
      << e[4] << " " << e[5] << ") lies outside the whole extent";
    problem = s.str();
    return false;
  }
  const vtkIdType l0 = hi[0] - lo[0] + 1, l1 = hi[1] - lo[1] + 1, l2 = hi[2] - lo[2] + 1;
  if (a->GetNumberOfTuples() != l0 * l1 * l2)
  {
    problem = "the input array '" + t.Name + "' of rank " + std::to_string(r) + " has " +
      std::to_string(a->GetNumberOfTuples()) + " tuples for " + std::to_string(l0 * l1 * l2) +
      (t.Cells ? " cells" : " points");
    return false;
  }
  CopyOwnedSamples(image, a, lo, hi, t);
  return true;
}

/// Rank 0: the image pieces stitched into one image of `wholeExtent` (null: the union of the pieces' extents).
vtkSmartPointer<vtkImageData> StitchImages(
  const std::vector<vtkSmartPointer<vtkDataObject>>& pieces, const int* wholeExtent, std::string& problem)
{
  // The reference piece (the first with the array) gives the array's name, type, components and association.
  const PieceSurvey survey = SurveyPieces(pieces);
  auto out = vtkSmartPointer<vtkImageData>::New();
  // Geometry: of the first piece with points (the origin is the whole image's on every piece), else rank 0's.
  auto* geometrySource = vtkImageData::SafeDownCast(pieces[survey.FirstData >= 0 ? size_t(survey.FirstData) : 0]);
  if (!geometrySource)
  {
    problem = "rank 0 has no image piece of the input";
    return nullptr;
  }
  CopyPieceGeometry(geometrySource, out);
  if (survey.FirstData < 0)
  {
    // No rank has a point: an empty image, which the filter reports as in serial.
    out->SetExtent(geometrySource->GetExtent());
    return out;
  }
  int whole[6];
  StitchedExtent(pieces, wholeExtent, whole);
  out->SetExtent(whole);
  if (survey.Ref < 0)
  {
    // No piece has the array: the whole image without it (the filter reports the missing array as in serial).
    return out;
  }
  auto* refImage = vtkImageData::SafeDownCast(pieces[size_t(survey.Ref)]);
  const int association = vtkIntArray::SafeDownCast(refImage->GetFieldData()->GetArray(kPieceFoundName))->GetValue(1);
  StitchTarget t;
  t.Cells = association == vtkDataObject::FIELD_ASSOCIATION_CELLS;
  t.Ref = survey.Ref;
  vtkDataArray* refArray = ReferenceArray(refImage, t.Cells);
  if (!refArray)
  {
    problem = "the image piece of rank " + std::to_string(survey.Ref) + " lost its array in transit";
    return nullptr;
  }
  t.Name = refArray->GetName() ? refArray->GetName() : "";
  if (!survey.Missing.empty())
  {
    problem = "the input array '" + t.Name + "' is missing on the piece of " + RankList(survey.Missing) +
      " (every rank's piece of the image needs it)";
    return nullptr;
  }
  PrepareStitchTarget(refArray, whole, t);
  for (size_t r = 0; r < pieces.size(); ++r)
  {
    auto* image = vtkImageData::SafeDownCast(pieces[r]);
    if (image && image->GetNumberOfPoints() != 0 && !StitchPiece(image, r, t, problem))
      return nullptr;
  }
  const vtkIdType done = std::count(t.Covered.begin(), t.Covered.end(), uint8_t(1));
  if (done != t.Count)
  {
    problem = "the pieces of the " + std::to_string(pieces.size()) + " ranks cover " + std::to_string(done) +
      " of the " + std::to_string(t.Count) + (t.Cells ? " cells" : " points") + " of the whole extent";
    return nullptr;
  }
  vtkDataSetAttributes* attributes = AttributesOf(out, t.Cells);
  attributes->AddArray(t.Values);
  // Found by name as on the pieces; by the active attribute when the filter selects one instead of a name.
  const int type = vtkDataSetAttributes::SCALARS;
  attributes->SetActiveAttribute(attributes->GetNumberOfArrays() - 1, type);
  return out;
}

} // namespace vtkNeuralCompressInternals
