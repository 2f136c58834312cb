// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The pieces the format files of io share (internal, not installed): messages, the text tokenizer, binary
// scalars, attribute types, the buffered writer, and each format's entry points. io.cpp dispatches on the
// extension; io_ply.cpp, io_pcd.cpp, io_text.cpp (xyz, xyzn, pts) and io_mesh_formats.cpp (off, obj, stl)
// hold one format family each.

#include "iires/io.hpp"
#include "iires/types.hpp"

#include <Eigen/Core>

#include <algorithm>
#include <charconv>
#include <cstddef>
#include <cstring>
#include <functional>
#include <optional>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

namespace iires::detail::io {

using Eigen::Vector3d;
using Eigen::Vector3i;

extern const bool kHostLittleEndian;

/// Throws InputError("<path>: <problem>").
[[noreturn]] void fail(const std::string& path, const std::string& problem);
/// Throws InputError("<path>: line <line>: <problem>").
[[noreturn]] void failAt(const std::string& path, std::size_t line, const std::string& problem);
/// Throws InputError("cannot write <path>: <problem>").
[[noreturn]] void failWrite(const std::string& path, const std::string& problem);
/// A token as it may appear in a message: quoted, non-printable bytes replaced, at most 32 characters.
std::string quoteToken(std::string_view token);
std::string lowerCase(std::string_view text);

/// What a reader found: vertices, normals (empty or one per vertex), the faces, fan-triangulated, and the
/// vertices' other properties (attributes, each with one value per vertex).
struct Geometry {
  std::vector<Vector3d> points;
  std::vector<Vector3d> normals;
  std::vector<Vector3i> triangles;
  std::vector<PointAttribute> attributes;
};

void addPolygon(Geometry& geometry, const std::vector<int>& polygon);

/// The face points of readSurfacePoints() (io.hpp), appended to @p geometry's vertices: one per s² of a face's
/// area, s the median edge length (io_face_samples.cpp).
void addFaceSamples(Geometry& geometry);

// ---------------------------------------------------------------------------------------------------------
// Text parsing

/// Parses a whole token as a double (locale-independent; "nan" and "inf" are accepted).
bool parseDouble(std::string_view token, double& value);
/// Parses a whole token as an integer.
bool parseInteger(std::string_view token, long long& value);

/// Splits text into lines (LF or CRLF) and lines into whitespace-separated tokens (and at @p separators, e.g. ","
/// in a CSV file), skipping blank lines and, when asked, '#' comments. A UTF-8 byte-order mark opening the text
/// is skipped.
class LineReader {
 public:
  LineReader(std::string_view text, bool hashComments, std::size_t firstLine = 1, std::string_view separators = {})
      : text_(text), comments_(hashComments), line_(firstLine - 1), separators_(std::string(kSpace) += separators) {
    if (text_.substr(0, 3) == "\xEF\xBB\xBF") pos_ = 3;
  }

  /// Advances to the next line holding a token; false at the end of the text.
  bool next() {
    while (pos_ < text_.size()) {
      const std::size_t end = std::min(text_.find('\n', pos_), text_.size());
      std::string_view line = text_.substr(pos_, end - pos_);
      pos_ = std::min(end + 1, text_.size());
      ++line_;
      if (comments_) line = line.substr(0, line.find('#'));
      tokens_.clear();
      for (std::size_t i = line.find_first_not_of(separators_); i != std::string_view::npos;
           i = line.find_first_not_of(separators_, i)) {
        const std::size_t j = std::min(line.find_first_of(separators_, i), line.size());
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
  std::string separators_;
  std::size_t pos_ = 0;
  std::vector<std::string_view> tokens_;
};

/// A text point file's layout: its field separators besides blanks ("," for CSV, ";" where its first data line
/// has one, where a ',' may be a decimal comma and is left to fail as a number), for LineReader.
std::string textSeparators(std::string_view text);
/// Whether the current line of @p lines is a header naming the columns ("x y z", CloudCompare's "//X Y Z"): no
/// digit in it (a line of data with a bad value is an error, not a header).
bool isHeaderLine(const LineReader& lines);

double number(const std::string& path, const LineReader& lines, std::size_t i);
Vector3d vector3(const std::string& path, const LineReader& lines, std::size_t first);
long long integer(const std::string& path, const LineReader& lines, std::size_t i);

// ---------------------------------------------------------------------------------------------------------
// Binary scalars (PLY, PCD, STL)

enum class ScalarType { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64 };

std::size_t sizeOf(ScalarType type);
/// The value of the sizeOf(@p type) bytes at @p data, byte-swapped when @p swap.
double decode(ScalarType type, const char* data, bool swap);
/// Rejects data after the last element of a binary body (trailing whitespace is tolerated).
void checkNoTrailingData(const std::string& path, std::string_view rest);

// ---------------------------------------------------------------------------------------------------------
// Per-point attributes: every vertex property that is not a position or a normal (PLY properties, PCD fields,
// named XYZ columns) is kept, with the type it was stored as.

/// The PLY name of a scalar type: how attributes of that type are written back.
std::string plyTypeName(ScalarType type);
/// The scalar type of a PLY type name (char, uchar, ..., also int8, uint8, ..., float64).
std::optional<ScalarType> plyScalarType(std::string_view name);
/// Colour channels are averaged, other integer properties are labels (majority), the rest scalars (averaged).
AttributeKind attributeKind(std::string_view name, ScalarType type);
PointAttribute makeAttribute(std::string_view name, ScalarType type);

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

/// Stages a file written through a Writer in @p batch.
void stage(OutputBatch& batch, const std::string& path, const std::function<void(Writer&)>& body);

// ---------------------------------------------------------------------------------------------------------
// The formats

Geometry parsePly(const std::string& path, std::string_view data);

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

/// A PLY header: the format ("ascii", "binary_little_endian", "binary_big_endian"), the elements, and where
/// the body starts (byte offset, line number).
struct PlyHeader {
  std::string format;
  std::vector<PlyElement> elements;
  std::size_t bodyOffset = 0, bodyLine = 0;
};
/// Parses the header at the start of @p data (which must hold at least the whole header).
PlyHeader parsePlyHeader(const std::string& path, std::string_view data);
/// Index of the property called one of @p names in @p element (a list property when @p list), or -1.
int findProperty(const PlyElement& element, std::initializer_list<std::string_view> names, bool list);
Geometry parsePcd(const std::string& path, std::string_view data);
Geometry parseXyz(const std::string& path, std::string_view text);
Geometry parseXyzn(const std::string& path, std::string_view text);
Geometry parsePts(const std::string& path, std::string_view text);
/// One value per named column on every line (names as in readPointCloud's @p columns).
Geometry parseXyzNamedColumns(const std::string& path, std::string_view text, const std::vector<std::string>& columns);
Geometry parseOff(const std::string& path, std::string_view text);
Geometry parseObj(const std::string& path, std::string_view text);
Geometry parseStl(const std::string& path, std::string_view data);

/// A vertex property the PLY writer adds after x y z [nx ny nz]: value(i) stored as the PLY type @p type
/// (integer types rounded and clamped to their range, NaN as 0).
struct PlyValues {
  std::string name;
  std::string type;
  std::function<double(std::size_t)> value;
};

/// What a PLY file holds: vertices (with normals when @p normals is not null), their extra properties, and
/// triangles when @p triangles is not null.
struct PlyContent {
  const std::vector<Vector3d>& points;
  const std::vector<Vector3d>* normals = nullptr;  ///< one per point
  std::vector<PlyValues> properties;
  const std::vector<Vector3i>* triangles = nullptr;
  std::string comment = "written by iires";  ///< the header's comment line
};

/// @p attributes as PLY properties, after checking that each has one value per vertex and a PLY type.
std::vector<PlyValues> plyProperties(const std::string& path, const std::vector<PointAttribute>& attributes,
                                     std::size_t vertices);
/// Stages a PLY file (binary little-endian unless @p ascii) in @p batch.
void stagePly(OutputBatch& batch, const std::string& path, const PlyContent& content, bool ascii);
/// x y z per line, then nx ny nz on the same line when @p normals.
void writeXyz(Writer& w, const PointCloud& cloud, bool normals);
void writeObj(Writer& w, const TriangleMesh& mesh);
void writeOff(Writer& w, const TriangleMesh& mesh);

}  // namespace iires::detail::io
