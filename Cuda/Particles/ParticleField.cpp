#include "ParticleField.h"

#include "Core/Error.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <thread>
#include <vector>

namespace nv
{
namespace
{
/// evaluateMany orders its queries by cell from this many points on.
constexpr int64_t kOrderedQueries = 65536;
}

std::vector<ParticleRecord> ParticleField::Gather(const ParticleInput& input)
{
  NV_CHECK(input.Count >= 0 && input.Count <= (int64_t(1) << 34), "particle count out of range");
  NV_CHECK(input.Count == 0 || (input.Xyz && input.Values), "particle positions and values are needed");
  // 0: used; 1 to 3: a non-finite position, value, radius that is not finite and positive.
  auto problemOf = [&input](int64_t i) {
    const double* p = input.Xyz + 3 * i;
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]))
      return 1;
    if (!std::isfinite(input.Values[i]))
      return 2;
    return input.Radii && !(input.Radii[i] > 0.0 && std::isfinite(input.Radii[i])) ? 3 : 0;
  };
  for (int a = 0; a < 3; ++a)
  {
    this->Bounds[2 * a] = std::numeric_limits<double>::max();
    this->Bounds[2 * a + 1] = -std::numeric_limits<double>::max();
  }
  // Two passes over the input (counts and box, then the records): no index array of the particles used.
  double largestRadius = 0.0;
  for (int64_t i = 0; i < input.Count; ++i)
  {
    const int problem = problemOf(i);
    int64_t* counters[4] = { &this->Counts.Used, &this->Counts.BadPosition, &this->Counts.BadValue,
      &this->Counts.BadRadius };
    ++*counters[problem];
    if (problem != 0)
      continue;
    for (int a = 0; a < 3; ++a)
    {
      this->Bounds[2 * a] = std::min(this->Bounds[2 * a], input.Xyz[3 * i + a]);
      this->Bounds[2 * a + 1] = std::max(this->Bounds[2 * a + 1], input.Xyz[3 * i + a]);
    }
    largestRadius = input.Radii ? std::max(largestRadius, input.Radii[i]) : largestRadius;
  }
  if (this->Counts.Used == 0)
  {
    std::ostringstream s;
    s << "none of the " << input.Count << " particles can be used (" << this->Counts.BadPosition
      << " with a non-finite position, " << this->Counts.BadValue << " with a non-finite value, "
      << this->Counts.BadRadius << " with a radius that is not positive)";
    NV_THROW(s.str());
  }
  // Records in units of the box's largest extent (or of the largest radius for particles at one point), so that
  // 1 / R^3 stays within float's range whatever the data's units (centimetres of a galaxy: 1e24).
  double largest = std::max({ this->Bounds[1] - this->Bounds[0], this->Bounds[3] - this->Bounds[2],
    this->Bounds[5] - this->Bounds[4] });
  largest = largest > 0.0 ? largest : (largestRadius > 0.0 ? largestRadius : this->Options.Radius);
  this->Scale = largest > 0.0 && std::isfinite(largest) ? 1.0 / largest : 1.0;
  std::vector<ParticleRecord> records(size_t(this->Counts.Used));
  size_t k = 0;
  for (int64_t i = 0; i < input.Count; ++i)
  {
    if (problemOf(i) != 0)
      continue;
    ParticleRecord& r = records[k++];
    r.x = float((input.Xyz[3 * i] - this->Bounds[0]) * this->Scale);
    r.y = float((input.Xyz[3 * i + 1] - this->Bounds[2]) * this->Scale);
    r.z = float((input.Xyz[3 * i + 2] - this->Bounds[4]) * this->Scale);
    r.radius = input.Radii ? float(std::min(input.Radii[i] * this->Scale, kMaxRadiusExtents)) : 0.0f;
    this->Counts.ClampedRadius += input.Radii && input.Radii[i] * this->Scale > kMaxRadiusExtents ? 1 : 0;
    r.value = float(input.Values[i]);
  }
  return records;
}

ParticleField::ParticleField(const ParticleInput& input, const ParticleOptions& options)
  : Options(options)
{
  if (!(options.Radius >= 0.0 && std::isfinite(options.Radius)))
    NV_THROW("the particle radius must be >= 0 (0: automatic), not " + std::to_string(options.Radius));
  std::vector<ParticleRecord> records = this->Gather(input);
  const double extent[3] = { (this->Bounds[1] - this->Bounds[0]) * this->Scale,
    (this->Bounds[3] - this->Bounds[2]) * this->Scale, (this->Bounds[5] - this->Bounds[4]) * this->Scale };
  const double spacing = meanParticleSpacing(records, extent); // in the records' units
  this->Spacing = spacing / this->Scale;
  if (!input.Radii)
  {
    double radius = options.Radius * this->Scale;
    if (radius == 0.0)
    {
      if (!(this->Spacing > 0.0))
      {
        std::ostringstream s;
        s << "all " << this->Counts.Used << " particles lie at one point (" << this->Bounds[0] << ", "
          << this->Bounds[2] << ", " << this->Bounds[4] << "): no spacing to choose a radius from and no volume";
        NV_THROW(s.str());
      }
      radius = kAutoRadiusSpacings * spacing;
      this->AutomaticRadius = true;
    }
    this->Counts.ClampedRadius = radius > kMaxRadiusExtents ? this->Counts.Used : 0;
    radius = std::min(radius, kMaxRadiusExtents);
    for (ParticleRecord& r : records)
      r.radius = float(radius);
  }
  this->MinRadius = std::numeric_limits<double>::max();
  for (ParticleRecord& r : records)
  {
    this->ScaledMaxRadius = std::max(this->ScaledMaxRadius, double(r.radius));
    this->MinRadius = std::min(this->MinRadius, double(r.radius) / this->Scale);
    r.invRadius3 = float(1.0 / (double(r.radius) * r.radius * r.radius));
  }
  this->MaxRadius = this->ScaledMaxRadius / this->Scale;
  this->BuildLocator(std::move(records), extent);
}

void ParticleField::BuildLocator(std::vector<ParticleRecord> records, const double extent[3])
{
  // Radius class c holds the radii in (Rmax / 2^(c+1), Rmax / 2^c]; the last class every smaller radius.
  auto classOf = [this](const ParticleRecord& r) {
    const double ratio = this->ScaledMaxRadius / double(r.radius);
    const int c = ratio < 2.0 ? 0 : int(std::floor(std::log2(ratio)));
    return std::min(std::max(c, 0), kRadiusClasses - 1);
  };
  std::vector<int64_t> perClass(size_t(kRadiusClasses), 0);
  for (const ParticleRecord& r : records)
    ++perClass[size_t(classOf(r))];
  std::vector<std::vector<ParticleRecord>> classes;
  if (std::count(perClass.begin(), perClass.end(), int64_t(0)) == kRadiusClasses - 1)
    classes.push_back(std::move(records)); // one radius class (e.g. a constant radius): no copy
  else
  {
    std::vector<int> slot(size_t(kRadiusClasses), -1);
    for (int c = 0; c < kRadiusClasses; ++c)
      if (perClass[size_t(c)] > 0)
      {
        slot[size_t(c)] = int(classes.size());
        classes.emplace_back();
        classes.back().reserve(size_t(perClass[size_t(c)]));
      }
    for (const ParticleRecord& r : records)
      classes[size_t(slot[size_t(classOf(r))])].push_back(r);
    std::vector<ParticleRecord>().swap(records);
  }
  const double lo[3] = { 0.0, 0.0, 0.0 };
  const double hi[3] = { extent[0], extent[1], extent[2] };
  int64_t most = 0;
  for (std::vector<ParticleRecord>& members : classes)
  {
    double reach = 0.0;
    for (const ParticleRecord& r : members)
      reach = std::max(reach, double(r.radius));
    // Cells of the class's largest radius: a query visits the 3^3 cells around its point (at most one cell per
    // particle of the class, at least 4096).
    const int64_t count = int64_t(members.size());
    const int64_t maxCells = std::max<int64_t>(count, 4096);
    if (count > most)
    {
      most = count;
      this->OrderGrid = this->Grids.size();
    }
    this->GridReach.push_back(reach);
    this->Grids.emplace_back(new ParticleGrid(std::move(members), lo, hi, reach, maxCells));
  }
}

int64_t ParticleField::locatorBytes() const
{
  int64_t bytes = 0;
  for (const auto& grid : this->Grids)
    bytes += grid->bytes();
  return bytes;
}

int64_t ParticleField::candidates(const double x[3]) const
{
  const double u[3] = { (x[0] - this->Bounds[0]) * this->Scale, (x[1] - this->Bounds[2]) * this->Scale,
    (x[2] - this->Bounds[4]) * this->Scale };
  int64_t visited = 0;
  this->forEachNear(u, [&visited](const ParticleRecord&) { ++visited; });
  return visited;
}

void ParticleField::sumsAt(const double x[3], double& sumWeighted, double& sumWeight) const
{
  const double u[3] = { (x[0] - this->Bounds[0]) * this->Scale, (x[1] - this->Bounds[2]) * this->Scale,
    (x[2] - this->Bounds[4]) * this->Scale };
  sumWeight = 0.0;
  sumWeighted = 0.0;
  const ParticleKernel kernel = this->Options.Kernel;
  this->forEachNear(u, [&](const ParticleRecord& r) {
    const double dx = u[0] - r.x, dy = u[1] - r.y, dz = u[2] - r.z;
    const double d2 = dx * dx + dy * dy + dz * dz, r2 = double(r.radius) * r.radius;
    if (d2 >= r2)
      return;
    const double w = particleKernel(kernel, std::sqrt(d2 / r2)) * r.invRadius3;
    sumWeight += w;
    sumWeighted += w * r.value;
  });
}

bool ParticleField::evaluate(const double x[3], double& value) const
{
  double sumWeight = 0.0, sumWeighted = 0.0;
  this->sumsAt(x, sumWeighted, sumWeight);
  if (!(sumWeight > 0.0))
    return false;
  // Density: the records' 1 / R^3 are in box units; Scale^3 turns them into the data's.
  value = this->Options.Mode == ParticleFieldMode::Density ? sumWeighted * this->Scale * this->Scale * this->Scale
                                                           : sumWeighted / sumWeight;
  return true;
}

void ParticleField::kernelSums(const double* xyz, int64_t count, double* weighted, double* weights, int threads) const
{
  if (count <= 0)
    return;
  const int cores = std::max(1, int(std::thread::hardware_concurrency()));
  const int n = int(std::min<int64_t>(threads > 0 ? threads : cores, std::max<int64_t>(1, count / 4096)));
  const double scale3 = this->Scale * this->Scale * this->Scale; // 1 / R^3 from box units to the data's
  auto work = [&](int t) {
    for (int64_t i = count * t / n; i < count * (t + 1) / n; ++i)
    {
      this->sumsAt(xyz + 3 * i, weighted[i], weights[i]);
      weighted[i] *= scale3;
      weights[i] *= scale3;
    }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < n; ++t)
    pool.emplace_back(work, t);
  work(0);
  for (std::thread& t : pool)
    t.join();
}

int64_t ParticleField::evaluateMany(const double* xyz, int64_t count, double* values, int threads) const
{
  if (count <= 0)
    return 0;
  const int cores = std::max(1, int(std::thread::hardware_concurrency()));
  const int n = int(std::min<int64_t>(threads > 0 ? threads : cores, std::max<int64_t>(1, count / 4096)));
  const ParticleGrid& grid = *this->Grids[this->OrderGrid];
  std::vector<int64_t> inside(size_t(n), 0);
  // Each thread its share of the points; many scattered points are visited in the order of the locator's cells
  // (each thread sorts its own share), so that neighbouring queries read the same particles from the cache (random
  // bank points against millions of particles: several times faster).
  auto work = [&](int t) {
    const int64_t first = count * t / n, last = count * (t + 1) / n;
    std::vector<std::pair<int64_t, int64_t>> order;
    if (count >= kOrderedQueries)
    {
      order.resize(size_t(last - first));
      for (int64_t i = first; i < last; ++i)
      {
        const double u[3] = { (xyz[3 * i] - this->Bounds[0]) * this->Scale,
          (xyz[3 * i + 1] - this->Bounds[2]) * this->Scale, (xyz[3 * i + 2] - this->Bounds[4]) * this->Scale };
        order[size_t(i - first)] = { grid.cellIndex(u), i };
      }
      std::sort(order.begin(), order.end());
    }
    for (int64_t k = first; k < last; ++k)
    {
      const int64_t i = order.empty() ? k : order[size_t(k - first)].second;
      double v = std::numeric_limits<double>::quiet_NaN();
      inside[size_t(t)] += this->evaluate(xyz + 3 * i, v) ? 1 : 0;
      values[i] = v;
    }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < n; ++t)
    pool.emplace_back(work, t);
  work(0);
  for (std::thread& t : pool)
    t.join();
  int64_t total = 0;
  for (int64_t k : inside)
    total += k;
  return total;
}

std::string ParticleField::describe() const
{
  std::ostringstream s;
  s.precision(4);
  s << this->Counts.Used << " particles, " << particleKernelName(this->Options.Kernel) << " kernel, ";
  if (this->MaxRadius == this->MinRadius)
    s << "radius " << this->MaxRadius;
  else
    s << "radii " << this->MinRadius << " to " << this->MaxRadius;
  if (this->AutomaticRadius)
    s << " (automatic: " << kAutoRadiusSpacings << " x mean spacing " << this->Spacing << ")";
  s << ", " << (this->Options.Mode == ParticleFieldMode::Density ? "density" : "interpolated");
  if (this->Grids.size() > 1)
    s << ", " << this->Grids.size() << " radius classes";
  if (this->Counts.ClampedRadius > 0)
    s << "; " << this->Counts.ClampedRadius << " radii clamped to " << kMaxRadiusExtents << " x the box ("
      << this->MaxRadius << ")";
  const int64_t skipped = this->Counts.BadPosition + this->Counts.BadValue + this->Counts.BadRadius;
  if (skipped > 0)
    s << "; " << skipped << " skipped (" << this->Counts.BadPosition << " non-finite positions, "
      << this->Counts.BadValue << " non-finite values, " << this->Counts.BadRadius << " radii not positive)";
  return s.str();
}

} // namespace nv
