// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/mpi/tiled_mpi.hpp"

#include <mpi.h>

#include <algorithm>
#include <climits>
#include <cstdint>
#include <cstring>
#include <new>
#include <stdexcept>
#include <string>
#include <type_traits>

namespace iires {
namespace {

static_assert(std::is_trivially_copyable_v<TileReport>, "a tile's report travels as raw bytes");

/// What kind of exception a failure was, so that every rank can throw the same kind.
enum class FailureKind : int { kInput = 1, kInvalidArgument, kOutOfMemory, kOther };

void check(int code, const char* call) {
  if (code != MPI_SUCCESS) throw std::runtime_error(std::string("MPI: ") + call + " failed");
}

/// Broadcasts @p bytes from @p root to every rank (in pieces: MPI counts are ints).
void broadcast(std::string& bytes, int root) {
  std::uint64_t size = bytes.size();
  check(MPI_Bcast(&size, 1, MPI_UINT64_T, root, MPI_COMM_WORLD), "MPI_Bcast");
  bytes.resize(size);
  constexpr std::uint64_t kPiece = 1u << 30;
  for (std::uint64_t at = 0; at < size; at += kPiece) {
    const int n = static_cast<int>(std::min(kPiece, size - at));
    check(MPI_Bcast(bytes.data() + at, n, MPI_BYTE, root, MPI_COMM_WORLD), "MPI_Bcast");
  }
}

template <class T>
void put(std::string& out, const T& value) {
  out.append(reinterpret_cast<const char*>(&value), sizeof(T));
}

template <class T>
T take(const std::string& in, std::size_t& at) {
  T value;
  std::memcpy(&value, in.data() + at, sizeof(T));
  at += sizeof(T);
  return value;
}

void putPoints(std::string& out, const std::vector<Eigen::Vector3d>& points) {
  put<std::uint64_t>(out, points.size());
  for (const Eigen::Vector3d& p : points) out.append(reinterpret_cast<const char*>(p.data()), 3 * sizeof(double));
}

std::vector<Eigen::Vector3d> takePoints(const std::string& in, std::size_t& at) {
  std::vector<Eigen::Vector3d> points(take<std::uint64_t>(in, at));
  for (Eigen::Vector3d& p : points) {
    std::memcpy(p.data(), in.data() + at, 3 * sizeof(double));
    at += 3 * sizeof(double);
  }
  return points;
}

/// A tile's outcome as bytes: report, heir, rest, samples (positions, normals) as the owner computed them.
std::string encode(const TileOutcome& o) {
  std::string out;
  put(out, o.report);
  put<std::uint64_t>(out, o.heir);
  put(out, o.rest);
  putPoints(out, o.samples.points);
  putPoints(out, o.samples.normals);
  return out;
}

TileOutcome decode(const std::string& in) {
  TileOutcome o;
  std::size_t at = 0;
  o.report = take<TileReport>(in, at);
  o.heir = take<std::uint64_t>(in, at);
  o.rest = take<long long>(in, at);
  o.samples.points = takePoints(in, at);
  o.samples.normals = takePoints(in, at);
  return o;
}

std::pair<FailureKind, std::string> describe(std::exception_ptr failure) {
  try {
    std::rethrow_exception(failure);
  } catch (const InputError& e) {
    return {FailureKind::kInput, e.what()};
  } catch (const std::invalid_argument& e) {
    return {FailureKind::kInvalidArgument, e.what()};
  } catch (const std::bad_alloc&) {
    return {FailureKind::kOutOfMemory, "out of memory"};
  } catch (const std::exception& e) {
    return {FailureKind::kOther, e.what()};
  } catch (...) {
    return {FailureKind::kOther, "unknown failure"};
  }
}

}  // namespace

MpiSession::MpiSession(int& argc, char**& argv) {
  int provided = 0;
  check(MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided), "MPI_Init_thread");
}

MpiSession::~MpiSession() { MPI_Finalize(); }

MpiTileExecutor::MpiTileExecutor() {
  check(MPI_Comm_rank(MPI_COMM_WORLD, &rank_), "MPI_Comm_rank");
  check(MPI_Comm_size(MPI_COMM_WORLD, &ranks_), "MPI_Comm_size");
}

void MpiTileExecutor::agree(std::exception_ptr failure) {
  const int mine = failure ? rank_ : ranks_;
  int first = ranks_;  // the lowest rank that failed; its failure is the one the others report
  check(MPI_Allreduce(&mine, &first, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD), "MPI_Allreduce");
  if (first == ranks_) return;
  auto [kind, message] = failure ? describe(failure) : std::pair<FailureKind, std::string>{};
  int code = static_cast<int>(kind);
  check(MPI_Bcast(&code, 1, MPI_INT, first, MPI_COMM_WORLD), "MPI_Bcast");
  broadcast(message, first);
  if (failure) std::rethrow_exception(failure);
  message = "rank " + std::to_string(first) + ": " + message;
  switch (static_cast<FailureKind>(code)) {
    case FailureKind::kInput:
      throw InputError(message);
    case FailureKind::kInvalidArgument:
      throw std::invalid_argument(message);
    case FailureKind::kOutOfMemory:
      throw std::bad_alloc();
    default:
      throw std::runtime_error(message);
  }
}

void MpiTileExecutor::share(const std::vector<std::size_t>& tiles, const std::vector<int>& owners,
                            std::vector<TileOutcome>& outcomes, std::exception_ptr failure) {
  agree(failure);
  for (std::size_t i = 0; i < tiles.size(); ++i) {
    if (ranks_ == 1) break;
    std::string bytes = owners[i] == rank_ ? encode(outcomes[i]) : std::string();
    broadcast(bytes, owners[i]);
    if (owners[i] != rank_) outcomes[i] = decode(bytes);
  }
}

}  // namespace iires
