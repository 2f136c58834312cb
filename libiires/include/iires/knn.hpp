// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file knn.hpp
/// @brief k-nearest-neighbour and radius search over a fixed set of 3-D points (nanoflann behind a PImpl).

#include <Eigen/Core>
#include <algorithm>
#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

namespace iires {

/// @brief A static k-d tree over points. The referenced vector must outlive the index and stay unchanged.
/// @note Queries are const and thread-safe. Results are sorted by distance; ties keep a deterministic order.
class KnnIndex {
 public:
  explicit KnnIndex(const std::vector<Eigen::Vector3d>& points);
  ~KnnIndex();
  KnnIndex(KnnIndex&&) noexcept;
  KnnIndex& operator=(KnnIndex&&) noexcept;
  KnnIndex(const KnnIndex&) = delete;
  KnnIndex& operator=(const KnnIndex&) = delete;

  /// @brief The @p k nearest points to @p query (fewer if the set is smaller).
  /// @param[out] indices point indices, nearest first
  /// @param[out] sqDists squared distances, same order
  /// @return number of neighbours found
  std::size_t knn(const Eigen::Vector3d& query, std::size_t k, std::vector<std::uint32_t>& indices,
                  std::vector<double>& sqDists) const;

  /// @brief All points within distance @p radius of @p query, nearest first.
  std::size_t radius(const Eigen::Vector3d& query, double radius, std::vector<std::uint32_t>& indices,
                     std::vector<double>& sqDists) const;

  /// @brief Index of the nearest point (or -1 when the set is empty); @p sqDist receives its squared distance.
  std::int64_t nearest(const Eigen::Vector3d& query, double* sqDist = nullptr) const;

  std::size_t size() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// @brief The k nearest neighbours of every point of a set, found once for the stages that each read the
/// first few of every row (outlier test, denoising, geodesic graph, MLS kernel widths: one k-NN pass instead
/// of four). Row i holds what KnnIndex::knn(points[i], k) returns (point i itself among them, nearest first) —
/// except where its nearest lie on a scan line (a lidar's sampling, dense along lines and sparse across): that
/// row keeps four of its line's points and fills up with the nearest off the line, so that fits, kernel widths
/// and graphs over any prefix of six or more reach across (scan_lines.hpp). get() hands out a prefix with the
/// squared distances recomputed, so the table costs 4 bytes per neighbour.
/// @note The points must outlive the table and stay unchanged (the index is only read while constructing).
class NeighbourTable {
 public:
  NeighbourTable(const KnnIndex& index, const std::vector<Eigen::Vector3d>& points, std::size_t k,
                 int threads = 0);

  std::size_t k() const { return k_; }
  std::size_t size() const { return found_.size(); }
  /// @brief The first min(@p k, found) neighbours of point @p i, as KnnIndex::knn(points()[i], k) gives them.
  /// @pre k ≤ k()
  std::size_t get(std::size_t i, std::size_t k, std::vector<std::uint32_t>& indices,
                  std::vector<double>& sqDists) const;
  /// @brief Where row @p i was widened across scan lines: the distance from point i to the nearest point off its
  /// line (the spacing across the lines there); else 0.
  float acrossLines(std::size_t i) const { return across_.empty() ? 0.0f : across_[i]; }
  /// @brief How many rows were widened across scan lines.
  std::size_t linePoints() const {
    return static_cast<std::size_t>(std::count_if(across_.begin(), across_.end(), [](float d) { return d > 0; }));
  }
  /// @brief Keeps the first @p k neighbours of every row and frees the rest, for readers that need no more
  /// (get() with up to @p k gives what it gave). No effect when k ≥ k().
  void truncate(std::size_t k);
  /// @brief Keeps, in every row, the neighbours @p keep(i, j) accepts (in their order; the point itself is
  /// always kept), so that every reader of the table sees only those (e.g. the sheet rule, sheets.hpp).
  /// Rows in which fewer than @p minKept neighbours besides the point itself would remain are left whole.
  /// @p keep is called concurrently. @return the number of (directed) entries removed.
  /// @param threads 0 = all cores; the result does not depend on it
  std::size_t filter(const std::function<bool(std::size_t i, std::size_t j)>& keep, std::size_t minKept,
                     int threads = 0);

 private:
  const std::vector<Eigen::Vector3d>& points_;
  std::size_t k_;
  std::vector<std::uint32_t> rows_;  // size()·k, row-major
  std::vector<std::uint8_t> found_;  // per row (≤ k ≤ 255)
  std::vector<float> across_;        // acrossLines() per row; empty when no row was widened
};

/// @brief A permutation that puts points in Morton (Z-curve) order: points close in space end up close in
/// memory, so loops over them and k-d tree queries from them stay in cache. Ties keep index order.
/// @param threads 0 = all cores; the order does not depend on it
/// @note O(n) (radix sort of the 63-bit codes); deterministic.
std::vector<std::uint32_t> mortonOrder(const std::vector<Eigen::Vector3d>& points, int threads = 0);

}  // namespace iires
