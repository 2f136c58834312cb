// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file json.hpp
/// @brief The one JSON writer of the reports (internal). Objects are laid out as blocks (one member per line,
/// indented by two spaces a level) or inline (on one line); arrays are inline. Strings are escaped; numbers
/// have a given count of significant digits, and NaN or infinity is written as null.

#include <cstddef>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

namespace iires::detail {

class JsonWriter {
 public:
  /// @param precision significant digits of floating-point numbers (as printf's %.*g)
  explicit JsonWriter(int precision = 10) : precision_(precision) {}

  /// Opens an object: @p block puts each member on its own line, else all on one line.
  JsonWriter& beginObject(bool block = false);
  JsonWriter& endObject();
  JsonWriter& beginArray();
  JsonWriter& endArray();
  /// The next member's key (inside an object).
  JsonWriter& key(std::string_view name);

  JsonWriter& value(double x);
  JsonWriter& value(bool b);
  JsonWriter& value(std::string_view s);
  JsonWriter& value(const char* s) { return value(std::string_view(s)); }
  JsonWriter& value(const std::string& s) { return value(std::string_view(s)); }
  template <class Int, std::enable_if_t<std::is_integral_v<Int> && !std::is_same_v<Int, bool>, int> = 0>
  JsonWriter& value(Int n) {
    return literal(std::to_string(n));
  }
  JsonWriter& null() { return literal("null"); }
  /// A value that is already JSON text (another report's toJson()): trailing newlines are dropped and its
  /// continuation lines indented to this level.
  JsonWriter& embed(std::string_view json);

  /// key(name) then value(v).
  template <class T>
  JsonWriter& member(std::string_view name, const T& v) {
    key(name);
    return value(v);
  }
  /// An inline array of the values of @p values.
  template <class T>
  JsonWriter& array(std::string_view name, const std::vector<T>& values) {
    key(name).beginArray();
    for (const T& v : values) value(v);
    return endArray();
  }

  /// The text so far.
  const std::string& str() const { return out_; }

  /// @p text as a JSON string literal, quotes included.
  static std::string quoted(std::string_view text);

 private:
  struct Level {
    bool block;
    bool empty = true;
  };
  JsonWriter& literal(std::string_view text);
  /// Separator and indentation before a value or a key at the current level.
  void next();

  int precision_;
  std::string out_;
  std::vector<Level> levels_;
  bool afterKey_ = false;
};

}  // namespace iires::detail
