// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/knn.hpp"

#include <algorithm>
#include <nanoflann.hpp>

#include "iires/detail/parallel.hpp"
#include "iires/detail/radix_sort.hpp"
#include "scan_lines.hpp"

namespace iires {
namespace {

struct Adaptor {
  const std::vector<Eigen::Vector3d>& pts;
  std::size_t kdtree_get_point_count() const { return pts.size(); }
  double kdtree_get_pt(std::size_t i, std::size_t d) const { return pts[i][static_cast<Eigen::Index>(d)]; }
  template <class Box>
  bool kdtree_get_bbox(Box&) const {
    return false;
  }
};

using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, Adaptor>, Adaptor, 3,
                                                 std::uint32_t>;

// nanoflann 1.5 renamed the search options (SearchParams → SearchParameters, without the ignored `checks`) and
// made the radius search fill ResultItem (fields first/second, as the std::pair it replaced) instead of pairs.
#if NANOFLANN_VERSION >= 0x150
using RadiusMatches = std::vector<nanoflann::ResultItem<std::uint32_t, double>>;
nanoflann::SearchParameters sortedSearch() { return nanoflann::SearchParameters(0.0f, true); }
#else
using RadiusMatches = std::vector<std::pair<std::uint32_t, double>>;
nanoflann::SearchParams sortedSearch() { return nanoflann::SearchParams(32, 0.0f, true); }
#endif

}  // namespace

struct KnnIndex::Impl {
  explicit Impl(const std::vector<Eigen::Vector3d>& p)
      : adaptor{p}, tree(3, adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(16)) {}  // the constructor builds
  Adaptor adaptor;
  Tree tree;
};

KnnIndex::KnnIndex(const std::vector<Eigen::Vector3d>& points) : impl_(std::make_unique<Impl>(points)) {}
KnnIndex::~KnnIndex() = default;
KnnIndex::KnnIndex(KnnIndex&&) noexcept = default;
KnnIndex& KnnIndex::operator=(KnnIndex&&) noexcept = default;

std::size_t KnnIndex::size() const { return impl_->adaptor.pts.size(); }

std::size_t KnnIndex::knn(const Eigen::Vector3d& query, std::size_t k, std::vector<std::uint32_t>& indices,
                          std::vector<double>& sqDists) const {
  k = std::min(k, size());
  indices.resize(k);
  sqDists.resize(k);
  if (k == 0) return 0;
  const std::size_t found = impl_->tree.knnSearch(query.data(), k, indices.data(), sqDists.data());
  indices.resize(found);
  sqDists.resize(found);
  return found;
}

std::size_t KnnIndex::radius(const Eigen::Vector3d& query, double radius, std::vector<std::uint32_t>& indices,
                             std::vector<double>& sqDists) const {
  indices.clear();
  sqDists.clear();
  if (size() == 0) return 0;
  RadiusMatches matches;
  impl_->tree.radiusSearch(query.data(), radius * radius, matches, sortedSearch());
  indices.reserve(matches.size());
  sqDists.reserve(matches.size());
  for (const auto& m : matches) {
    indices.push_back(m.first);
    sqDists.push_back(m.second);
  }
  return matches.size();
}

std::int64_t KnnIndex::nearest(const Eigen::Vector3d& query, double* sqDist) const {
  if (size() == 0) return -1;
  std::uint32_t index = 0;
  double d2 = 0;
  impl_->tree.knnSearch(query.data(), 1, &index, &d2);
  if (sqDist) *sqDist = d2;
  return index;
}

NeighbourTable::NeighbourTable(const KnnIndex& index, const std::vector<Eigen::Vector3d>& points,
                               std::size_t k, int threads)
    : points_(points),
      k_(std::min<std::size_t>(k, 255)),
      rows_(points.size() * k_),
      found_(points.size()) {
  parallelFor(points.size(), threads, [&](std::size_t i) {
    thread_local std::vector<std::uint32_t> idx;
    thread_local std::vector<double> d2;
    const std::size_t f = index.knn(points[i], k_, idx, d2);
    std::copy_n(idx.begin(), f, rows_.begin() + static_cast<long>(i * k_));
    found_[i] = static_cast<std::uint8_t>(f);
  });
  across_ = detail::widenAcrossScanLines(points, index, k_, rows_.data(), found_.data(), threads);
}

std::size_t NeighbourTable::get(std::size_t i, std::size_t k, std::vector<std::uint32_t>& indices,
                                std::vector<double>& sqDists) const {
  const std::size_t f = std::min<std::size_t>(k, found_[i]);
  const std::uint32_t* row = rows_.data() + i * k_;
  indices.assign(row, row + f);
  sqDists.resize(f);
  const Eigen::Vector3d& p = points_[i];
  for (std::size_t j = 0; j < f; ++j) {  // in nanoflann's order of terms, so the values are the tree's
    const Eigen::Vector3d& q = points_[row[j]];
    const double dx = p.x() - q.x(), dy = p.y() - q.y(), dz = p.z() - q.z();
    sqDists[j] = dx * dx + dy * dy + dz * dz;
  }
  return f;
}

void NeighbourTable::truncate(std::size_t k) {
  if (k >= k_) return;
  for (std::size_t i = 0; i < found_.size(); ++i) {
    std::copy_n(rows_.begin() + static_cast<long>(i * k_), k, rows_.begin() + static_cast<long>(i * k));
    found_[i] = static_cast<std::uint8_t>(std::min<std::size_t>(found_[i], k));
  }
  k_ = k;
  rows_.resize(found_.size() * k);
  rows_.shrink_to_fit();
}

std::size_t NeighbourTable::filter(const std::function<bool(std::size_t, std::size_t)>& keep, std::size_t minKept,
                                   int threads) {
  std::vector<std::uint8_t> kept(found_.size());
  std::vector<std::uint32_t> scratch(rows_.size());
  parallelFor(found_.size(), threads, [&](std::size_t i) {
    const std::uint32_t* row = rows_.data() + i * k_;
    std::uint32_t* out = scratch.data() + i * k_;
    std::size_t w = 0, others = 0;
    for (std::size_t a = 0; a < found_[i]; ++a)
      if (row[a] == i || keep(i, static_cast<std::size_t>(row[a]))) {
        others += row[a] != i;
        out[w++] = row[a];
      }
    kept[i] = static_cast<std::uint8_t>(others >= minKept ? w : found_[i]);
    if (others < minKept) std::copy_n(row, found_[i], out);
  });
  std::size_t removed = 0;
  for (std::size_t i = 0; i < found_.size(); ++i) removed += found_[i] - kept[i];
  rows_.swap(scratch);
  found_.swap(kept);
  return removed;
}

namespace {
/// The 21 low bits of @p x spread to every third bit.
std::uint64_t spreadBits(std::uint64_t x) {
  x &= 0x1fffff;
  x = (x | x << 32) & 0x1f00000000ffffull;
  x = (x | x << 16) & 0x1f0000ff0000ffull;
  x = (x | x << 8) & 0x100f00f00f00f00full;
  x = (x | x << 4) & 0x10c30c30c30c30c3ull;
  x = (x | x << 2) & 0x1249249249249249ull;
  return x;
}
}  // namespace

std::vector<std::uint32_t> mortonOrder(const std::vector<Eigen::Vector3d>& points, int threads) {
  std::vector<std::uint32_t> order(points.size());
  if (points.empty()) return order;
  Eigen::Vector3d lo = points[0], hi = points[0];
  for (const auto& p : points) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  const double extent = (hi - lo).maxCoeff();
  const double scale = extent > 0 ? 2097151.0 / extent : 0.0;
  std::vector<KeyedIndex> keyed(points.size());
  parallelFor(points.size(), threads, [&](std::size_t i) {
    const Eigen::Vector3d q = (points[i] - lo) * scale;
    keyed[i] = {spreadBits(static_cast<std::uint64_t>(q.x())) | spreadBits(static_cast<std::uint64_t>(q.y())) << 1 |
                    spreadBits(static_cast<std::uint64_t>(q.z())) << 2,
                static_cast<std::uint32_t>(i)};
  });
  // Already in Z-order (the resampler's working cloud, met again by each stage that sorts): no sort needed.
  const bool sorted = std::is_sorted(
      keyed.begin(), keyed.end(), [](const KeyedIndex& a, const KeyedIndex& b) { return a.first < b.first; });
  if (!sorted) radixSort(keyed, threads);  // stable: ties keep index order
  for (std::size_t i = 0; i < keyed.size(); ++i) order[i] = keyed[i].second;
  return order;
}

}  // namespace iires
