// SPDX-License-Identifier: GPL-3.0-or-later
// XYZ, XYZN and PTS: one point per text line.
#include "io_format.hpp"

#include <algorithm>
#include <cmath>
#include <optional>

namespace iires::detail::io {

std::string textSeparators(std::string_view text) {
  // The first line with a digit outside a '#' comment is data (a header names the columns without one).
  for (std::size_t pos = 0; pos < text.size();) {
    const std::size_t end = std::min(text.find('\n', pos), text.size());
    std::string_view line = text.substr(pos, end - pos);
    pos = end + 1;
    line = line.substr(0, line.find('#'));
    if (line.find_first_of("0123456789") == std::string_view::npos) continue;
    if (line.find(';') != std::string_view::npos) return ";";
    if (line.find(',') != std::string_view::npos) return ",";
    return {};
  }
  return {};
}

bool isHeaderLine(const LineReader& lines) {
  return std::none_of(lines.tokens().begin(), lines.tokens().end(), [](std::string_view token) {
    return token.find_first_of("0123456789") != std::string_view::npos;
  });
}

namespace {

/// x y z [nx ny nz] per line; every line has the column count of the first (3, or 6 with normals).
Geometry parseXyzColumns(const std::string& path, std::string_view text, bool normalsRequired) {
  Geometry geometry;
  LineReader lines(text, true, 1, textSeparators(text));
  std::size_t columns = 0;
  for (bool first = true; lines.next(); first = false) {
    if (first && isHeaderLine(lines)) continue;  // "x y z", "//X Y Z"
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

}  // namespace

Geometry parseXyz(const std::string& path, std::string_view text) {
  return parseXyzColumns(path, text, false);
}

Geometry parseXyzn(const std::string& path, std::string_view text) {
  return parseXyzColumns(path, text, true);
}

/// An optional point count on the first line, then x y z per line; further columns are ignored.
Geometry parsePts(const std::string& path, std::string_view text) {
  Geometry geometry;
  LineReader lines(text, true, 1, textSeparators(text));
  std::optional<long long> declared;
  for (bool first = true; lines.next(); first = false) {
    if (first && isHeaderLine(lines)) {
      first = lines.next();  // the line after a header may hold the count
      if (!first) break;
    }
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
  LineReader lines(text, true, 1, textSeparators(text));
  Vector3d p, n;
  for (bool first = true; lines.next(); first = false) {
    if (first && isHeaderLine(lines)) continue;  // the columns' names
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

void writeXyz(Writer& w, const PointCloud& cloud, bool normals) {
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    w.row(cloud.points[i], !normals);
    if (normals) w.row(cloud.normals[i]);
  }
}

}  // namespace iires::detail::io
