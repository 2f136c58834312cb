// SPDX-License-Identifier: GPL-3.0-or-later
// The mesh formats OFF, OBJ and STL (read: vertices and faces; written: OFF and OBJ).
#include "io_format.hpp"

#include <algorithm>
#include <cstring>
#include <map>

namespace iires::detail::io {

namespace {

/// Indexed geometry from triangle corners (three per triangle), merging corners at bit-identical positions.
Geometry weld(const std::vector<Vector3d>& corners) {
  Geometry geometry;
  std::map<std::array<std::uint64_t, 3>, int> indexOf;
  std::array<int, 3> triangle{};
  for (std::size_t c = 0; c < corners.size(); ++c) {
    std::array<std::uint64_t, 3> key{};
    std::memcpy(key.data(), corners[c].data(), sizeof key);
    const auto [it, inserted] = indexOf.emplace(key, static_cast<int>(geometry.points.size()));
    if (inserted) geometry.points.push_back(corners[c]);
    triangle[c % 3] = it->second;
    if (c % 3 == 2) geometry.triangles.emplace_back(triangle[0], triangle[1], triangle[2]);
  }
  return geometry;
}

Geometry parseAsciiStl(const std::string& path, std::string_view text) {
  LineReader lines(text, false);
  std::vector<Vector3d> corners, loop;
  bool inSolid = false, inFacet = false, inLoop = false;
  while (lines.next()) {
    const std::string keyword = lowerCase(lines[0]);  // STL keywords in any case
    bool ok = true;
    if (keyword == "solid") {
      ok = !inSolid;
      inSolid = true;
    } else if (keyword == "facet") {
      ok = inSolid && !inFacet;
      inFacet = true;
    } else if (keyword == "outer") {
      ok = inFacet && !inLoop;
      inLoop = true;
      loop.clear();
    } else if (keyword == "vertex") {
      ok = inLoop;
      if (lines.size() != 4) failAt(path, lines.line(), "a vertex needs x y z");
      loop.push_back(vector3(path, lines, 1));
    } else if (keyword == "endloop") {
      ok = inLoop;
      if (loop.size() < 3) failAt(path, lines.line(), "a facet needs at least 3 vertices");
      for (std::size_t i = 1; i + 1 < loop.size(); ++i)
        corners.insert(corners.end(), {loop[0], loop[i], loop[i + 1]});
      inLoop = false;
    } else if (keyword == "endfacet") {
      ok = inFacet && !inLoop;
      inFacet = false;
    } else if (keyword == "endsolid") {
      ok = inSolid && !inFacet;
      inSolid = false;
    } else {
      ok = false;
    }
    if (!ok) failAt(path, lines.line(), "unexpected " + quoteToken(keyword));
  }
  if (inSolid) fail(path, "truncated: no endsolid line");
  return weld(corners);
}

Geometry parseBinaryStl(const std::string& path, std::string_view data) {
  if (data.size() < 84)
    fail(path, "truncated: a binary STL header needs 84 bytes, the file has " + std::to_string(data.size()));
  const auto count =
      static_cast<std::size_t>(decode(ScalarType::kUint32, data.data() + 80, !kHostLittleEndian));
  const std::size_t expected = 84 + 50 * count;
  if (data.size() < expected)
    fail(path, "truncated binary body: the header declares " + std::to_string(count) +
                   " triangles, the file holds " + std::to_string((data.size() - 84) / 50));
  if (data.size() > expected)
    fail(path, "corrupted: the header declares " + std::to_string(count) + " triangles (" +
                   std::to_string(expected) + " bytes), the file has " + std::to_string(data.size()) +
                   " bytes");
  std::vector<Vector3d> corners;
  corners.reserve(3 * count);
  for (std::size_t t = 0; t < count; ++t) {
    const char* record = data.data() + 84 + 50 * t + 12;  // skip the facet normal
    for (int k = 0; k < 9; ++k) {
      if (k % 3 == 0) corners.emplace_back();
      corners.back()[k % 3] = decode(ScalarType::kFloat32, record + 4 * k, !kHostLittleEndian);
    }
  }
  return weld(corners);
}

}  // namespace

/// Geomview OFF: [C][N]OFF, "nv nf [ne]", nv vertex lines (x y z [nx ny nz with N] [colour]), nf faces
/// "k i1 .. ik [colour]".
Geometry parseOff(const std::string& path, std::string_view text) {
  LineReader lines(text, true);
  const std::string_view keyword = lines.next() ? lines[0] : std::string_view();
  static const std::array<std::string_view, 4> kKeywords = {"OFF", "COFF", "NOFF", "CNOFF"};
  if (std::find(kKeywords.begin(), kKeywords.end(), keyword) == kKeywords.end())
    fail(path, "corrupted header: expected OFF, COFF, NOFF or CNOFF, found " + quoteToken(keyword));
  const bool hasNormals = keyword.find('N') != std::string_view::npos;
  std::size_t first = 1;  // the counts may follow the keyword on the same line
  if (lines.size() == 1) {
    if (!lines.next()) fail(path, "truncated: no vertex and face counts after the OFF line");
    first = 0;
  }
  long long counts[2] = {-1, -1};
  const std::size_t n = lines.size() - first;
  if (n == 2 || n == 3) {
    parseInteger(lines[first], counts[0]);
    parseInteger(lines[first + 1], counts[1]);
  }
  if (counts[0] < 0 || counts[1] < 0 || counts[0] > std::numeric_limits<int>::max())
    failAt(path, lines.line(), "corrupted header: expected \"vertices faces [edges]\" counts");
  const std::size_t vertexCount = counts[0], faceCount = counts[1];

  Geometry geometry;
  const std::size_t columns = hasNormals ? 6 : 3;
  for (std::size_t i = 0; i < vertexCount; ++i) {
    if (!lines.next())
      fail(path, "truncated: the header declares " + std::to_string(vertexCount) +
                     " vertices, the file holds " + std::to_string(i));
    if (lines.size() < columns)
      failAt(path, lines.line(),
             "a vertex needs " + std::to_string(columns) + " values, found " + std::to_string(lines.size()));
    geometry.points.push_back(vector3(path, lines, 0));
    if (hasNormals) geometry.normals.push_back(vector3(path, lines, 3));
  }
  std::vector<int> polygon;
  for (std::size_t f = 0; f < faceCount; ++f) {
    if (!lines.next())
      fail(path, "truncated: the header declares " + std::to_string(faceCount) + " faces, the file holds " +
                     std::to_string(f));
    const long long k = integer(path, lines, 0);
    if (k < 3) failAt(path, lines.line(), "a face needs at least 3 vertices, found " + std::to_string(k));
    if (static_cast<long long>(lines.size()) - 1 < k)
      failAt(path, lines.line(),
             "the face declares " + std::to_string(k) + " vertices but lists " +
                 std::to_string(lines.size() - 1));
    polygon.clear();
    for (long long j = 1; j <= k; ++j) {
      const long long index = integer(path, lines, j);
      if (index < 0 || index >= static_cast<long long>(vertexCount))
        failAt(path, lines.line(),
               "vertex index " + std::to_string(index) + " out of range (the file holds " +
                   std::to_string(vertexCount) + " vertices)");
      polygon.push_back(static_cast<int>(index));
    }
    addPolygon(geometry, polygon);
  }
  if (lines.next()) failAt(path, lines.line(), "unexpected data after the last face");
  return geometry;
}

/// Wavefront OBJ: "v x y z [w | r g b]" and "f i[/t][/n] ..." (1-based, negative = relative); the other
/// statements (vt, vn, g, o, s, usemtl, ...) are ignored.
Geometry parseObj(const std::string& path, std::string_view text) {
  Geometry geometry;
  LineReader lines(text, true);
  std::vector<int> polygon;
  while (lines.next()) {
    if (lines[0] == "v") {
      if (lines.size() < 4) failAt(path, lines.line(), "a vertex needs x y z");
      geometry.points.push_back(vector3(path, lines, 1));
    } else if (lines[0] == "f") {
      polygon.clear();
      const auto count = static_cast<long long>(geometry.points.size());
      for (std::size_t j = 1; j < lines.size(); ++j) {
        const std::string_view token = lines[j].substr(0, lines[j].find('/'));
        long long index = 0;
        if (!parseInteger(token, index) || index == 0)
          failAt(path, lines.line(), "malformed face index " + quoteToken(lines[j]));
        const long long resolved = index > 0 ? index - 1 : count + index;
        if (resolved < 0 || resolved >= count)
          failAt(path, lines.line(),
                 "face index " + std::to_string(index) + " out of range (" + std::to_string(count) +
                     " vertices defined so far)");
        polygon.push_back(static_cast<int>(resolved));
      }
      if (polygon.size() < 3)
        failAt(path, lines.line(),
               "a face needs at least 3 vertices, found " + std::to_string(polygon.size()));
      addPolygon(geometry, polygon);
    }
  }
  return geometry;
}

/// Binary when the size matches the triangle count at byte 80; otherwise ascii when the file starts with
/// "solid" (in any case) and holds no NUL byte (binary headers may start with "solid" too).
Geometry parseStl(const std::string& path, std::string_view data) {
  const bool sizeMatches =
      data.size() >= 84 &&
      data.size() == 84 + 50 * decode(ScalarType::kUint32, data.data() + 80, !kHostLittleEndian);
  const std::size_t start = std::min(data.find_first_not_of(" \t\r\n"), data.size());
  if (!sizeMatches && lowerCase(data.substr(start, 5)) == "solid" && data.find('\0') == std::string_view::npos)
    return parseAsciiStl(path, data);
  return parseBinaryStl(path, data);
}

void writeObj(Writer& w, const TriangleMesh& mesh) {
  w.text("# written by iires\n");
  for (const Vector3d& v : mesh.vertices) {
    w.text("v ");
    w.row(v);
  }
  for (const Vector3i& t : mesh.triangles) {
    w.text("f ");
    w.row(Vector3i(t.array() + 1));
  }
}

void writeOff(Writer& w, const TriangleMesh& mesh) {
  w.text("OFF\n" + std::to_string(mesh.vertices.size()) + " " + std::to_string(mesh.triangles.size()) + " 0\n");
  for (const Vector3d& v : mesh.vertices) w.row(v);
  for (const Vector3i& t : mesh.triangles) {
    w.text("3 ");
    w.row(t);
  }
}

}  // namespace iires::detail::io
