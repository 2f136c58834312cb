// SPDX-License-Identifier: GPL-3.0-or-later
#include "io_format.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <iterator>

namespace iires::detail::io {

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

[[noreturn]] void failWrite(const std::string& path, const std::string& problem) {
  throw InputError("cannot write " + path + ": " + problem);
}

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

/// Stages a file written through a Writer in @p batch.
void stage(OutputBatch& batch, const std::string& path, const std::function<void(Writer&)>& body) {
  batch.file(path, [&](std::ostream& out) {
    Writer writer(out);
    body(writer);
    writer.flush();
  });
}

}  // namespace iires::detail::io
