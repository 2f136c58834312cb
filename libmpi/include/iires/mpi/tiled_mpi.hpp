// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file tiled_mpi.hpp
/// @brief The MPI engine of tiled resampling: tiles spread over the ranks of MPI_COMM_WORLD (DESIGN §9).

#include <exception>
#include <vector>

#include "iires/tile_executor.hpp"

namespace iires {

/// @brief MPI for the lifetime of the object: MPI_Init_thread (funneled: only the main thread calls MPI; the
/// OpenMP threads inside a tile never do) and MPI_Finalize. One per process, before any MpiTileExecutor.
class MpiSession {
 public:
  MpiSession(int& argc, char**& argv);
  ~MpiSession();
  MpiSession(const MpiSession&) = delete;
  MpiSession& operator=(const MpiSession&) = delete;
};

/// @brief A TileExecutor over the ranks of MPI_COMM_WORLD. share() broadcasts each finished tile from its
/// owner, in tile order; agree() turns a failure on any rank into the same kind of exception on every rank
/// (InputError, std::invalid_argument, std::bad_alloc, else std::runtime_error), with the failing rank's message.
/// @note All of its functions are collective: every rank calls them in the same order.
class MpiTileExecutor : public TileExecutor {
 public:
  MpiTileExecutor();
  int rank() const override { return rank_; }
  int ranks() const override { return ranks_; }
  void agree(std::exception_ptr failure) override;
  void share(const std::vector<std::size_t>& tiles, const std::vector<int>& owners,
             std::vector<TileOutcome>& outcomes, std::exception_ptr failure) override;

 private:
  int rank_ = 0, ranks_ = 1;
};

}  // namespace iires
