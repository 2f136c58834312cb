// SPDX-License-Identifier: GPL-3.0-or-later
// PointStream: PLY (binary and ascii) and XYZ read in chunks, for inputs larger than memory.
#include "iires/point_stream.hpp"

#include <algorithm>
#include <array>
#include <filesystem>
#include <fstream>

#include "io_format.hpp"

namespace iires {

using detail::io::fail;
using detail::io::failAt;
using detail::io::LineReader;
using detail::io::ScalarType;

namespace {

constexpr std::size_t kReadBlock = 4u << 20;  // bytes per read of a text body
constexpr std::size_t kMaxHeader = 16u << 20;  // a PLY header longer than this is corrupted

enum class Layout { kPlyBinary, kPlyAscii, kText };

/// Where x y z (and nx ny nz) sit in a binary PLY vertex record.
struct BinaryField {
  std::size_t offset = 0;
  ScalarType type = ScalarType::kFloat32;
};

}  // namespace

struct PointStream::Impl {
  std::string path;
  std::ifstream in;
  Layout layout = Layout::kText;
  bool normals = false, swap = false;
  std::size_t declared = 0, estimate = 0;  // PLY: the vertex count; text: an estimate
  std::size_t bodyOffset = 0, bodyLine = 1;
  // binary PLY
  std::size_t recordSize = 0;
  std::array<BinaryField, 6> fields{};
  std::vector<char> record;
  // ascii PLY and text: columns per line and which hold x y z nx ny nz
  std::size_t columns = 0;
  std::array<std::size_t, 6> column{};
  std::string buffer;       // text not yet parsed (starts at a line start)
  std::size_t line = 1;     // line number of buffer's first line
  bool atEnd = false;       // the file is read to its end (the buffer may still hold lines)
  std::size_t delivered = 0;

  void openPly();
  void openText();
  bool fill();
  std::size_t nextBinary(PointCloud& chunk, std::size_t maxPoints);
  std::size_t nextText(PointCloud& chunk, std::size_t maxPoints);
  void add(PointCloud& chunk, const Eigen::Vector3d& p, const Eigen::Vector3d& n, std::size_t lineNumber);
};

/// Reads the next block of a text body into the buffer; false when there was nothing left to read.
bool PointStream::Impl::fill() {
  if (atEnd) return false;
  const std::size_t old = buffer.size();
  buffer.resize(old + kReadBlock);
  in.read(buffer.data() + old, static_cast<std::streamsize>(kReadBlock));
  buffer.resize(old + static_cast<std::size_t>(in.gcount()));
  if (!in) {
    atEnd = true;
    if (!buffer.empty() && buffer.back() != '\n') buffer.push_back('\n');  // an unterminated last line
  }
  return buffer.size() > old;
}

void PointStream::Impl::openPly() {
  std::string head;
  std::size_t end = std::string::npos;
  while (end == std::string::npos && head.size() < kMaxHeader && in) {
    const std::size_t old = head.size();
    head.resize(old + 65536);
    in.read(head.data() + old, 65536);
    head.resize(old + static_cast<std::size_t>(in.gcount()));
    end = head.find("end_header");
    if (end != std::string::npos && head.find('\n', end) == std::string::npos && in) end = std::string::npos;
  }
  const detail::io::PlyHeader header = detail::io::parsePlyHeader(path, head);
  if (header.elements.empty() || header.elements[0].name != "vertex")
    fail(path, "reading in chunks needs the vertex element first in the file");
  const detail::io::PlyElement& vertex = header.elements[0];
  const std::array<int, 6> at = {detail::io::findProperty(vertex, {"x"}, false),
                                 detail::io::findProperty(vertex, {"y"}, false),
                                 detail::io::findProperty(vertex, {"z"}, false),
                                 detail::io::findProperty(vertex, {"nx"}, false),
                                 detail::io::findProperty(vertex, {"ny"}, false),
                                 detail::io::findProperty(vertex, {"nz"}, false)};
  if (std::min({at[0], at[1], at[2]}) < 0)
    fail(path, "corrupted header: the vertex element lacks an x, y or z property");
  normals = std::min({at[3], at[4], at[5]}) >= 0;
  declared = estimate = vertex.count;
  bodyOffset = header.bodyOffset;
  bodyLine = header.bodyLine;
  layout = header.format == "ascii" ? Layout::kPlyAscii : Layout::kPlyBinary;
  swap = (header.format == "binary_big_endian") == detail::io::kHostLittleEndian;
  columns = vertex.properties.size();
  std::vector<std::size_t> offsets;
  for (const detail::io::PlyProperty& p : vertex.properties) {
    if (p.list && layout == Layout::kPlyBinary) fail(path, "reading in chunks needs vertices without list properties");
    offsets.push_back(recordSize);
    recordSize += detail::io::sizeOf(p.type);
  }
  for (std::size_t k = 0; k < (normals ? 6u : 3u); ++k) {
    const auto p = static_cast<std::size_t>(at[k]);
    column[k] = p;
    fields[k] = {offsets[p], vertex.properties[p].type};
  }
}

void PointStream::Impl::openText() {
  const std::string extension = extensionOf(path);
  if (extension != ".xyz" && extension != ".xyzn")
    fail(path, "reading in chunks supports .ply, .xyz and .xyzn, not " + detail::io::quoteToken(extension));
  fill();
  const std::size_t complete = buffer.rfind('\n');
  LineReader lines(std::string_view(buffer).substr(0, complete == std::string::npos ? 0 : complete + 1), true);
  if (lines.next()) columns = lines.size();
  if (extension == ".xyzn" ? columns != 6 : columns != 3 && columns != 6)
    failAt(path, lines.line(), std::string("expected ") + (extension == ".xyzn" ? "6 values" : "3 or 6 values") +
                                   " (x y z [nx ny nz]), found " + std::to_string(columns));
  normals = columns == 6;
  for (std::size_t k = 0; k < 6; ++k) column[k] = k;
  std::size_t lineCount = 1;
  while (lines.next()) ++lineCount;
  const auto size = static_cast<double>(std::filesystem::file_size(path));
  estimate = static_cast<std::size_t>(size * static_cast<double>(lineCount) /
                                      static_cast<double>(std::max<std::size_t>(lines.offset(), 1)));
}

PointStream::PointStream(const std::string& path) : impl_(std::make_unique<Impl>()) {
  Impl& s = *impl_;
  s.path = path;
  std::error_code error;
  if (std::filesystem::is_directory(path, error)) fail(path, "is a directory");
  s.in.open(path, std::ios::binary);
  if (!s.in) fail(path, "cannot open the file");
  if (extensionOf(path) == ".ply")
    s.openPly();
  else
    s.openText();
  rewind();
}

PointStream::~PointStream() = default;

bool PointStream::hasNormals() const { return impl_->normals; }

std::size_t PointStream::estimatedCount() const { return impl_->estimate; }

void PointStream::rewind() {
  Impl& s = *impl_;
  s.in.clear();
  s.in.seekg(static_cast<std::streamoff>(s.bodyOffset));
  s.buffer.clear();
  s.atEnd = false;
  s.line = s.bodyLine;
  s.delivered = 0;
}

void PointStream::Impl::add(PointCloud& chunk, const Eigen::Vector3d& p, const Eigen::Vector3d& n,
                            std::size_t lineNumber) {
  if (!p.allFinite()) {
    if (lineNumber) failAt(path, lineNumber, "non-finite coordinate");
    fail(path, "vertex " + std::to_string(delivered) + ": non-finite coordinate");
  }
  chunk.points.push_back(p);
  if (normals) chunk.normals.push_back(n);
  ++delivered;
}

std::size_t PointStream::Impl::nextBinary(PointCloud& chunk, std::size_t maxPoints) {
  const std::size_t want = std::min(maxPoints, declared - delivered);
  record.resize(want * recordSize);
  in.read(record.data(), static_cast<std::streamsize>(record.size()));
  const auto got = static_cast<std::size_t>(in.gcount()) / std::max<std::size_t>(recordSize, 1);
  if (got < want)
    fail(path, "truncated binary body: header declares " + std::to_string(declared) + " vertices, file holds " +
                   std::to_string(delivered + got));
  Eigen::Vector3d p, n = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < want; ++i) {
    const char* r = record.data() + i * recordSize;
    for (int k = 0; k < 3; ++k) p[k] = detail::io::decode(fields[k].type, r + fields[k].offset, swap);
    for (int k = 0; normals && k < 3; ++k)
      n[k] = detail::io::decode(fields[3 + k].type, r + fields[3 + k].offset, swap);
    add(chunk, p, n, 0);
  }
  return want;
}

std::size_t PointStream::Impl::nextText(PointCloud& chunk, std::size_t maxPoints) {
  const bool ply = layout == Layout::kPlyAscii;
  std::size_t taken = 0;
  while (taken < maxPoints && !(ply && delivered == declared)) {
    const std::size_t complete = buffer.rfind('\n');
    if (complete == std::string::npos) {
      if (fill()) continue;
      if (ply) fail(path, "truncated: header declares " + std::to_string(declared) + " vertices, file holds " +
                              std::to_string(delivered));
      break;
    }
    LineReader lines(std::string_view(buffer).substr(0, complete + 1), !ply, line);
    std::size_t consumed = 0;
    while (taken < maxPoints && !(ply && delivered == declared) && lines.next()) {
      if (lines.size() != columns)
        failAt(path, lines.line(), std::to_string(lines.size()) + " values, expected " + std::to_string(columns));
      const Eigen::Vector3d p(detail::io::number(path, lines, column[0]), detail::io::number(path, lines, column[1]),
                              detail::io::number(path, lines, column[2]));
      Eigen::Vector3d n = Eigen::Vector3d::Zero();
      if (normals)
        n = {detail::io::number(path, lines, column[3]), detail::io::number(path, lines, column[4]),
             detail::io::number(path, lines, column[5])};
      add(chunk, p, n, lines.line());
      ++taken;
      consumed = lines.offset();
    }
    if (taken < maxPoints && !(ply && delivered == declared)) consumed = complete + 1;  // the rest was blank
    line += static_cast<std::size_t>(std::count(buffer.begin(), buffer.begin() + static_cast<long>(consumed), '\n'));
    buffer.erase(0, consumed);
  }
  return taken;
}

bool PointStream::next(PointCloud& chunk, std::size_t maxPoints) {
  Impl& s = *impl_;
  chunk.points.clear();
  chunk.normals.clear();
  chunk.attributes.clear();
  chunk.points.reserve(maxPoints);
  if (s.normals) chunk.normals.reserve(maxPoints);
  if (s.layout == Layout::kPlyBinary)
    s.nextBinary(chunk, maxPoints);
  else
    s.nextText(chunk, maxPoints);
  return !chunk.points.empty();
}

}  // namespace iires
