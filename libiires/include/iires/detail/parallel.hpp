// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file parallel.hpp
/// @brief Deterministic parallel loops: every iteration writes only its own slot, so results do not depend
/// on the thread count.

#include <omp.h>

#include <algorithm>
#include <cstddef>

namespace iires {

/// @brief Number of threads to use for a requested count (0 = all cores). Requests above four threads per
/// core are clamped there: more only adds start-up cost (and OpenMP runtimes fail at tens of thousands).
inline int resolveThreads(int requested) {
  if (requested <= 0) return omp_get_max_threads();
  return std::min(requested, 4 * std::max(1, omp_get_num_procs()));
}

/// @brief Run fn(i) for i in [0, n) on @p threads threads (0 = all cores), dynamic chunks of up to 256
/// iterations, fewer for short loops so that every thread gets work.
/// @note fn must only write state owned by iteration i (or thread-local state it merges in a fixed order).
template <typename Fn>
void parallelFor(std::size_t n, int threads, Fn&& fn) {
  const long long count = static_cast<long long>(n);
  const int team = resolveThreads(threads);
  const int chunk = static_cast<int>(std::clamp<long long>(count / (8LL * team), 1, 256));
#pragma omp parallel for schedule(dynamic, chunk) num_threads(team)
  for (long long i = 0; i < count; ++i) fn(static_cast<std::size_t>(i));
}

}  // namespace iires
