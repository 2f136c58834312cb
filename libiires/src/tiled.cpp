// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/tiled.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <exception>
#include <limits>
#include <numeric>
#include <optional>
#include <stdexcept>

#include <Eigen/Geometry>

#include "iires/detail/json.hpp"
#include "iires/detail/parallel.hpp"
#include "iires/detail/stage_clock.hpp"
#include "iires/detail/tile_grid.hpp"
#include "iires/detail/tile_spill.hpp"
#include "iires/knn.hpp"
#include "iires/metrics.hpp"
#include "iires/point_stream.hpp"
#include "iires/tile_executor.hpp"
#include "crowded.hpp"

namespace iires {
namespace {

using detail::TileGrid;
using detail::TileSpill;
using Clock = std::chrono::steady_clock;

constexpr std::size_t kMaxTiles = 4096;
constexpr int kAreaNeighbours = 8;
constexpr int kContextRelaxFactor = 3;  // the k-th neighbour's distance gives a sample point's share of the area

std::uint64_t splitMix(std::uint64_t& state) {
  std::uint64_t z = (state += 0x9e3779b97f4a7c15ull);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

/// What the first pass learns: bounds, the point count and a uniform sample (reservoir sampling, seeded) with
/// each sample point's share of the surface area.
struct Survey {
  Eigen::AlignedBox3d bounds;
  std::size_t points = 0;
  bool normals = false;
  std::vector<Eigen::Vector3d> sample;
  std::vector<double> area;
  double totalArea = 0;
};

Survey survey(PointStream& stream, const ResampleParams& params, const TileParams& tp) {
  Survey s;
  s.normals = stream.hasNormals();
  std::uint64_t state = params.seed;
  PointCloud chunk;
  while (stream.next(chunk, tp.chunkPoints)) {
    for (const Eigen::Vector3d& p : chunk.points) {
      s.bounds.extend(p);
      if (s.sample.size() < tp.surveyPoints) {
        s.sample.push_back(p);
      } else if (const std::uint64_t j = splitMix(state) % (s.points + 1); j < tp.surveyPoints) {
        s.sample[j] = p;
      }
      ++s.points;
    }
  }
  if (s.points == 0) throw InputError("the input holds no points");
  return s;
}

/// Each sample point's share of the surface: for points spread uniformly on a surface, π r_k² / k with r_k the
/// distance to the k-th nearest neighbour estimates the area per point (unbiased for a Poisson sample).
void surveyAreas(Survey& s, int threads) {
  s.area.assign(s.sample.size(), 0.0);
  if (s.sample.size() <= static_cast<std::size_t>(kAreaNeighbours)) {
    const double d = s.bounds.diagonal().norm();
    s.area.assign(s.sample.size(), d * d / static_cast<double>(std::max<std::size_t>(s.sample.size(), 1)));
  } else {
    const KnnIndex index(s.sample);
    parallelFor(s.sample.size(), threads, [&](std::size_t i) {
      thread_local std::vector<std::uint32_t> idx;
      thread_local std::vector<double> d2;
      index.knn(s.sample[i], kAreaNeighbours + 1, idx, d2);
      s.area[i] = M_PI * d2.back() / kAreaNeighbours;
    });
  }
  s.totalArea = std::accumulate(s.area.begin(), s.area.end(), 0.0);
}

/// Shares of @p n proportional to @p weights, summing to @p n exactly: floors, then one more to the largest
/// remainders (ties to the lower index).
std::vector<std::size_t> apportion(const std::vector<double>& weights, std::size_t n) {
  const double total = std::accumulate(weights.begin(), weights.end(), 0.0);
  std::vector<std::size_t> share(weights.size(), 0);
  std::vector<std::pair<double, std::size_t>> remainder;
  std::size_t given = 0;
  for (std::size_t t = 0; t < weights.size(); ++t) {
    const double q = total > 0 ? static_cast<double>(n) * weights[t] / total : 0.0;
    share[t] = static_cast<std::size_t>(std::floor(q));
    given += share[t];
    remainder.emplace_back(-(q - std::floor(q)), t);
  }
  std::sort(remainder.begin(), remainder.end());
  for (std::size_t r = 0; given < n; r = (r + 1) % remainder.size(), ++given) ++share[remainder[r].second];
  return share;
}

/// The number of tiles of edge @p size over the survey's bounds.
std::size_t gridCount(const Survey& s, double size) {
  double count = 1;
  for (int a = 0; a < 3; ++a) count *= std::max(1.0, std::ceil(s.bounds.sizes()[a] / size));
  return count > 1e15 ? std::numeric_limits<std::size_t>::max() : static_cast<std::size_t>(count);
}

/// The grid with tiles of edge @p size over the survey's bounds.
TileGrid makeGrid(const Survey& s, double size, double margin) {
  if (const std::size_t count = gridCount(s, size); count > kMaxTiles)
    throw std::invalid_argument("a tile size of " + std::to_string(size) + " makes " + std::to_string(count) +
                                " tiles; at most " + std::to_string(kMaxTiles));
  TileGrid g;
  g.origin = s.bounds.min();
  g.size = size;
  g.margin = margin;
  for (int a = 0; a < 3; ++a)
    g.dims[a] = std::max(1, static_cast<int>(std::ceil(s.bounds.sizes()[a] / size)));
  return g;
}

/// Per tile, the survey sample points in its region (what the tile will load, up to the sample's scale).
std::vector<std::size_t> regionCounts(const Survey& s, const TileGrid& g) {
  std::vector<std::size_t> count(g.count(), 0);
  for (const Eigen::Vector3d& p : s.sample) g.forEachRegion(p, [&](std::size_t t) { ++count[t]; });
  return count;
}

/// The largest number of input points one tile's region holds, estimated from the regions' survey points @p load.
double largestRegion(const Survey& s, const std::vector<std::size_t>& load) {
  return static_cast<double>(*std::max_element(load.begin(), load.end())) * static_cast<double>(s.points) /
         static_cast<double>(s.sample.size());
}

/// The grid's critical path, in survey points (@p load per tile): the colours run one after another and a
/// colour's tiles side by side, so with unlimited processes a run takes the sum over colours of the largest
/// tile's work (its region).
double criticalPath(const TileGrid& g, const std::vector<std::size_t>& load) {
  std::array<std::size_t, 8> largest{};
  for (std::size_t t = 0; t < g.count(); ++t) largest[g.colour(t)] = std::max(largest[g.colour(t)], load[t]);
  return static_cast<double>(std::accumulate(largest.begin(), largest.end(), std::size_t{0}));
}

/// The tile grid: the given tile size, or the largest tiles whose regions fit @p capacity points. Tiles are
/// never smaller than two margins (a region then meets only adjacent tiles). Once the input needs more than one
/// tile, the tiles shrink further until the critical path is at most 1/kParallelism of the sample: processes
/// share each colour's round, and a colour of one large tile would leave all but one idle. The rule ignores the
/// process count, so the grid (and the output) is the same for any number of ranks.
TileGrid chooseGrid(const Survey& s, const TileParams& tp, double margin, std::size_t capacity) {
  constexpr double kParallelism = 8;
  constexpr double kSpreadMargins = 16;  // spreading stops at tiles this many margins wide (the margins' overlap
                                         // then adds at most (1 + 2/16)² − 1 ≈ 27 % to a tile's area)
  const double minSize = std::max(2.0 * margin, 1e-12 * s.bounds.diagonal().norm());
  if (tp.tileSize > 0) return makeGrid(s, std::max(tp.tileSize, minSize), margin);
  double size = std::max(s.bounds.sizes().maxCoeff() * (1 + 1e-9), minSize);
  const auto fits = [&](const TileGrid& g) {
    const std::vector<std::size_t> load = regionCounts(s, g);
    return largestRegion(s, load) <= 0.9 * static_cast<double>(capacity) &&
           (g.count() == 1 || size * 0.8 < kSpreadMargins * margin ||
            criticalPath(g, load) <= static_cast<double>(s.sample.size()) / kParallelism);
  };
  for (;;) {
    const TileGrid g = makeGrid(s, size, margin);
    if (fits(g) || size <= minSize) return g;
    const double next = std::max(size * 0.8, minSize);
    if (gridCount(s, next) > kMaxTiles) return g;
    size = next;
  }
}

/// Each tile's process: a colour's tiles, largest region first, each to the process with the least load so far
/// (ties to the lower rank). The assignment changes only who computes a tile, never its result.
std::vector<int> owners(const Survey& s, const TileGrid& g, int ranks) {
  const std::vector<std::size_t> load = regionCounts(s, g);
  std::vector<int> owner(g.count(), 0);
  for (int colour = 0; colour < 8; ++colour) {
    std::vector<std::size_t> tiles;
    for (std::size_t t = 0; t < g.count(); ++t)
      if (g.colour(t) == colour) tiles.push_back(t);
    std::stable_sort(tiles.begin(), tiles.end(), [&](std::size_t a, std::size_t b) { return load[a] > load[b]; });
    std::vector<std::size_t> rankLoad(static_cast<std::size_t>(ranks), 0);
    for (std::size_t t : tiles) {
      const auto least = std::min_element(rankLoad.begin(), rankLoad.end());
      owner[t] = static_cast<int>(least - rankLoad.begin());
      *least += load[t];
    }
  }
  return owner;
}

/// Pass 2: every point into the spill file of each tile of @p rank whose region holds it.
void spill(PointStream& stream, const TileGrid& g, TileSpill& files, std::size_t chunkPoints,
           const std::vector<int>& owner, int rank) {
  stream.rewind();
  PointCloud chunk;
  while (stream.next(chunk, chunkPoints))
    for (std::size_t i = 0; i < chunk.size(); ++i)
      g.forEachRegion(chunk.points[i], [&](std::size_t t) {
        if (owner[t] == rank) files.add(t, chunk, i);
      });
  files.flush();
}

/// Runs @p f; every process of @p executor then learns whether it failed anywhere (and throws if so).
template <class F>
void together(TileExecutor& executor, F&& f) {
  std::exception_ptr failure;
  try {
    f();
  } catch (...) {
    failure = std::current_exception();
  }
  executor.agree(failure);
}

/// @p own without its @p surplus most crowded samples (detail::mostCrowded(), the held @p context among their
/// neighbours).
PointCloud dropMostCrowded(const PointCloud& own, const std::vector<Eigen::Vector3d>& context, std::size_t surplus) {
  std::vector<Eigen::Vector3d> all = own.points;
  all.insert(all.end(), context.begin(), context.end());
  std::vector<char> held(all.size(), 1);
  std::fill(held.begin(), held.begin() + static_cast<std::ptrdiff_t>(own.size()), 0);
  const std::vector<char> drop = detail::mostCrowded(all, held, surplus);
  PointCloud kept;
  for (std::size_t i = 0; i < own.size(); ++i)
    if (!drop[i]) kept.points.push_back(own.points[i]), kept.normals.push_back(own.normals[i]);
  return kept;
}

/// The state of a tiled run: which tiles are finished, their samples, and the quotas still to meet.
struct TileRun {
  const ResampleParams& params;
  int threads;
  const TileGrid& grid;
  const Survey& survey;
  const TileSpill& files;
  std::size_t capacity;
  double contextReach;  // context samples come from the region grown by this much: a free sample at the
                        // region's edge still sees the finished samples just beyond it
  std::vector<std::vector<std::size_t>> regionSample;  // per tile: the survey sample points in its region
  std::vector<std::size_t> sampleTile;                  // per survey sample point: its tile
  std::vector<char> finished;
  std::vector<PointCloud> samples;
  std::vector<TileReport> reports;

  /// Resamples tile @p t (reading only tiles of earlier colours), keeps at most its quota, and picks the largest
  /// unfinished neighbour (else nearestLaterTile()) to take its shortfall.
  TileOutcome process(std::size_t t) const;
  /// Records @p t's outcome: its samples, its report, and its shortfall added to its heir's quota.
  void finish(std::size_t t, TileOutcome outcome);

 private:
  std::vector<Eigen::Vector3d> context(std::size_t t) const;
  std::size_t nearestLaterTile(std::size_t t) const;
  std::size_t unfinishedMargin(std::size_t t) const;
  PointCloud keepOwn(std::size_t t, PointCloud out) const;
};

/// Where every neighbour of @p t is finished (or holds no surface), its shortfall goes to the nearest tile of a
/// later colour that holds some (nearest by cell, then lowest index); grid.count() when there is none.
std::size_t TileRun::nearestLaterTile(std::size_t t) const {
  const std::array<int, 3> c = grid.cell(t);
  std::size_t best = grid.count();
  long long bestD2 = 0;
  for (std::size_t u = 0; u < grid.count(); ++u) {
    if (grid.colour(u) <= grid.colour(t) || reports[u].share == 0) continue;
    const std::array<int, 3> cu = grid.cell(u);
    long long d2 = 0;
    for (int a = 0; a < 3; ++a) d2 += static_cast<long long>(cu[a] - c[a]) * (cu[a] - c[a]);
    if (best == grid.count() || d2 < bestD2) best = u, bestD2 = d2;
  }
  return best;
}

std::vector<Eigen::Vector3d> TileRun::context(std::size_t t) const {
  TileGrid reach = grid;
  reach.margin += contextReach;
  std::vector<Eigen::Vector3d> held;
  grid.forEachNeighbour(t, [&](std::size_t u) {
    if (!finished[u]) return;
    for (const Eigen::Vector3d& p : samples[u].points)
      if (reach.inRegion(t, p)) held.push_back(p);
  });
  return held;
}

/// Samples the part of @p t's margin in unfinished tiles will take (they are resampled and dropped: the core's
/// samples near the seam then see the surface go on).
std::size_t TileRun::unfinishedMargin(std::size_t t) const {
  double area = 0;
  for (std::size_t i : regionSample[t])
    if (const std::size_t u = sampleTile[i]; u != t && !finished[u]) area += survey.area[i];
  return static_cast<std::size_t>(
      std::llround(area / survey.totalArea * static_cast<double>(params.targetCount)));
}

/// The samples of @p out not in an unfinished tile's core (those are that tile's to place).
PointCloud TileRun::keepOwn(std::size_t t, PointCloud out) const {
  PointCloud own;
  for (std::size_t i = 0; i < out.size(); ++i) {
    const std::size_t u = grid.tileOf(out.points[i]);
    if (u != t && !finished[u]) continue;
    own.points.push_back(out.points[i]);
    own.normals.push_back(out.normals[i]);
  }
  return own;
}

TileOutcome TileRun::process(std::size_t t) const {
  const auto start = Clock::now();
  TileOutcome outcome;
  TileReport& report = outcome.report;
  report = reports[t];
  const long long quota = report.quota;
  if (quota > 0 && files.count(t) >= 4) {
    ResampleParams p = params;
    p.contextSamples = context(t);
    p.targetCount = static_cast<std::size_t>(quota) + unfinishedMargin(t);
    if (!p.contextSamples.empty()) {  // free samples settle against held ones more slowly: relax them longer
      p.maxRelaxIterations *= kContextRelaxFactor;
      p.relaxPatience = std::max(p.relaxPatience, kContextRelaxFactor);
    }
    report.context = p.contextSamples.size();
    report.requested = p.targetCount;
    PointCloud points = files.read(t, capacity, params.seed);
    report.loadedPoints = points.size();
    try {
      outcome.samples = keepOwn(t, resample(std::move(points), p, Execution{threads}).cloud);
      // A tile places at most its quota: a surplus passed on would lower a neighbour's quota, and the last
      // tiles of a region, their quotas gone negative, could not return it.
      if (const auto q = static_cast<std::size_t>(quota); outcome.samples.size() > q)
        outcome.samples = dropMostCrowded(outcome.samples, p.contextSamples, outcome.samples.size() - q);
    } catch (const InputError&) {
      outcome.samples = {};  // too few or degenerate points for a surface: the quota passes on
    }
  }
  report.produced = outcome.samples.size();
  report.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  outcome.rest = quota - static_cast<long long>(report.produced);
  if (outcome.rest == 0) return outcome;
  // Tiles of t's colour are never its neighbours: the heir is the same whichever of them finished first.
  outcome.heir = grid.count();
  grid.forEachNeighbour(t, [&](std::size_t u) {
    if (!finished[u] && reports[u].share > 0 &&
        (outcome.heir == grid.count() || reports[u].share > reports[outcome.heir].share))
      outcome.heir = u;
  });
  if (outcome.heir == grid.count()) outcome.heir = nearestLaterTile(t);
  if (outcome.heir == grid.count())
    throw std::runtime_error("tiled resampling: tile " + std::to_string(t) + " produced " +
                             std::to_string(report.produced) + " samples for a quota of " + std::to_string(quota) +
                             " and no tile is left to run that could take the difference");
  return outcome;
}

void TileRun::finish(std::size_t t, TileOutcome outcome) {
  finished[t] = 1;
  samples[t] = std::move(outcome.samples);
  reports[t] = outcome.report;
  if (outcome.rest != 0) reports[outcome.heir].quota += outcome.rest;
}

/// The run's tiles in order: reports (with each tile's owner), and the survey sample assigned to tiles and regions.
TileRun prepareRun(const ResampleParams& params, int threads, const TileGrid& grid, const Survey& s,
                   const TileSpill& files, const std::vector<int>& owner, std::size_t capacity,
                   double contextReach) {
  TileRun run{params, threads, grid, s, files, capacity, contextReach,
              std::vector<std::vector<std::size_t>>(grid.count()), {}, {}, {}, {}};
  run.sampleTile.resize(s.sample.size());
  std::vector<double> area(grid.count(), 0.0);
  for (std::size_t i = 0; i < s.sample.size(); ++i) {
    run.sampleTile[i] = grid.tileOf(s.sample[i]);
    area[run.sampleTile[i]] += s.area[i];
    grid.forEachRegion(s.sample[i], [&](std::size_t t) { run.regionSample[t].push_back(i); });
  }
  const std::vector<std::size_t> share = apportion(area, params.targetCount);
  run.finished.assign(grid.count(), 0);
  run.samples.resize(grid.count());
  run.reports.resize(grid.count());
  for (std::size_t t = 0; t < grid.count(); ++t) {
    TileReport& r = run.reports[t];
    r.index = t;
    r.cell = grid.cell(t);
    r.colour = grid.colour(t);
    r.rank = owner[t];
    r.points = files.count(t);
    r.share = share[t];
    r.quota = static_cast<long long>(share[t]);
  }
  return run;
}

/// Pass 3: the tiles colour by colour, each process resampling its own; after each colour every process holds
/// every outcome and records them in tile order.
void runColours(TileRun& run, TileSpill& files, const std::vector<int>& owner, TileExecutor& executor,
                const Execution& exec, std::vector<StageTime>& timings) {
  const TileGrid& grid = run.grid;
  std::size_t before = 0;
  for (int colour = 0; colour < 8; ++colour) {
    std::vector<std::size_t> tiles;
    std::vector<int> owners;
    for (std::size_t t = 0; t < grid.count(); ++t)
      if (grid.colour(t) == colour) tiles.push_back(t), owners.push_back(owner[t]);
    if (tiles.empty()) continue;
    const auto tc = Clock::now();
    std::vector<TileOutcome> outcomes(tiles.size());
    std::exception_ptr failure;
    try {
      for (std::size_t i = 0; i < tiles.size(); ++i) {
        if (owners[i] != executor.rank()) continue;
        outcomes[i] = run.process(tiles[i]);
        files.release(tiles[i]);
        exec.report("tiles", static_cast<double>(before + i + 1) / static_cast<double>(grid.count()));
      }
    } catch (...) {
      failure = std::current_exception();
    }
    executor.share(tiles, owners, outcomes, failure);
    for (std::size_t i = 0; i < tiles.size(); ++i) run.finish(tiles[i], std::move(outcomes[i]));
    before += tiles.size();
    timings.push_back({"colour_" + std::to_string(colour), std::chrono::duration<double>(Clock::now() - tc).count()});
  }
}

}  // namespace

void TileParams::validate() const {
  if (!(tileSize >= 0)) throw std::invalid_argument("the tile size must be > 0 (or 0 = auto)");
  if (!(memoryBudgetGB > 0)) throw std::invalid_argument("the memory budget must be > 0 GB");
  if (!(marginSpacings >= 2)) throw std::invalid_argument("the tile margin must be at least 2 spacings");
  if (surveyPoints < 1000) throw std::invalid_argument("the survey sample must hold at least 1000 points");
  if (chunkPoints < 1) throw std::invalid_argument("chunkPoints must be >= 1");
}

std::size_t TileParams::tileCapacity(std::size_t outputPoints) const {
  constexpr double kOutputBytesPerPoint = 128;  // finished samples, their copy in the output, context copies
  constexpr double kReserveBytes = 2e8;         // the survey sample and its k-d tree, read buffers
  const double free = memoryBudgetGB * 1e9 - kOutputBytesPerPoint * static_cast<double>(outputPoints) - kReserveBytes;
  return static_cast<std::size_t>(std::max(1e5, free / kBytesPerInputPoint));
}

std::string TiledResult::toJson() const {
  detail::JsonWriter j;
  j.beginObject(true).member("input_points", inputPoints).member("requested_points", requestedPoints);
  j.member("output_points", cloud.size());
  j.key("grid").beginArray().value(grid[0]).value(grid[1]).value(grid[2]).endArray();
  j.key("origin").beginArray().value(origin.x()).value(origin.y()).value(origin.z()).endArray();
  j.member("tile_size", tileSize).member("margin", margin).member("target_spacing", spacing).member("area", area);
  j.member("tile_capacity", tileCapacity);
  j.key("spacing").beginObject().member("mean", spacingStats.mean).member("min", spacingStats.min);
  j.member("max", spacingStats.max).member("cv", spacingStats.cv).endObject();
  j.key("tiles").beginArray();
  for (const TileReport& t : tiles) {
    j.beginObject().member("index", t.index).member("colour", t.colour).member("rank", t.rank);
    j.member("points", t.points);
    j.member("loaded_points", t.loadedPoints).member("share", t.share).member("quota", t.quota);
    j.member("requested", t.requested).member("context", t.context).member("produced", t.produced);
    j.member("time_s", t.seconds).endObject();
  }
  j.endArray();
  j.key("time_s").beginObject();
  for (const StageTime& t : timings) j.member(t.name, t.seconds);
  j.endObject().endObject();
  return j.str() + "\n";
}

TiledResult resampleTiled(const std::string& path, const ResampleParams& params, const TileParams& tp,
                          const Execution& exec) {
  TileExecutor local;
  return resampleTiled(path, params, tp, exec, local);
}

TiledResult resampleTiled(const std::string& path, const ResampleParams& params, const TileParams& tp,
                          const Execution& exec, TileExecutor& executor) {
  params.validate();
  exec.validate();
  tp.validate();
  if (!params.fixedSamples.empty() || !params.contextSamples.empty() || params.ringEdges)
    throw std::invalid_argument("tiled resampling takes no fixed or context samples and gives no ring edges");
  const auto start = Clock::now();
  TiledResult result;
  result.requestedPoints = params.targetCount;
  const StageClock clock(result.timings, exec.progress);

  auto t0 = clock.begin("survey");
  std::optional<PointStream> stream;
  Survey s;
  TileGrid grid;
  together(executor, [&] {
    stream.emplace(path);
    s = survey(*stream, params, tp);
    surveyAreas(s, exec.threads);
    result.inputPoints = s.points;
    result.area = s.totalArea;
    result.spacing = std::sqrt(2.0 * s.totalArea / (std::sqrt(3.0) * static_cast<double>(params.targetCount)));
    result.margin = tp.marginSpacings * result.spacing;
    result.tileCapacity = tp.tileCapacity(params.targetCount);
    grid = chooseGrid(s, tp, result.margin, result.tileCapacity);
  });
  result.grid = grid.dims;
  result.origin = grid.origin;
  result.tileSize = grid.size;
  clock.end("survey", t0);

  t0 = clock.begin("spill");
  const std::vector<int> owner = owners(s, grid, executor.ranks());
  std::optional<detail::ScratchDirectory> scratch;
  std::optional<TileSpill> files;
  together(executor, [&] {
    scratch.emplace(tp.scratchDir);
    constexpr double kSpillBufferBytes = 6.4e7;  // all tiles' write buffers together
    files.emplace(scratch->path(), grid.count(), s.normals,
                  static_cast<std::size_t>(std::clamp(kSpillBufferBytes / static_cast<double>(grid.count()), 6.5e4, 4e6)));
    spill(*stream, grid, *files, tp.chunkPoints, owner, executor.rank());
  });
  clock.end("spill", t0);

  TileRun run = prepareRun(params, exec.threads, grid, s, *files, owner, result.tileCapacity, 2 * result.spacing);
  runColours(run, *files, owner, executor, exec, result.timings);

  t0 = clock.begin("assemble");
  for (PointCloud& c : run.samples) {
    result.cloud.points.insert(result.cloud.points.end(), c.points.begin(), c.points.end());
    result.cloud.normals.insert(result.cloud.normals.end(), c.normals.begin(), c.normals.end());
    c = {};
  }
  if (result.cloud.size() != params.targetCount)
    throw std::runtime_error("tiled resampling produced " + std::to_string(result.cloud.size()) + " points, not " +
                             std::to_string(params.targetCount));
  result.spacingStats = spacingStats(result.cloud.points, exec.threads);
  result.tiles = std::move(run.reports);
  clock.end("assemble", t0);
  clock.end("total", start);
  return result;
}

}  // namespace iires
