// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/attributes.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

#include "iires/knn.hpp"
#include "iires/detail/parallel.hpp"

namespace iires {
namespace {

/// The source points a target draws from and their weights (summing to 1).
struct Stencil {
  std::vector<std::uint32_t> index;
  std::vector<double> weight;
};

/// @param normal the target's unit normal, or null; @param maxSine sine of the largest slope accepted
void computeStencil(const KnnIndex& tree, const std::vector<Eigen::Vector3d>& source, const Eigen::Vector3d& target,
                    const Eigen::Vector3d* normal, double maxSine, const SameSheet& sameSheet, std::size_t k,
                    Stencil& out) {
  thread_local std::vector<std::uint32_t> idx;
  thread_local std::vector<double> d2;
  tree.knn(target, k, idx, d2);
  out.index.clear();
  std::vector<double>& dist2 = out.weight;  // the squared distances first, the weights below
  dist2.clear();
  for (std::size_t j = 0; j < idx.size(); ++j) {
    const Eigen::Vector3d& p = source[idx[j]];
    if (normal && std::abs(normal->dot(p - target)) > maxSine * std::sqrt(d2[j])) continue;  // off the plane
    if (sameSheet && !sameSheet(target, p)) continue;
    out.index.push_back(idx[j]);
    dist2.push_back(d2[j]);
  }
  if (out.index.empty()) {  // nothing on the target's sheet among its neighbours: its nearest point
    out.index.push_back(idx[0]);
    dist2.push_back(d2[0]);
  }
  double mean = 0;
  for (const double d : dist2) mean += std::sqrt(d);
  mean /= static_cast<double>(dist2.size());
  double total = 0;
  for (double& w : dist2) {
    w = mean > 0 ? std::exp(-w / (mean * mean)) : 1.0;
    total += w;
  }
  for (double& w : dist2) w /= total;
}

double weightedMean(const std::vector<double>& values, const Stencil& s) {
  double v = 0;
  for (std::size_t j = 0; j < s.index.size(); ++j) v += s.weight[j] * values[s.index[j]];
  return v;
}

double weightedMajority(const std::vector<double>& values, const Stencil& s) {
  thread_local std::vector<std::pair<double, double>> votes;  // (label, total weight), sorted by label
  votes.clear();
  for (std::size_t j = 0; j < s.index.size(); ++j) {
    const double label = values[s.index[j]];
    auto it = std::lower_bound(votes.begin(), votes.end(), label,
                               [](const std::pair<double, double>& v, double l) { return v.first < l; });
    if (it == votes.end() || it->first != label) it = votes.insert(it, {label, 0.0});
    it->second += s.weight[j];
  }
  auto best = votes.begin();  // the first (smallest) label with the largest weight
  for (auto it = votes.begin(); it != votes.end(); ++it)
    if (it->second > best->second) best = it;
  return best->first;
}

}  // namespace

void AttributeParams::validate() const {
  if (neighbours < 1) throw std::invalid_argument("attributes: neighbours must be at least 1");
  if (!(maxSlopeDeg > 0 && maxSlopeDeg <= 90)) throw std::invalid_argument("attributes: maxSlopeDeg must be in (0, 90]");
}

std::vector<PointAttribute> interpolateAttributes(const PointCloud& source, const std::vector<Eigen::Vector3d>& targets,
                                                  const std::vector<Eigen::Vector3d>& targetNormals,
                                                  const SameSheet& sameSheet, const AttributeParams& params,
                                                  const Execution& exec) {
  params.validate();
  if (!targetNormals.empty() && targetNormals.size() != targets.size())
    throw std::invalid_argument("attributes: expected one normal per target");
  for (const PointAttribute& a : source.attributes)
    if (a.values.size() != source.size())
      throw std::invalid_argument("attributes: \"" + a.name + "\" has " + std::to_string(a.values.size()) +
                                  " values for " + std::to_string(source.size()) + " points");
  std::vector<PointAttribute> out;
  for (const PointAttribute& a : source.attributes) {
    out.push_back({a.name, a.kind, a.type, {}});
    out.back().values.resize(targets.size());
  }
  if (out.empty() || targets.empty()) return out;
  if (source.empty()) throw std::invalid_argument("attributes: the source cloud is empty");

  const KnnIndex tree(source.points);
  const auto k = static_cast<std::size_t>(params.neighbours);
  const bool slopeTest = !targetNormals.empty() && params.maxSlopeDeg < 90;
  const double maxSine = std::sin(params.maxSlopeDeg * M_PI / 180.0);
  parallelFor(targets.size(), exec.threads, [&](std::size_t i) {
    thread_local Stencil stencil;
    computeStencil(tree, source.points, targets[i], slopeTest ? &targetNormals[i] : nullptr, maxSine, sameSheet, k,
                   stencil);
    for (std::size_t a = 0; a < out.size(); ++a) {
      const std::vector<double>& values = source.attributes[a].values;
      out[a].values[i] = source.attributes[a].kind == AttributeKind::kLabel ? weightedMajority(values, stencil)
                                                                             : weightedMean(values, stencil);
    }
  });
  return out;
}

}  // namespace iires
