// SPDX-License-Identifier: GPL-3.0-or-later
// PCD (PCL's format): ascii, binary and binary_compressed bodies.
#include "io_format.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <iterator>

namespace iires::detail::io {

namespace {

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

/// PCL marks the pixels of an organised cloud (a depth camera's, a structured-light scan's) that measured nothing
/// with NaN coordinates (is_dense false): they are no points, and are left out with their normals and attributes.
void dropUnmeasured(Geometry& g) {
  std::size_t kept = 0;
  for (std::size_t i = 0; i < g.points.size(); ++i) {
    if (std::isnan(g.points[i].x()) || std::isnan(g.points[i].y()) || std::isnan(g.points[i].z())) continue;
    g.points[kept] = g.points[i];
    if (!g.normals.empty()) g.normals[kept] = g.normals[i];
    for (PointAttribute& a : g.attributes) a.values[kept] = a.values[i];
    ++kept;
  }
  g.points.resize(kept);
  if (!g.normals.empty()) g.normals.resize(kept);
  for (PointAttribute& a : g.attributes) a.values.resize(kept);
}

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

}  // namespace

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
  dropUnmeasured(geometry);
  return geometry;
}

}  // namespace iires::detail::io
