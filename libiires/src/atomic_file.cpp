// SPDX-License-Identifier: GPL-3.0-or-later
#include "atomic_file.hpp"

#include <unistd.h>

#include <atomic>
#include <climits>
#include <cstring>
#include <filesystem>
#include <mutex>

#include "iires/io.hpp"

namespace iires::detail {
namespace {

namespace fs = std::filesystem;

// The signal handler may only read plain memory: temporaries live in a fixed table of paths, each slot
// claimed by a flag. A handler that sees a flag set unlinks that path (unlink is async-signal-safe).
constexpr int kSlots = 64;
char gPaths[kSlots][PATH_MAX];
std::atomic<bool> gUsed[kSlots];
std::mutex gClaim;
std::atomic<unsigned> gCounter{0};

int claimSlot(const std::string& path) {
  if (path.size() >= PATH_MAX) return -1;
  const std::lock_guard<std::mutex> lock(gClaim);
  for (int s = 0; s < kSlots; ++s) {
    if (gUsed[s].load(std::memory_order_acquire)) continue;
    std::memcpy(gPaths[s], path.c_str(), path.size() + 1);
    gUsed[s].store(true, std::memory_order_release);
    return s;
  }
  return -1;  // more than kSlots outputs at once: still written, just not removed on a signal
}

void releaseSlot(int slot) {
  if (slot >= 0) gUsed[slot].store(false, std::memory_order_release);
}

}  // namespace

TemporaryFile::TemporaryFile(const std::string& target) : target_(target) {
  const fs::path t(target);
  const fs::path directory = t.has_parent_path() ? t.parent_path() : fs::path(".");
  path_ = (directory / (".iires." + std::to_string(::getpid()) + "." + std::to_string(gCounter++) + ".tmp")).string();
  slot_ = claimSlot(path_);
}

TemporaryFile::TemporaryFile(TemporaryFile&& other) noexcept
    : path_(std::move(other.path_)), target_(std::move(other.target_)), slot_(other.slot_),
      committed_(other.committed_) {
  other.slot_ = -1;
  other.committed_ = true;  // the moved-from object owns nothing
}

TemporaryFile::~TemporaryFile() {
  if (!committed_) ::unlink(path_.c_str());
  releaseSlot(slot_);
}

std::string TemporaryFile::commit() {
  std::error_code ec;
  fs::rename(path_, target_, ec);
  if (ec) return ec.message();
  committed_ = true;
  releaseSlot(slot_);
  slot_ = -1;
  return {};
}

SignalBlock::SignalBlock() {
  sigset_t block;
  sigemptyset(&block);
  for (int s : {SIGINT, SIGTERM, SIGHUP}) sigaddset(&block, s);
  pthread_sigmask(SIG_BLOCK, &block, &saved_);
}

SignalBlock::~SignalBlock() { pthread_sigmask(SIG_SETMASK, &saved_, nullptr); }

}  // namespace iires::detail

namespace iires {
namespace {

extern "C" void removeTemporariesAndDie(int signal) {
  for (int s = 0; s < detail::kSlots; ++s)
    if (detail::gUsed[s].load(std::memory_order_acquire)) ::unlink(detail::gPaths[s]);
  ::signal(signal, SIG_DFL);
  ::raise(signal);
}

}  // namespace

void removeTemporariesOnSignal() {
  struct sigaction action {};
  action.sa_handler = removeTemporariesAndDie;
  sigemptyset(&action.sa_mask);
  for (int s : {SIGINT, SIGTERM, SIGHUP}) ::sigaction(s, &action, nullptr);
}

}  // namespace iires
