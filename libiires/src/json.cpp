// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/detail/json.hpp"

#include <cmath>
#include <cstdio>
#include <locale>
#include <sstream>

namespace iires::detail {

void JsonWriter::next() {
  if (afterKey_) {  // the value of a key: no separator
    afterKey_ = false;
    return;
  }
  if (levels_.empty()) return;
  Level& level = levels_.back();
  if (level.block) {
    out_ += level.empty ? "\n" : ",\n";
    out_.append(2 * levels_.size(), ' ');
  } else if (!level.empty) {
    out_ += ", ";
  }
  level.empty = false;
}

JsonWriter& JsonWriter::beginObject(bool block) {
  next();
  out_ += '{';
  levels_.push_back({block});
  return *this;
}

JsonWriter& JsonWriter::endObject() {
  const Level level = levels_.back();
  levels_.pop_back();
  if (level.block && !level.empty) {
    out_ += '\n';
    out_.append(2 * levels_.size(), ' ');
  }
  out_ += '}';
  return *this;
}

JsonWriter& JsonWriter::beginArray() {
  next();
  out_ += '[';
  levels_.push_back({false});
  return *this;
}

JsonWriter& JsonWriter::endArray() {
  levels_.pop_back();
  out_ += ']';
  return *this;
}

JsonWriter& JsonWriter::key(std::string_view name) {
  next();
  out_ += quoted(name);
  out_ += ": ";
  afterKey_ = true;
  return *this;
}

JsonWriter& JsonWriter::literal(std::string_view text) {
  next();
  out_ += text;
  return *this;
}

JsonWriter& JsonWriter::value(double x) {
  if (!std::isfinite(x)) return null();
  std::ostringstream os;
  os.imbue(std::locale::classic());
  os.precision(precision_);
  os << x;
  return literal(os.str());
}

JsonWriter& JsonWriter::value(bool b) { return literal(b ? "true" : "false"); }

JsonWriter& JsonWriter::value(std::string_view s) { return literal(quoted(s)); }

JsonWriter& JsonWriter::embed(std::string_view json) {
  while (!json.empty() && json.back() == '\n') json.remove_suffix(1);
  std::string indented;
  for (const char c : json) {
    indented += c;
    if (c == '\n') indented.append(2 * levels_.size(), ' ');
  }
  return literal(indented);
}

std::string JsonWriter::quoted(std::string_view text) {
  std::string out = "\"";
  for (const char c : text) {
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\r': out += "\\r"; break;
      case '\t': out += "\\t"; break;
      case '\b': out += "\\b"; break;
      case '\f': out += "\\f"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char escaped[8];
          std::snprintf(escaped, sizeof escaped, "\\u%04x", static_cast<unsigned>(static_cast<unsigned char>(c)));
          out += escaped;
        } else {
          out += c;
        }
    }
  }
  return out + "\"";
}

}  // namespace iires::detail
