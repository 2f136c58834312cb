// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/io.hpp"

#include "atomic_file.hpp"

#include <Eigen/Geometry>

#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <optional>
#include <string_view>
#include <vector>

namespace iires {
namespace {

namespace fs = std::filesystem;
using Eigen::Vector3d;
using Eigen::Vector3i;

const bool kHostLittleEndian = [] {
  const std::uint16_t one = 1;
  unsigned char first = 0;
  std::memcpy(&first, &one, 1);
  return first == 1;
}();

[[noreturn]] void fail(const std::string& path, const std::string& problem) {
  throw InputError(path + ": " + problem);
}

[[noreturn]] void failAt(const std::string& path, std::size_t line, const std::string& problem) {
  fail(path, "line " + std::to_string(line) + ": " + problem);
}

/// A token as it may appear in a message: quoted, non-printable bytes replaced, at most 32 characters.
std::string quoteToken(std::string_view token) {
  std::string out = "\"";
  for (const char c : token.substr(0, 32)) out += std::isprint(static_cast<unsigned char>(c)) ? c : '?';
  return out + (token.size() > 32 ? "...\"" : "\"");
}

std::string lowerCase(std::string_view text) {
  std::string lower(text);
  for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return lower;
}

/// What a reader found: vertices, normals (empty or one per vertex), the faces, fan-triangulated, and the
/// vertices' other properties (attributes, each with one value per vertex).
struct Geometry {
  std::vector<Vector3d> points;
  std::vector<Vector3d> normals;
  std::vector<Vector3i> triangles;
  std::vector<PointAttribute> attributes;
};

void addPolygon(Geometry& geometry, const std::vector<int>& polygon) {
  for (std::size_t i = 1; i + 1 < polygon.size(); ++i)
    geometry.triangles.emplace_back(polygon[0], polygon[i], polygon[i + 1]);
}

// ---------------------------------------------------------------------------------------------------------
// Text parsing

/// Parses a whole token as a double (locale-independent; "nan" and "inf" are accepted).
bool parseDouble(std::string_view token, double& value) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  const char* last = token.data() + token.size();
  const auto [end, ec] = std::from_chars(token.data(), last, value);
  if (end != last || token.empty()) return false;
  if (ec == std::errc::result_out_of_range) value = std::strtod(std::string(token).c_str(), nullptr);
  return ec == std::errc() || ec == std::errc::result_out_of_range;
}

/// Parses a whole token as an integer.
bool parseInteger(std::string_view token, long long& value) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  const char* last = token.data() + token.size();
  const auto [end, ec] = std::from_chars(token.data(), last, value);
  return ec == std::errc() && end == last && !token.empty();
}

/// Splits text into lines (LF or CRLF) and lines into whitespace-separated tokens, skipping blank lines and,
/// when asked, '#' comments.
class LineReader {
 public:
  LineReader(std::string_view text, bool hashComments, std::size_t firstLine = 1)
      : text_(text), comments_(hashComments), line_(firstLine - 1) {}

  /// Advances to the next line holding a token; false at the end of the text.
  bool next() {
    while (pos_ < text_.size()) {
      const std::size_t end = std::min(text_.find('\n', pos_), text_.size());
      std::string_view line = text_.substr(pos_, end - pos_);
      pos_ = std::min(end + 1, text_.size());
      ++line_;
      if (comments_) line = line.substr(0, line.find('#'));
      tokens_.clear();
      for (std::size_t i = line.find_first_not_of(kSpace); i != std::string_view::npos;
           i = line.find_first_not_of(kSpace, i)) {
        const std::size_t j = std::min(line.find_first_of(kSpace, i), line.size());
        tokens_.push_back(line.substr(i, j - i));
        i = j;
      }
      if (!tokens_.empty()) return true;
    }
    tokens_.clear();
    return false;
  }

  const std::vector<std::string_view>& tokens() const { return tokens_; }
  std::size_t size() const { return tokens_.size(); }
  std::string_view operator[](std::size_t i) const { return tokens_[i]; }
  std::size_t line() const { return line_; }
  /// Offset of the first byte after the current line.
  std::size_t offset() const { return pos_; }

 private:
  static constexpr const char* kSpace = " \t\r\f\v";
  std::string_view text_;
  bool comments_;
  std::size_t line_;
  std::size_t pos_ = 0;
  std::vector<std::string_view> tokens_;
};

double number(const std::string& path, const LineReader& lines, std::size_t i) {
  double value = 0;
  if (!parseDouble(lines[i], value)) failAt(path, lines.line(), "malformed number " + quoteToken(lines[i]));
  return value;
}

Vector3d vector3(const std::string& path, const LineReader& lines, std::size_t first) {
  return {number(path, lines, first), number(path, lines, first + 1), number(path, lines, first + 2)};
}

long long integer(const std::string& path, const LineReader& lines, std::size_t i) {
  long long value = 0;
  if (!parseInteger(lines[i], value)) failAt(path, lines.line(), "malformed integer " + quoteToken(lines[i]));
  return value;
}

// ---------------------------------------------------------------------------------------------------------
// Binary scalars (PLY, PCD, STL)

enum class ScalarType { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64 };

std::size_t sizeOf(ScalarType type) {
  static constexpr std::size_t kSizes[] = {1, 1, 2, 2, 4, 4, 4, 8};
  return kSizes[static_cast<int>(type)];
}

template <class T>
double as(const unsigned char* bytes) {
  T value;
  std::memcpy(&value, bytes, sizeof value);
  return static_cast<double>(value);
}

/// The value of the sizeOf(@p type) bytes at @p data, byte-swapped when @p swap.
double decode(ScalarType type, const char* data, bool swap) {
  unsigned char bytes[8];
  std::memcpy(bytes, data, sizeOf(type));
  if (swap) std::reverse(bytes, bytes + sizeOf(type));
  switch (type) {
    case ScalarType::kInt8:
      return as<std::int8_t>(bytes);
    case ScalarType::kUint8:
      return as<std::uint8_t>(bytes);
    case ScalarType::kInt16:
      return as<std::int16_t>(bytes);
    case ScalarType::kUint16:
      return as<std::uint16_t>(bytes);
    case ScalarType::kInt32:
      return as<std::int32_t>(bytes);
    case ScalarType::kUint32:
      return as<std::uint32_t>(bytes);
    case ScalarType::kFloat32:
      return as<float>(bytes);
    case ScalarType::kFloat64:
      return as<double>(bytes);
  }
  return 0;
}

/// Rejects data after the last element of a binary body (trailing whitespace is tolerated).
void checkNoTrailingData(const std::string& path, std::string_view rest) {
  if (rest.find_first_not_of(" \t\r\n") != std::string_view::npos)
    fail(path, std::to_string(rest.size()) +
                   " bytes after the last element: the header counts do not match "
                   "the data");
}

// ---------------------------------------------------------------------------------------------------------
// XYZ, XYZN, PTS

/// x y z [nx ny nz] per line; every line has the column count of the first (3, or 6 with normals).
Geometry parseXyzColumns(const std::string& path, std::string_view text, bool normalsRequired) {
  Geometry geometry;
  LineReader lines(text, true);
  std::size_t columns = 0;
  while (lines.next()) {
    const std::size_t n = lines.size();
    if (normalsRequired ? n != 6 : n != 3 && n != 6)
      failAt(path, lines.line(),
             std::string(normalsRequired ? "expected 6 values (x y z nx ny nz)"
                                         : "expected 3 values (x y z) or 6 (x y z nx ny nz)") +
                 ", found " + std::to_string(n));
    if (columns == 0) columns = n;
    if (n != columns)
      failAt(path, lines.line(),
             std::to_string(n) + " values, but the first point has " + std::to_string(columns));
    geometry.points.push_back(vector3(path, lines, 0));
    if (n == 6) geometry.normals.push_back(vector3(path, lines, 3));
  }
  return geometry;
}

Geometry parseXyz(const std::string& path, std::string_view text) {
  return parseXyzColumns(path, text, false);
}

Geometry parseXyzn(const std::string& path, std::string_view text) {
  return parseXyzColumns(path, text, true);
}

/// An optional point count on the first line, then x y z per line; further columns are ignored.
Geometry parsePts(const std::string& path, std::string_view text) {
  Geometry geometry;
  LineReader lines(text, true);
  std::optional<long long> declared;
  for (bool first = true; lines.next(); first = false) {
    if (first && lines.size() == 1) {
      declared = integer(path, lines, 0);
      continue;
    }
    if (lines.size() < 3)
      failAt(path, lines.line(), "expected x y z, found " + std::to_string(lines.size()) + " value(s)");
    geometry.points.push_back(vector3(path, lines, 0));
  }
  if (declared && *declared != static_cast<long long>(geometry.points.size()))
    fail(path, std::string(*declared > static_cast<long long>(geometry.points.size()) ? "truncated: " : "") +
                   "the first line declares " + std::to_string(*declared) + " points, the file holds " +
                   std::to_string(geometry.points.size()));
  return geometry;
}

// ---------------------------------------------------------------------------------------------------------
// OFF, OBJ

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

// ---------------------------------------------------------------------------------------------------------
// STL

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

// ---------------------------------------------------------------------------------------------------------
// Per-point attributes: every vertex property that is not a position or a normal (PLY properties, PCD fields,
// named XYZ columns) is kept, with the type it was stored as.

/// The PLY name of a scalar type: how attributes of that type are written back.
std::string plyTypeName(ScalarType type) {
  static const char* const kNames[] = {"char", "uchar", "short", "ushort", "int", "uint", "float", "double"};
  return kNames[static_cast<int>(type)];
}

/// Colour channels are averaged, other integer properties are labels (majority), the rest scalars (averaged).
AttributeKind attributeKind(std::string_view name, ScalarType type) {
  static const std::string_view kColourNames[] = {"red",           "green",          "blue",
                                                  "alpha",         "r",              "g",
                                                  "b",             "a",              "diffuse_red",
                                                  "diffuse_green", "diffuse_blue",   "diffuse_alpha"};
  if (std::find(std::begin(kColourNames), std::end(kColourNames), name) != std::end(kColourNames))
    return AttributeKind::kColor;
  return type == ScalarType::kFloat32 || type == ScalarType::kFloat64 ? AttributeKind::kScalar
                                                                      : AttributeKind::kLabel;
}

PointAttribute makeAttribute(std::string_view name, ScalarType type) {
  PointAttribute attribute;
  attribute.name = std::string(name);
  attribute.kind = attributeKind(name, type);
  attribute.type = plyTypeName(type);
  return attribute;
}

/// Which of an element's values become attributes: slot[p] = the attribute that property p fills, or -1.
struct AttributeSlots {
  std::vector<int> slot;
  std::vector<PointAttribute> attributes;

  /// Appends one vertex's values (all of its properties, in header order) to the attributes.
  void append(const std::vector<double>& values) {
    for (std::size_t p = 0; p < slot.size(); ++p)
      if (slot[p] >= 0) attributes[static_cast<std::size_t>(slot[p])].values.push_back(values[p]);
  }
};

/// PCL's packed colour (field rgb or rgba: a float or uint whose bytes are b, g, r, a) as red, green, blue.
void unpackPcdColour(std::vector<PointAttribute>& attributes, const std::vector<double>& packed,
                     ScalarType packedType) {
  std::array<PointAttribute, 3> rgb = {makeAttribute("red", ScalarType::kUint8),
                                       makeAttribute("green", ScalarType::kUint8),
                                       makeAttribute("blue", ScalarType::kUint8)};
  for (const double value : packed) {
    std::uint32_t bits = 0;
    if (packedType == ScalarType::kFloat32) {
      const auto f = static_cast<float>(value);
      std::memcpy(&bits, &f, sizeof bits);
    } else {
      bits = static_cast<std::uint32_t>(value);
    }
    for (int c = 0; c < 3; ++c) rgb[static_cast<std::size_t>(c)].values.push_back((bits >> (16 - 8 * c)) & 0xffu);
  }
  for (PointAttribute& channel : rgb) attributes.push_back(std::move(channel));
}

// ---------------------------------------------------------------------------------------------------------
// PLY

std::optional<ScalarType> plyScalarType(std::string_view name) {
  static const std::pair<std::string_view, ScalarType> kNames[] = {
      {"char", ScalarType::kInt8},      {"int8", ScalarType::kInt8},       {"uchar", ScalarType::kUint8},
      {"uint8", ScalarType::kUint8},    {"short", ScalarType::kInt16},     {"int16", ScalarType::kInt16},
      {"ushort", ScalarType::kUint16},  {"uint16", ScalarType::kUint16},   {"int", ScalarType::kInt32},
      {"int32", ScalarType::kInt32},    {"uint", ScalarType::kUint32},     {"uint32", ScalarType::kUint32},
      {"float", ScalarType::kFloat32},  {"float32", ScalarType::kFloat32}, {"double", ScalarType::kFloat64},
      {"float64", ScalarType::kFloat64}};
  for (const auto& [typeName, type] : kNames)
    if (typeName == name) return type;
  return std::nullopt;
}

struct PlyProperty {
  std::string name;
  ScalarType type = ScalarType::kFloat32;
  bool list = false;
  ScalarType countType = ScalarType::kUint8;
};

struct PlyElement {
  std::string name;
  std::size_t count = 0;
  std::vector<PlyProperty> properties;

  /// "1000 vertices", "3 faces", "2 edge elements".
  std::string counted() const {
    const std::string noun = name == "vertex" ? "vertices" : name == "face" ? "faces" : name + " elements";
    return std::to_string(count) + " " + noun;
  }
};

/// Scalars of a binary PLY body, one after another.
class PlyBinarySource {
 public:
  PlyBinarySource(const std::string& path, std::string_view data, bool bigEndian)
      : path_(path), data_(data), swap_(bigEndian == kHostLittleEndian) {}

  void begin(const PlyElement& element, std::size_t instance) {
    element_ = &element;
    instance_ = instance;
  }

  double next(ScalarType type) {
    if (data_.size() - pos_ < sizeOf(type))
      fail(path_, "truncated binary body: header declares " + element_->counted() + ", file holds " +
                      std::to_string(instance_));
    pos_ += sizeOf(type);
    return decode(type, data_.data() + pos_ - sizeOf(type), swap_);
  }

  void end() {}

  void finish() { checkNoTrailingData(path_, data_.substr(pos_)); }

 private:
  const std::string& path_;
  std::string_view data_;
  bool swap_;
  std::size_t pos_ = 0;
  const PlyElement* element_ = nullptr;
  std::size_t instance_ = 0;
};

/// Values of an ascii PLY body: one element instance per line.
class PlyAsciiSource {
 public:
  PlyAsciiSource(const std::string& path, std::string_view body, std::size_t firstLine)
      : path_(path), lines_(body, false, firstLine) {}

  void begin(const PlyElement& element, std::size_t instance) {
    element_ = &element;
    if (!lines_.next())
      fail(path_,
           "truncated: header declares " + element.counted() + ", file holds " + std::to_string(instance));
    token_ = 0;
  }

  double next(ScalarType) {
    if (token_ == lines_.size()) failAt(path_, lines_.line(), "too few values for a " + element_->name);
    return number(path_, lines_, token_++);
  }

  void end() {
    if (token_ != lines_.size())
      failAt(path_, lines_.line(), "more values than the header declares for a " + element_->name);
  }

  void finish() {
    if (lines_.next()) failAt(path_, lines_.line(), "unexpected data after the last element");
  }

 private:
  const std::string& path_;
  LineReader lines_;
  const PlyElement* element_ = nullptr;
  std::size_t token_ = 0;
};

/// Index of the property called one of @p names in @p element, or -1.
int findProperty(const PlyElement& element, std::initializer_list<std::string_view> names, bool list) {
  for (std::size_t p = 0; p < element.properties.size(); ++p)
    if (element.properties[p].list == list &&
        std::find(names.begin(), names.end(), element.properties[p].name) != names.end())
      return static_cast<int>(p);
  return -1;
}

/// The attributes of a PLY vertex element: its scalar properties except x y z nx ny nz.
AttributeSlots plyVertexAttributes(const PlyElement& vertex) {
  AttributeSlots slots;
  for (const PlyProperty& property : vertex.properties) {
    const std::string& name = property.name;
    const bool geometric = name == "x" || name == "y" || name == "z" || name == "nx" || name == "ny" || name == "nz";
    slots.slot.push_back(property.list || geometric ? -1 : static_cast<int>(slots.attributes.size()));
    if (slots.slot.back() >= 0) slots.attributes.push_back(makeAttribute(name, property.type));
  }
  return slots;
}

template <class Source>
Geometry readPlyBody(const std::string& path, const std::vector<PlyElement>& elements, Source& source) {
  const auto vertex =
      std::find_if(elements.begin(), elements.end(), [](auto& e) { return e.name == "vertex"; });
  if (vertex == elements.end()) fail(path, "corrupted header: no vertex element");
  if (vertex->count > static_cast<std::size_t>(std::numeric_limits<int>::max()))
    fail(path, "corrupted header: " + vertex->counted() + " exceed the supported 2^31 - 1");
  const int xyz[3] = {findProperty(*vertex, {"x"}, false), findProperty(*vertex, {"y"}, false),
                      findProperty(*vertex, {"z"}, false)};
  const int nxyz[3] = {findProperty(*vertex, {"nx"}, false), findProperty(*vertex, {"ny"}, false),
                       findProperty(*vertex, {"nz"}, false)};
  if (std::min({xyz[0], xyz[1], xyz[2]}) < 0)
    fail(path, "corrupted header: the vertex element lacks an x, y or z property");
  const bool hasNormals = std::min({nxyz[0], nxyz[1], nxyz[2]}) >= 0;

  Geometry geometry;
  AttributeSlots attributes = plyVertexAttributes(*vertex);
  std::vector<int> polygon;
  for (const PlyElement& element : elements) {
    const bool isVertex = &element == &*vertex;
    const int faceList =
        element.name == "face" ? findProperty(element, {"vertex_indices", "vertex_index"}, true) : -1;
    if (element.name == "face" && faceList < 0)
      fail(path, "corrupted header: the face element has no vertex_indices list");
    std::vector<double> values(element.properties.size());
    for (std::size_t i = 0; i < element.count; ++i) {
      source.begin(element, i);
      for (std::size_t p = 0; p < element.properties.size(); ++p) {
        const PlyProperty& property = element.properties[p];
        if (!property.list) {
          values[p] = source.next(property.type);
          continue;
        }
        const double length = source.next(property.countType);
        if (!(length >= 0 && length == std::floor(length)))
          fail(path, element.name + " " + std::to_string(i) + ": invalid list length");
        polygon.clear();
        for (double k = 0; k < length; ++k) {
          const double index = source.next(property.type);
          if (static_cast<int>(p) != faceList) continue;
          if (!(index >= 0 && index < static_cast<double>(vertex->count) && index == std::floor(index)))
            fail(path, "face " + std::to_string(i) + ": vertex index " + std::to_string(index) +
                           " out of range (the file holds " + std::to_string(vertex->count) + " vertices)");
          polygon.push_back(static_cast<int>(index));
        }
        if (static_cast<int>(p) != faceList) continue;
        if (polygon.size() < 3)
          fail(path, "face " + std::to_string(i) + " has " + std::to_string(polygon.size()) + " vertices");
        addPolygon(geometry, polygon);
      }
      source.end();
      if (!isVertex) continue;
      geometry.points.emplace_back(values[xyz[0]], values[xyz[1]], values[xyz[2]]);
      if (hasNormals) geometry.normals.emplace_back(values[nxyz[0]], values[nxyz[1]], values[nxyz[2]]);
      attributes.append(values);
    }
  }
  source.finish();
  geometry.attributes = std::move(attributes.attributes);
  return geometry;
}

Geometry parsePly(const std::string& path, std::string_view data) {
  LineReader lines(data, false);
  if (!lines.next() || lines.size() != 1 || lines[0] != "ply")
    fail(path, "corrupted header: the file does not start with \"ply\"");
  std::optional<std::string_view> format;
  std::vector<PlyElement> elements;
  bool ended = false;
  while (!ended && lines.next()) {
    const std::string_view keyword = lines[0];
    const auto corrupted = [&](const std::string& what) {
      failAt(path, lines.line(), "corrupted header: " + what);
    };
    if (keyword == "format") {
      if (lines.size() != 3 ||
          (lines[1] != "ascii" && lines[1] != "binary_little_endian" && lines[1] != "binary_big_endian"))
        corrupted("unknown format " + quoteToken(lines.size() > 1 ? lines[1] : ""));
      format = lines[1];
    } else if (keyword == "element") {
      long long count = -1;
      if (lines.size() != 3 || !parseInteger(lines[2], count) || count < 0)
        corrupted("malformed element line");
      elements.push_back({std::string(lines[1]), static_cast<std::size_t>(count), {}});
    } else if (keyword == "property") {
      if (elements.empty()) corrupted("a property before any element");
      PlyProperty property;
      std::optional<ScalarType> type, countType = ScalarType::kUint8;
      if (lines.size() == 3) {
        type = plyScalarType(lines[1]);
      } else if (lines.size() == 5 && lines[1] == "list") {
        property.list = true;
        countType = plyScalarType(lines[2]);
        type = plyScalarType(lines[3]);
      }
      if (!type || !countType) corrupted("malformed property line");
      property.name = lines[lines.size() - 1];
      property.type = *type;
      property.countType = *countType;
      elements.back().properties.push_back(property);
    } else if (keyword == "end_header") {
      ended = true;
    } else if (keyword != "comment" && keyword != "obj_info") {
      corrupted("unexpected " + quoteToken(keyword));
    }
  }
  if (!ended) fail(path, "corrupted header: no end_header line");
  if (!format) fail(path, "corrupted header: no format line");
  const std::string_view body = data.substr(lines.offset());
  if (*format == "ascii") {
    PlyAsciiSource source(path, body, lines.line() + 1);
    return readPlyBody(path, elements, source);
  }
  PlyBinarySource source(path, body, *format == "binary_big_endian");
  return readPlyBody(path, elements, source);
}

// ---------------------------------------------------------------------------------------------------------
// XYZ with named columns (attributes)

/// One value per named column on every line (names as in readPointCloud's @p columns: x y z required, nx ny nz
/// together or not at all, any other name an attribute, "name:type" to give its type).
Geometry parseXyzNamedColumns(const std::string& path, std::string_view text, const std::vector<std::string>& columns) {
  std::vector<int> role(columns.size(), -1);  // 0–2 position, 3–5 normal, -1 attribute
  std::vector<std::optional<ScalarType>> typed(columns.size());
  std::vector<std::string> names(columns.size());
  static const char* const kGeometric[] = {"x", "y", "z", "nx", "ny", "nz"};
  for (std::size_t c = 0; c < columns.size(); ++c) {
    const std::size_t colon = columns[c].find(':');
    names[c] = columns[c].substr(0, colon);
    if (colon != std::string::npos && !(typed[c] = plyScalarType(columns[c].substr(colon + 1))))
      fail(path, "column " + quoteToken(columns[c]) + ": unknown type (use a PLY type: uchar int float ...)");
    for (int g = 0; g < 6; ++g)
      if (names[c] == kGeometric[g]) role[c] = g;
    if (names[c].empty() || std::count(names.begin(), names.begin() + static_cast<long>(c), names[c]))
      fail(path, "column names must be distinct and non-empty (got " + quoteToken(columns[c]) + ")");
  }
  const auto has = [&](int g) { return std::find(role.begin(), role.end(), g) != role.end(); };
  if (!has(0) || !has(1) || !has(2)) fail(path, "the columns must name x, y and z");
  const bool normals = has(3) || has(4) || has(5);
  if (normals && !(has(3) && has(4) && has(5))) fail(path, "the columns name some of nx, ny, nz but not all three");

  Geometry geometry;
  std::vector<std::vector<double>> values(columns.size());
  LineReader lines(text, true);
  Vector3d p, n;
  while (lines.next()) {
    if (lines.size() != columns.size())
      failAt(path, lines.line(),
             "expected " + std::to_string(columns.size()) + " values (the columns), found " + std::to_string(lines.size()));
    for (std::size_t c = 0; c < columns.size(); ++c) {
      const double v = number(path, lines, c);
      if (role[c] >= 3) n[role[c] - 3] = v;
      else if (role[c] >= 0) p[role[c]] = v;
      else values[c].push_back(v);
    }
    geometry.points.push_back(p);
    if (normals) geometry.normals.push_back(n);
  }
  for (std::size_t c = 0; c < columns.size(); ++c) {
    if (role[c] >= 0) continue;
    // Untyped colours: bytes when every value is a whole number in [0, 255], else float; other names float.
    const bool bytes = std::all_of(values[c].begin(), values[c].end(),
                                   [](double v) { return v >= 0 && v <= 255 && v == std::floor(v); });
    const ScalarType type = typed[c] ? *typed[c]
                            : attributeKind(names[c], ScalarType::kFloat32) == AttributeKind::kColor && bytes
                                ? ScalarType::kUint8
                                : ScalarType::kFloat32;
    geometry.attributes.push_back(makeAttribute(names[c], type));
    geometry.attributes.back().values = std::move(values[c]);
  }
  return geometry;
}

// ---------------------------------------------------------------------------------------------------------
// PCD (ascii, binary, binary_compressed)

struct PcdField {
  std::string_view name;
  ScalarType type = ScalarType::kFloat32;
  std::size_t column = 0;  ///< first value of the field in an ascii line
  std::size_t offset = 0;  ///< first byte of the field in a binary record
  std::size_t bytes = 0;   ///< bytes of the field in a binary record
};

/// The attributes of a PCD file: its one-value fields except x y z normal_* (and curvature, which PCL writes
/// next to its normals); a packed rgb/rgba field becomes red, green, blue.
struct PcdAttributes {
  std::vector<const PcdField*> fields;
  std::vector<PointAttribute> attributes;

  explicit PcdAttributes(const std::vector<PcdField>& all) {
    static const std::string_view kSkipped[] = {"x", "y", "z", "normal_x", "normal_y", "normal_z", "curvature", "_"};
    for (const PcdField& f : all) {
      if (f.bytes != sizeOf(f.type) || std::find(std::begin(kSkipped), std::end(kSkipped), f.name) != std::end(kSkipped))
        continue;
      fields.push_back(&f);
      attributes.push_back(makeAttribute(f.name, f.type));
    }
  }

  /// Appends the current point's values: value(field).
  template <class Value>
  void append(Value&& value) {
    for (std::size_t a = 0; a < fields.size(); ++a) attributes[a].values.push_back(value(*fields[a]));
  }

  /// The attributes, with a packed colour unpacked.
  std::vector<PointAttribute> finish() {
    std::vector<PointAttribute> out;
    for (std::size_t a = 0; a < fields.size(); ++a) {
      if (fields[a]->name == "rgb" || fields[a]->name == "rgba")
        unpackPcdColour(out, attributes[a].values, fields[a]->type);
      else
        out.push_back(std::move(attributes[a]));
    }
    return out;
  }
};

std::optional<ScalarType> pcdScalarType(std::string_view type, std::string_view size) {
  static const std::pair<std::string_view, ScalarType> kTypes[] = {
      {"F4", ScalarType::kFloat32}, {"F8", ScalarType::kFloat64}, {"I1", ScalarType::kInt8},
      {"I2", ScalarType::kInt16},   {"I4", ScalarType::kInt32},   {"U1", ScalarType::kUint8},
      {"U2", ScalarType::kUint16},  {"U4", ScalarType::kUint32}};
  const std::string key = std::string(type) + std::string(size);
  for (const auto& [name, scalar] : kTypes)
    if (name == key) return scalar;
  return std::nullopt;
}

/// LZF decompression (liblzf's format, used by PCL for binary_compressed PCD): false when @p in is malformed
/// or does not unpack to exactly out.size() bytes.
bool lzfDecompress(std::string_view in, std::string& out) {
  std::size_t ip = 0, op = 0;
  while (ip < in.size()) {
    const unsigned control = static_cast<unsigned char>(in[ip++]);
    if (control < 32) {  // a literal run of control + 1 bytes
      const std::size_t length = control + 1;
      if (in.size() - ip < length || out.size() - op < length) return false;
      std::memcpy(&out[op], &in[ip], length);
      ip += length;
      op += length;
      continue;
    }
    std::size_t length = control >> 5;  // a back reference
    if (length == 7 && ip < in.size()) length += static_cast<unsigned char>(in[ip++]);
    if (ip == in.size()) return false;
    const std::size_t distance = ((control & 0x1f) << 8) + static_cast<unsigned char>(in[ip++]) + 1;
    length += 2;
    if (distance > op || out.size() - op < length) return false;
    for (; length > 0; --length, ++op) out[op] = out[op - distance];
  }
  return op == out.size();
}

/// The field-major records of a binary_compressed PCD body: sizes (compressed, uncompressed), LZF data.
std::string unpackPcdBody(const std::string& path, std::string_view body, std::size_t points,
                          std::size_t recordSize) {
  const auto size = [&](std::size_t at) {
    return body.size() < 8
               ? 0
               : static_cast<std::size_t>(decode(ScalarType::kUint32, body.data() + at, !kHostLittleEndian));
  };
  const std::size_t compressed = size(0), unpacked = size(4);
  if (body.size() < 8 || body.size() - 8 < compressed)
    fail(path, "truncated compressed body: " + std::to_string(body.size()) + " bytes after the header");
  if (points > UINT32_MAX || unpacked != points * recordSize)
    fail(path, "corrupted: the compressed body unpacks to " + std::to_string(unpacked) +
                   " bytes, the header declares " + std::to_string(points) + " points of " +
                   std::to_string(recordSize) + " bytes");
  std::string records(unpacked, '\0');
  if (!lzfDecompress(body.substr(8, compressed), records)) fail(path, "corrupted compressed body");
  checkNoTrailingData(path, body.substr(8 + compressed));
  return records;
}

Geometry parsePcd(const std::string& path, std::string_view data) {
  LineReader lines(data, true);
  std::vector<std::string_view> names, sizes, types, counts;
  long long points = -1;
  std::string_view encoding;
  while (encoding.empty() && lines.next()) {
    const std::string_view key = lines[0];
    const std::vector<std::string_view> values(lines.tokens().begin() + 1, lines.tokens().end());
    const auto corrupted = [&](const std::string& what) {
      failAt(path, lines.line(), "corrupted header: " + what);
    };
    if (key == "FIELDS") {
      names = values;
    } else if (key == "SIZE") {
      sizes = values;
    } else if (key == "TYPE") {
      types = values;
    } else if (key == "COUNT") {
      counts = values;
    } else if (key == "POINTS") {
      if (values.size() != 1 || !parseInteger(values[0], points) || points < 0)
        corrupted("malformed POINTS line");
    } else if (key == "DATA") {
      if (values.size() != 1) corrupted("malformed DATA line");
      encoding = values[0];
    } else if (key != "VERSION" && key != "WIDTH" && key != "HEIGHT" && key != "VIEWPOINT") {
      corrupted("unexpected " + quoteToken(key));
    }
  }
  if (encoding.empty()) fail(path, "corrupted header: no DATA line");
  if (points < 0) fail(path, "corrupted header: no POINTS line");
  if (counts.empty()) counts.assign(names.size(), "1");
  if (names.empty() || sizes.size() != names.size() || types.size() != names.size() ||
      counts.size() != names.size())
    fail(path, "corrupted header: FIELDS, SIZE, TYPE and COUNT do not match");

  std::vector<PcdField> fields;
  std::size_t columns = 0, recordSize = 0;
  for (std::size_t f = 0; f < names.size(); ++f) {
    const std::optional<ScalarType> type = pcdScalarType(types[f], sizes[f]);
    long long count = 0;
    if (!type || !parseInteger(counts[f], count) || count < 1)
      fail(path, "corrupted header: unsupported field " + quoteToken(names[f]) + " (TYPE " +
                     quoteToken(types[f]) + ", SIZE " + quoteToken(sizes[f]) + ", COUNT " +
                     quoteToken(counts[f]) + ")");
    fields.push_back({names[f], *type, columns, recordSize, count * sizeOf(*type)});
    columns += count;
    recordSize += count * sizeOf(*type);
  }
  const auto field = [&](std::string_view name) {
    return std::find_if(fields.begin(), fields.end(), [&](const PcdField& f) { return f.name == name; });
  };
  const std::array<std::vector<PcdField>::const_iterator, 6> used = {
      field("x"), field("y"), field("z"), field("normal_x"), field("normal_y"), field("normal_z")};
  if (used[0] == fields.end() || used[1] == fields.end() || used[2] == fields.end())
    fail(path, "corrupted header: no x, y, z fields");
  const bool hasNormals =
      std::none_of(used.begin() + 3, used.end(), [&](auto it) { return it == fields.end(); });

  const std::string_view body = data.substr(lines.offset());
  const auto count = static_cast<std::size_t>(points);
  Geometry geometry;
  geometry.points.reserve(std::min(count, body.size()));
  PcdAttributes attributes(fields);
  const auto add = [&](auto&& value) {  // value(field) of the current point
    geometry.points.emplace_back(value(*used[0]), value(*used[1]), value(*used[2]));
    if (hasNormals) geometry.normals.emplace_back(value(*used[3]), value(*used[4]), value(*used[5]));
    attributes.append(value);
  };
  if (encoding == "ascii") {
    LineReader bodyLines(body, false, lines.line() + 1);
    for (std::size_t i = 0; i < count; ++i) {
      if (!bodyLines.next())
        fail(path, "truncated: header declares " + std::to_string(count) + " points, file holds " +
                       std::to_string(i));
      if (bodyLines.size() != columns)
        failAt(path, bodyLines.line(),
               "expected " + std::to_string(columns) + " values, found " + std::to_string(bodyLines.size()));
      add([&](const PcdField& f) { return number(path, bodyLines, f.column); });
    }
    if (bodyLines.next()) failAt(path, bodyLines.line(), "unexpected data after the last point");
  } else if (encoding == "binary") {
    if (count > body.size() / recordSize)
      fail(path, "truncated binary body: header declares " + std::to_string(count) + " points, file holds " +
                     std::to_string(body.size() / recordSize));
    for (std::size_t i = 0; i < count; ++i)
      add([&](const PcdField& f) {
        return decode(f.type, body.data() + i * recordSize + f.offset, !kHostLittleEndian);
      });
    checkNoTrailingData(path, body.substr(count * recordSize));
  } else if (encoding == "binary_compressed") {  // field-major: all x, then all y, ...
    const std::string records = unpackPcdBody(path, body, count, recordSize);
    for (std::size_t i = 0; i < count; ++i)
      add([&](const PcdField& f) {
        return decode(f.type, records.data() + f.offset * count + i * f.bytes, !kHostLittleEndian);
      });
  } else {
    fail(path, "corrupted header: unknown DATA " + quoteToken(encoding));
  }
  geometry.attributes = attributes.finish();
  return geometry;
}

// ---------------------------------------------------------------------------------------------------------
// Reading: dispatch and file access

/// What the first bytes of a file must look like, checked before the whole file is read.
enum class Signature {
  kPly,   ///< "ply" on the first line
  kText,  ///< no NUL byte (a text format)
  kAny,   ///< binary or text (PCD's binary body, STL)
};

struct ReadFormat {
  std::string_view extension;
  Geometry (*parse)(const std::string&, std::string_view);
  bool mesh;  ///< also a mesh format
  Signature signature;
};

const ReadFormat kReadFormats[] = {
    {".ply", parsePly, true, Signature::kPly},     {".pcd", parsePcd, false, Signature::kAny},
    {".xyz", parseXyz, false, Signature::kText},   {".xyzn", parseXyzn, false, Signature::kText},
    {".pts", parsePts, false, Signature::kText},   {".obj", parseObj, true, Signature::kText},
    {".off", parseOff, true, Signature::kText},    {".stl", parseStl, true, Signature::kAny}};

void checkSignature(const std::string& path, std::string_view head, Signature signature) {
  const bool plyLine = head.substr(0, 3) == "ply" && (head.size() == 3 || head[3] == '\n' || head[3] == '\r');
  if (signature == Signature::kPly && !plyLine)
    fail(path, "corrupted header: the file does not start with \"ply\"");
  if (signature == Signature::kText && head.find('\0') != std::string_view::npos)
    fail(path, "not a text file (it holds NUL bytes)");
}

/// The whole file, after checking that it is a regular file whose first bytes fit @p signature (so that a
/// large file of the wrong kind is rejected without being read).
/// Fails unless @p path names an existing regular file.
void checkRegularFile(const std::string& path) {
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (ec && ec != std::errc::no_such_file_or_directory) fail(path, "cannot access: " + ec.message());
  if (!fs::exists(status)) fail(path, "no such file");
  if (fs::is_directory(status)) fail(path, "is a directory, not a file");
  if (!fs::is_regular_file(status)) fail(path, "not a regular file (a device, pipe or socket)");
}

std::string readFile(const std::string& path, Signature signature) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, std::string("cannot open for reading: ") + std::strerror(errno));
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  in.seekg(0);
  if (size < 0) fail(path, "cannot determine the file size");
  if (size == 0) fail(path, "the file is empty");
  std::string data(static_cast<std::size_t>(std::min<std::streamoff>(size, 4096)), '\0');
  if (!in.read(data.data(), static_cast<std::streamsize>(data.size()))) fail(path, "read error");
  checkSignature(path, data, signature);
  const std::size_t head = data.size();
  data.resize(static_cast<std::size_t>(size));
  if (!in.read(data.data() + head, size - static_cast<std::streamoff>(head))) fail(path, "read error");
  return data;
}

Geometry load(const std::string& path, bool mesh) {
  checkRegularFile(path);
  const std::string extension = extensionOf(path);
  const auto format =
      std::find_if(std::begin(kReadFormats), std::end(kReadFormats),
                   [&](const ReadFormat& f) { return f.extension == extension && (f.mesh || !mesh); });
  if (format == std::end(kReadFormats)) {
    std::string supported;
    for (const ReadFormat& f : kReadFormats)
      if (f.mesh || !mesh) supported += (supported.empty() ? "" : " ") + std::string(f.extension);
    fail(path, "unknown " + std::string(mesh ? "mesh" : "point cloud") + " extension " +
                   quoteToken(extension) + " (supported: " + supported + ")");
  }
  Geometry geometry = format->parse(path, readFile(path, format->signature));
  if (geometry.points.empty()) fail(path, "the file holds no points");
  return geometry;
}

// ---------------------------------------------------------------------------------------------------------
// Writing

/// Buffers output and hands it to the stream in large blocks.
class Writer {
 public:
  explicit Writer(std::ostream& out) : out_(out) {}

  void text(std::string_view s) {
    buffer_.append(s);
    if (buffer_.size() > (1u << 20)) flush();
  }

  /// Shortest decimal form that reads back to the same value.
  template <class T>
  void number(T value) {
    char chars[32];
    const auto [end, ec] = std::to_chars(chars, chars + sizeof chars, value);
    text(std::string_view(chars, end - chars));
  }

  /// Space-separated numbers ending the line.
  template <class Vector>
  void row(const Vector& v, bool last = true) {
    for (int k = 0; k < v.size(); ++k) {
      number(v[k]);
      text(k + 1 < v.size() || !last ? " " : "\n");
    }
  }

  /// Little-endian bytes of a scalar.
  template <class T>
  void binary(T value) {
    char bytes[sizeof(T)];
    std::memcpy(bytes, &value, sizeof value);
    if (!kHostLittleEndian) std::reverse(bytes, bytes + sizeof bytes);
    text(std::string_view(bytes, sizeof bytes));
  }

  void flush() {
    out_.write(buffer_.data(), static_cast<std::streamsize>(buffer_.size()));
    buffer_.clear();
  }

 private:
  std::ostream& out_;
  std::string buffer_;
};

[[noreturn]] void failWrite(const std::string& path, const std::string& problem) {
  throw InputError("cannot write " + path + ": " + problem);
}

/// Stages a file written through a Writer in @p batch.
void stage(OutputBatch& batch, const std::string& path, const std::function<void(Writer&)>& body) {
  batch.file(path, [&](std::ostream& out) {
    Writer writer(out);
    body(writer);
    writer.flush();
  });
}

void checkTriangles(const std::string& path, const TriangleMesh& mesh) {
  const auto count = static_cast<int>(mesh.vertices.size());
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
    if (mesh.triangles[t].minCoeff() < 0 || mesh.triangles[t].maxCoeff() >= count)
      failWrite(path, "triangle " + std::to_string(t) + " refers to a vertex out of range (the mesh has " +
                          std::to_string(count) + " vertices)");
}

/// Every attribute must hold one value per vertex.
void checkAttributes(const std::string& path, const std::vector<PointAttribute>& attributes, std::size_t vertices) {
  for (const PointAttribute& a : attributes) {
    if (a.values.size() != vertices)
      failWrite(path, "attribute " + quoteToken(a.name) + " has " + std::to_string(a.values.size()) +
                          " values for " + std::to_string(vertices) + " points");
    if (!plyScalarType(a.type)) failWrite(path, "attribute " + quoteToken(a.name) + " has unknown type " + quoteToken(a.type));
  }
}

/// @p value in the attribute's storage type: integers rounded and clamped to the type's range.
template <class T>
T stored(double value) {
  if constexpr (std::is_floating_point_v<T>) {
    return static_cast<T>(value);
  } else {
    if (!(value == value)) return T{0};
    const double clamped = std::clamp(std::round(value), static_cast<double>(std::numeric_limits<T>::lowest()),
                                      static_cast<double>(std::numeric_limits<T>::max()));
    return static_cast<T>(clamped);
  }
}

/// Vertex @p i's attribute values: binary in their storage types, or ascii separated by spaces.
void writeAttributeValues(Writer& w, const std::vector<PointAttribute>& attributes, std::size_t i, bool ascii) {
  for (const PointAttribute& a : attributes) {
    const double v = a.values[i];
    const auto put = [&](auto typed) {
      if (!ascii) return w.binary(typed);
      if (&a != &attributes.front()) w.text(" ");
      if constexpr (std::is_floating_point_v<decltype(typed)>)
        w.number(typed);
      else
        w.number(static_cast<long long>(typed));  // chars as numbers
    };
    switch (*plyScalarType(a.type)) {
      case ScalarType::kInt8: put(stored<std::int8_t>(v)); break;
      case ScalarType::kUint8: put(stored<std::uint8_t>(v)); break;
      case ScalarType::kInt16: put(stored<std::int16_t>(v)); break;
      case ScalarType::kUint16: put(stored<std::uint16_t>(v)); break;
      case ScalarType::kInt32: put(stored<std::int32_t>(v)); break;
      case ScalarType::kUint32: put(stored<std::uint32_t>(v)); break;
      case ScalarType::kFloat32: put(stored<float>(v)); break;
      case ScalarType::kFloat64: put(v); break;
    }
  }
}

void writePlyHeader(Writer& w, bool ascii, std::size_t vertices, bool normals, std::size_t faces,
                    const std::vector<PointAttribute>& attributes = {}) {
  w.text(std::string("ply\nformat ") + (ascii ? "ascii" : "binary_little_endian") +
         " 1.0\ncomment written by iires\nelement vertex " + std::to_string(vertices) +
         "\nproperty double x\nproperty double y\nproperty double z\n");
  if (normals) w.text("property double nx\nproperty double ny\nproperty double nz\n");
  for (const PointAttribute& a : attributes) w.text("property " + a.type + " " + a.name + "\n");
  if (faces > 0)
    w.text("element face " + std::to_string(faces) + "\nproperty list uchar int vertex_indices\n");
  w.text("end_header\n");
}

}  // namespace

PointCloud readPointCloud(const std::string& path) { return readPointCloud(path, {}); }

PointCloud readPointCloud(const std::string& path, const std::vector<std::string>& columns) {
  Geometry geometry;
  if (columns.empty()) {
    geometry = load(path, false);
  } else {
    checkRegularFile(path);
    if (extensionOf(path) != ".xyz") fail(path, "column names apply to .xyz files only");
    geometry = parseXyzNamedColumns(path, readFile(path, Signature::kText), columns);
    if (geometry.points.empty()) fail(path, "the file holds no points");
  }
  PointCloud cloud;
  cloud.points = std::move(geometry.points);
  cloud.normals = std::move(geometry.normals);
  cloud.attributes = std::move(geometry.attributes);
  if (cloud.normals.empty() && !geometry.triangles.empty()) {
    // Mesh vertices: area-weighted face normals, oriented by the winding (exact where PCA would guess).
    std::vector<Vector3d> normals(cloud.size(), Vector3d::Zero());
    for (const Eigen::Vector3i& t : geometry.triangles) {
      const Vector3d& a = cloud.points[t[0]];
      const Vector3d n = (cloud.points[t[1]] - a).cross(cloud.points[t[2]] - a);
      for (int k = 0; k < 3; ++k) normals[t[k]] += n;
    }
    const bool complete = std::all_of(normals.begin(), normals.end(), [](const Vector3d& n) {
      return n.squaredNorm() > 0 && n.allFinite();
    });
    if (complete) {
      for (Vector3d& n : normals) n.normalize();
      cloud.normals = std::move(normals);
    }
  }
  return cloud;
}

TriangleMesh readMesh(const std::string& path) {
  Geometry geometry = load(path, true);
  if (geometry.triangles.empty()) fail(path, "the file holds no triangles");
  return {std::move(geometry.points), std::move(geometry.triangles), std::move(geometry.attributes)};
}

struct OutputBatch::Staged {
  detail::TemporaryFile file;
};

OutputBatch::OutputBatch() = default;
OutputBatch::~OutputBatch() = default;

void OutputBatch::file(const std::string& path, const std::function<void(std::ostream&)>& write) {
  const fs::path target(path);
  const fs::path directory = target.has_parent_path() ? target.parent_path() : fs::path(".");
  std::error_code ec;
  if (path.empty()) failWrite(path, "the file name is empty");
  if (!fs::is_directory(directory, ec))
    failWrite(path, "directory " + directory.string() +
                        (fs::exists(directory, ec) ? " is not a directory" : " does not exist"));
  if (fs::is_directory(target, ec)) failWrite(path, "it is a directory");
  const fs::path canonical = fs::weakly_canonical(fs::absolute(target, ec), ec);
  for (const auto& s : staged_)
    if (fs::weakly_canonical(fs::absolute(s->file.target(), ec), ec) == canonical)
      failWrite(path, "the run writes it twice (two outputs name the same file)");
  auto staged = std::make_unique<Staged>(Staged{detail::TemporaryFile(path)});
  std::ofstream out(staged->file.path(), std::ios::binary | std::ios::trunc);
  if (!out) failWrite(path, "cannot create a file in " + directory.string() + ": " + std::strerror(errno));
  write(out);
  out.close();
  if (!out) failWrite(path, "write error (disk full?)");
  staged_.push_back(std::move(staged));
}

void OutputBatch::commit() {
  const detail::SignalBlock hold;
  for (const auto& s : staged_)
    if (const std::string problem = s->file.commit(); !problem.empty()) failWrite(s->file.target(), problem);
  staged_.clear();
}

void OutputBatch::pointCloud(const std::string& path, const PointCloud& cloud, bool ascii) {
  const std::string extension = extensionOf(path);
  const bool normals = cloud.hasNormals();
  if (extension == ".ply") {
    checkAttributes(path, cloud.attributes, cloud.size());
    const bool attributes = !cloud.attributes.empty();
    stage(*this, path, [&](Writer& w) {
      writePlyHeader(w, ascii, cloud.size(), normals, 0, cloud.attributes);
      for (std::size_t i = 0; i < cloud.size(); ++i) {
        if (ascii) {
          w.row(cloud.points[i], !normals && !attributes);
          if (normals) w.row(cloud.normals[i], !attributes);
          if (attributes) {
            writeAttributeValues(w, cloud.attributes, i, true);
            w.text("\n");
          }
          continue;
        }
        for (int k = 0; k < 3; ++k) w.binary(cloud.points[i][k]);
        for (int k = 0; normals && k < 3; ++k) w.binary(cloud.normals[i][k]);
        writeAttributeValues(w, cloud.attributes, i, false);
      }
    });
  } else if (extension == ".xyz") {
    stage(*this, path, [&](Writer& w) {
      for (const Vector3d& p : cloud.points) w.row(p);
    });
  } else if (extension == ".xyzn") {
    if (!normals) failWrite(path, ".xyzn needs normals and the cloud has none");
    stage(*this, path, [&](Writer& w) {
      for (std::size_t i = 0; i < cloud.size(); ++i) {
        w.row(cloud.points[i], false);
        w.row(cloud.normals[i]);
      }
    });
  } else {
    failWrite(path,
              "unknown point cloud extension " + quoteToken(extension) + " (supported: .ply .xyz .xyzn)");
  }
}

void OutputBatch::mesh(const std::string& path, const TriangleMesh& mesh) {
  const std::string extension = extensionOf(path);
  if (extension != ".ply" && extension != ".obj" && extension != ".off")
    failWrite(path, "unknown mesh extension " + quoteToken(extension) + " (supported: .ply .obj .off)");
  checkTriangles(path, mesh);
  if (extension == ".ply") checkAttributes(path, mesh.vertexAttributes, mesh.vertices.size());
  stage(*this, path, [&](Writer& w) {
    if (extension == ".ply") {
      writePlyHeader(w, false, mesh.vertices.size(), false, mesh.triangles.size(), mesh.vertexAttributes);
      for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
        for (int k = 0; k < 3; ++k) w.binary(mesh.vertices[i][k]);
        writeAttributeValues(w, mesh.vertexAttributes, i, false);
      }
      for (const Vector3i& t : mesh.triangles) {
        w.binary(std::uint8_t{3});
        for (int k = 0; k < 3; ++k) w.binary(std::int32_t{t[k]});
      }
    } else if (extension == ".obj") {
      w.text("# written by iires\n");
      for (const Vector3d& v : mesh.vertices) {
        w.text("v ");
        w.row(v);
      }
      for (const Vector3i& t : mesh.triangles) {
        w.text("f ");
        w.row(Vector3i(t.array() + 1));
      }
    } else {
      w.text("OFF\n" + std::to_string(mesh.vertices.size()) + " " + std::to_string(mesh.triangles.size()) +
             " 0\n");
      for (const Vector3d& v : mesh.vertices) w.row(v);
      for (const Vector3i& t : mesh.triangles) {
        w.text("3 ");
        w.row(t);
      }
    }
  });
}

void OutputBatch::text(const std::string& path, const std::string& text) {
  stage(*this, path, [&](Writer& w) { w.text(text); });
}

void writePointCloud(const std::string& path, const PointCloud& cloud, bool ascii) {
  OutputBatch batch;
  batch.pointCloud(path, cloud, ascii);
  batch.commit();
}

void writeMesh(const std::string& path, const TriangleMesh& mesh) {
  OutputBatch batch;
  batch.mesh(path, mesh);
  batch.commit();
}

void writeTextFile(const std::string& path, const std::string& text) {
  OutputBatch batch;
  batch.text(path, text);
  batch.commit();
}

std::string extensionOf(const std::string& path) {
  std::string extension = fs::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return extension;
}

}  // namespace iires
