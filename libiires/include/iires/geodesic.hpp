// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file geodesic.hpp
/// @brief Geodesic coordinates of a point cloud (paper §3.2, "efficient intrinsic control"; DESIGN §3 step 6):
/// a symmetric k-NN graph that does not cross thin gaps, its connected components, three *satellites* per
/// component chosen by geodesic farthest-point sampling, and for every point the geodesic coordinates
/// G(p) = (g1, g2, g3), gᵢ(p) = geodesic distance from p to satellite i of p's component.
///
/// Distances are computed on the graph by a Dijkstra sweep with fast-marching-like *segment updates*: when a
/// point c is reached from a settled neighbour a, the front is also interpolated linearly along the segment
/// between a and another settled neighbour b of c (the Tsitsiklis / semi-Lagrangian update
/// t(c) = min_λ [λ t(a) + (1−λ) t(b) + |c − (λ a + (1−λ) b)|]), which is exact for a planar front. Plain
/// Dijkstra on a k-NN graph follows zig-zag paths and overestimates by several percent; see
/// tests/geodesic_test.cpp for the measured error of both on a 20k-point unit sphere.

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "iires/execution.hpp"
#include "iires/io.hpp"
#include "iires/knn.hpp"
#include "iires/types.hpp"

namespace iires {

/// @brief Parameters of the geodesic graph and fields.
struct GeodesicParams {
  int k = 16;              ///< graph neighbours per point before filtering (8–32; 16 is accurate and fast)
  /// keep an edge only when each endpoint is among the other's k nearest (a row widened across scan lines
  /// excepted: its links to the next lines stand one way)
  bool mutualNeighbours = true;
  int spacingNeighbour = 6;      ///< local spacing ρ(p) = distance to this nearest neighbour (1 ≤ · ≤ k)
  /// An edge pq is dropped when |p − q| > maxEdgeRatio · min(ρ(p), ρ(q)) (0 = no length bound).
  double maxEdgeRatio = 3.0;
  /// Tangent test: an edge is dropped when the edge direction makes more than this angle (degrees) with the
  /// tangent planes at *both* endpoints (cross-gap edges run along the normal). 90 = off. Uses the given
  /// normals, or PCA normals of the k nearest neighbours when the cloud has none.
  double maxEdgeSlopeDeg = 50.0;
  /// With given (oriented) normals only: an edge is dropped when the endpoint normals differ by more than
  /// this angle (degrees): facing sheets across a gap have opposite normals. 180 = off.
  double maxNormalAngleDeg = 120.0;
  bool fastMarching = true;  ///< segment updates on top of Dijkstra (false = plain Dijkstra on edge lengths)
  int satellites = 3;        ///< satellites (geodesic coordinates) per component [paper: 3]
  /// Components with fewer points are attached to a larger one through their shortest k-NN link (isolated
  /// specks from filtering); 0 or 1 = never attach.
  std::size_t minComponentSize = 16;

  /// @throws std::invalid_argument with a readable message when a field is out of range.
  void validate() const;
};

/// @brief Wall times and sizes of the last build.
struct GeodesicReport {
  std::size_t points = 0;
  std::size_t edges = 0;               ///< undirected graph edges
  std::size_t components = 0;          ///< connected components after attaching tiny ones
  std::size_t attachedComponents = 0;  ///< tiny components attached to a larger one
  double spacing = 0;                  ///< median nearest-neighbour distance of the cloud
  double graphSeconds = 0;             ///< k-NN search, filtering, adjacency
  double componentSeconds = 0;         ///< union-find and attaching
  double satelliteSeconds = 0;         ///< picking satellite 1 (farthest from each component's first point)
  double fieldSeconds = 0;             ///< the satellites' distance fields (farthest-point sampling on them)
  double totalSeconds = 0;

  /// @brief The report as a JSON object.
  std::string toJson() const;
};

/// @brief Geodesic coordinates of a cloud, built once and queried many times.
///
/// Build: k-NN graph (filtered: mutual neighbours, length bound by the local spacing, tangent and normal
/// tests, so it does not cross gaps of a few spacings) → connected components (union-find; components
/// smaller than minComponentSize attached by their shortest k-NN link) → per component (components in
/// parallel): satellite 1 = the point farthest (straight-line) from the component's first point, satellite
/// s+1 = the point farthest from satellites 1..s on their accurate fields, which are the coordinates gₛ —
/// except satellite 3, farthest from satellite 1 on g₁ and from satellite 2 in straight line, so that fields
/// 2 and 3 are swept at once when a thread is free (equal on any thread count). Points are processed
/// internally in Z-order for cache locality; every public index is the caller's.
/// @note Cost O(n k log n) for the graph, O(n k + n log n) per field (satellites fields per component);
/// memory O(n k).
/// Deterministic: same cloud and params give the same coordinates for any thread count (ties broken by
/// point index).
class GeodesicCoordinates {
 public:
  using Alongside =
      std::function<void(int threads, const KnnIndex* pointIndex, const std::vector<float>& samplingScales)>;

  /// @param cloud points, with normals (oriented) or without
  /// @param table (optional) neighbour lists of exactly cloud.points with k ≥ params.k + 1, borrowed for the
  /// build of the graph, to save its k-NN search; not read once @p alongside runs (which may free it)
  /// @param alongside (optional) work that does not need the coordinates, called once with the number of
  /// threads it may use, the k-d tree over cloud.points when they came in Z-order (mortonOrder(), as the
  /// resampler's working cloud does), else null (the tree lives as long as this object), and samplingScales().
  /// It runs during the satellite sweeps when those leave threads idle (fewer components than threads: each
  /// component's sweeps are serial), else after them. Its exceptions propagate.
  /// @throws InputError when the cloud is empty or has non-finite coordinates; std::invalid_argument for
  /// bad params.
  explicit GeodesicCoordinates(const PointCloud& cloud, const GeodesicParams& params = {}, const Execution& exec = {},
                               const NeighbourTable* table = nullptr, const Alongside& alongside = {});
  ~GeodesicCoordinates();
  GeodesicCoordinates(GeodesicCoordinates&&) noexcept;
  GeodesicCoordinates& operator=(GeodesicCoordinates&&) noexcept;
  GeodesicCoordinates(const GeodesicCoordinates&) = delete;
  GeodesicCoordinates& operator=(const GeodesicCoordinates&) = delete;

  std::size_t size() const;
  const std::vector<Eigen::Vector3d>& points() const;
  /// @brief The normals the cloud was built with (empty when it had none).
  const std::vector<Eigen::Vector3d>& normals() const;
  /// @brief Index of the cloud point nearest to @p query (-1 only for an empty cloud); thread-safe.
  /// @param[out] sqDist squared distance to it, when not null
  std::int64_t nearest(const Eigen::Vector3d& query, double* sqDist = nullptr) const;
  const GeodesicParams& params() const;

  /// @brief Number of coordinates per point (params().satellites).
  int dimensions() const;
  /// @brief Coordinate @p s of point @p i: geodesic distance to satellite s of its component.
  float coordinate(std::size_t i, int s) const;
  /// @brief All coordinates, point-major: coordinates()[i·dimensions() + s].
  const std::vector<float>& coordinates() const;

  std::size_t components() const;
  /// @brief Component of point @p i, in [0, components()); components are numbered by their first point.
  std::uint32_t component(std::size_t i) const;
  const std::vector<std::uint32_t>& componentIds() const;
  std::size_t componentSize(std::size_t c) const;
  /// @brief Point indices of component @p c's satellites (dimensions() of them; may repeat in a tiny one).
  const std::vector<std::uint32_t>& satellites(std::size_t c) const;

  /// @brief Geodesic distances from @p source to every point (+infinity outside its component), computed
  /// on the same graph and with the same method as the coordinates.
  /// @note O(m k + m log m) for a component of m points; thread-safe.
  std::vector<float> distanceField(std::uint32_t source) const;
  /// @brief As distanceField(), with the fast-marching updates switched on or off (for comparison).
  std::vector<float> distanceField(std::uint32_t source, bool fastMarching) const;

  /// @brief Median nearest-neighbour distance of the cloud.
  double spacing() const;
  /// @brief Estimated surface area: Σ over points of π·d², d the point's nearest-neighbour distance (a random
  /// sampling's mean d is half the distance between points, whatever its density, so parts sparser than the
  /// median count with their own spacing).
  double area() const;
  /// @brief Per point: how much more coarsely than the cloud its component is sampled (a separate object
  /// scanned sparsely) — the component's median nearest-neighbour distance over the cloud's, at least 1.
  const std::vector<float>& samplingScales() const;
  /// @brief Per point: samplingScales(), or how much more coarsely than the cloud its own neighbourhood is sampled
  /// where that is at least twice (the median nearest-neighbour distance over the point and its graph neighbours,
  /// over the cloud's): the far side of a single scan, whose density falls with the range.
  const std::vector<float>& localScales() const;
  /// @brief Undirected graph edges as (a, b), a < b, sorted — for inspection and tests.
  std::vector<std::array<std::uint32_t, 2>> edges() const;
  const GeodesicReport& report() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// @brief Write the cloud with its geodesic coordinates as a binary PLY: x y z (double), nx ny nz when the
/// cloud had normals, then g1 g2 g3 (float) and component (uint), so the fields can be viewed in any viewer.
/// @note Atomic (temporary file + rename) like writePointCloud. @throws InputError when the file cannot be
/// written ("cannot write <path>: <problem>") or the extension is not .ply.
void writeGeodesicPly(const std::string& path, const GeodesicCoordinates& geo);
/// @brief The same, staged in @p batch (committed with the run's other outputs).
void writeGeodesicPly(OutputBatch& batch, const std::string& path, const GeodesicCoordinates& geo);

}  // namespace iires
