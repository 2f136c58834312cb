// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/detail/tile_spill.hpp"

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>

namespace iires::detail {

namespace fs = std::filesystem;

ScratchDirectory::ScratchDirectory(const std::string& parent) {
  std::error_code error;
  const fs::path base = parent.empty() ? fs::temp_directory_path(error) : fs::path(parent);
  if (!fs::is_directory(base, error))
    throw InputError("scratch directory " + base.string() + ": not an existing directory");
  std::string name = (base / "iires-tiles-XXXXXX").string();
  if (!::mkdtemp(name.data()))
    throw InputError("scratch directory " + base.string() + ": cannot create a directory in it (" +
                     std::strerror(errno) + ")");
  path_ = name;
}

ScratchDirectory::~ScratchDirectory() {
  std::error_code error;
  fs::remove_all(path_, error);
}

TileSpill::TileSpill(const std::string& directory, std::size_t tiles, bool normals, std::size_t bufferBytes)
    : directory_(directory),
      normals_(normals),
      bufferBytes_(bufferBytes),
      recordBytes_((normals ? 6 : 3) * sizeof(double)),
      buffers_(tiles),
      counts_(tiles, 0) {}

std::string TileSpill::file(std::size_t t) const { return (fs::path(directory_) / ("tile" + std::to_string(t))).string(); }

void TileSpill::add(std::size_t t, const PointCloud& cloud, std::size_t i) {
  std::string& b = buffers_[t];
  b.append(reinterpret_cast<const char*>(cloud.points[i].data()), 3 * sizeof(double));
  if (normals_) b.append(reinterpret_cast<const char*>(cloud.normals[i].data()), 3 * sizeof(double));
  ++counts_[t];
  if (b.size() >= bufferBytes_) flush(t);
}

void TileSpill::flush(std::size_t t) {
  std::string& b = buffers_[t];
  if (b.empty()) return;
  std::ofstream out(file(t), std::ios::binary | std::ios::app);
  out.write(b.data(), static_cast<std::streamsize>(b.size()));
  out.close();
  if (!out) throw InputError("cannot write the scratch file " + file(t) + " (is the disk full?)");
  b.clear();
}

void TileSpill::flush() {
  for (std::size_t t = 0; t < buffers_.size(); ++t) {
    flush(t);
    std::string().swap(buffers_[t]);
  }
}

PointCloud TileSpill::read(std::size_t t, std::size_t cap, std::uint64_t seed) const {
  PointCloud cloud;
  const std::size_t n = counts_[t];
  if (n == 0) return cloud;
  std::ifstream in(file(t), std::ios::binary);
  if (!in) throw InputError("cannot read the scratch file " + file(t));
  // Each point kept with probability cap / n, decided by a hash of its position in the file.
  const double keep = n > cap ? static_cast<double>(cap) / static_cast<double>(n) : 1.0;
  const auto threshold = static_cast<std::uint64_t>(keep * 18446744073709551615.0);
  const std::size_t reserve = std::min(n, cap + cap / 8);
  cloud.points.reserve(reserve);
  if (normals_) cloud.normals.reserve(reserve);
  constexpr std::size_t kBlock = 1u << 16;
  std::vector<double> block(kBlock * (normals_ ? 6 : 3));
  for (std::size_t done = 0; done < n;) {
    const std::size_t m = std::min(kBlock, n - done);
    in.read(reinterpret_cast<char*>(block.data()), static_cast<std::streamsize>(m * recordBytes_));
    if (static_cast<std::size_t>(in.gcount()) != m * recordBytes_)
      throw InputError("the scratch file " + file(t) + " is truncated");
    for (std::size_t i = 0; i < m; ++i, ++done) {
      std::uint64_t z = seed + 0x9e3779b97f4a7c15ull * (done + 1);
      z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
      z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
      if (keep < 1.0 && (z ^ (z >> 31)) > threshold) continue;
      const double* r = block.data() + i * (normals_ ? 6 : 3);
      cloud.points.emplace_back(r[0], r[1], r[2]);
      if (normals_) cloud.normals.emplace_back(r[3], r[4], r[5]);
    }
  }
  return cloud;
}

void TileSpill::release(std::size_t t) {
  std::error_code error;
  fs::remove(file(t), error);
}

}  // namespace iires::detail
