// SPDX-License-Identifier: GPL-3.0-or-later
// PLY (ascii, binary little- and big-endian): the reader keeps every vertex property; the writer takes extra
// per-vertex properties (geodesic coordinates, attributes) next to positions and normals.
#include "io_format.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <type_traits>

namespace iires::detail::io {

namespace {

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

}  // namespace

int findProperty(const PlyElement& element, std::initializer_list<std::string_view> names, bool list) {
  for (std::size_t p = 0; p < element.properties.size(); ++p)
    if (element.properties[p].list == list &&
        std::find(names.begin(), names.end(), element.properties[p].name) != names.end())
      return static_cast<int>(p);
  return -1;
}

namespace {

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

}  // namespace

PlyHeader parsePlyHeader(const std::string& path, std::string_view data) {
  LineReader lines(data, false);
  if (!lines.next() || lines.size() != 1 || lines[0] != "ply")
    fail(path, "corrupted header: the file does not start with \"ply\"");
  PlyHeader header;
  std::optional<std::string_view> format;
  std::vector<PlyElement>& elements = header.elements;
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
  header.format = std::string(*format);
  header.bodyOffset = lines.offset();
  header.bodyLine = lines.line() + 1;
  return header;
}

Geometry parsePly(const std::string& path, std::string_view data) {
  const PlyHeader header = parsePlyHeader(path, data);
  const std::string_view body = data.substr(header.bodyOffset);
  if (header.format == "ascii") {
    PlyAsciiSource source(path, body, header.bodyLine);
    return readPlyBody(path, header.elements, source);
  }
  PlyBinarySource source(path, body, header.format == "binary_big_endian");
  return readPlyBody(path, header.elements, source);
}

namespace {

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

/// Vertex @p i's property values: binary in their storage types, or ascii separated by spaces.
void writePropertyValues(Writer& w, const std::vector<PlyValues>& properties, const std::vector<ScalarType>& types,
                         std::size_t i, bool ascii) {
  for (std::size_t p = 0; p < properties.size(); ++p) {
    const double v = properties[p].value(i);
    const auto put = [&](auto typed) {
      if (!ascii) return w.binary(typed);
      if (p > 0) w.text(" ");
      if constexpr (std::is_floating_point_v<decltype(typed)>)
        w.number(typed);
      else
        w.number(static_cast<long long>(typed));  // chars as numbers
    };
    switch (types[p]) {
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

void writePlyHeader(Writer& w, const PlyContent& content, bool ascii) {
  w.text(std::string("ply\nformat ") + (ascii ? "ascii" : "binary_little_endian") + " 1.0\ncomment " +
         content.comment + "\nelement vertex " + std::to_string(content.points.size()) +
         "\nproperty double x\nproperty double y\nproperty double z\n");
  if (content.normals) w.text("property double nx\nproperty double ny\nproperty double nz\n");
  for (const PlyValues& p : content.properties) w.text("property " + p.type + " " + p.name + "\n");
  if (content.triangles && !content.triangles->empty())
    w.text("element face " + std::to_string(content.triangles->size()) +
           "\nproperty list uchar int vertex_indices\n");
  w.text("end_header\n");
}

}  // namespace

std::vector<PlyValues> plyProperties(const std::string& path, const std::vector<PointAttribute>& attributes,
                                     std::size_t vertices) {
  std::vector<PlyValues> properties;
  for (const PointAttribute& a : attributes) {
    if (a.values.size() != vertices)
      failWrite(path, "attribute " + quoteToken(a.name) + " has " + std::to_string(a.values.size()) +
                          " values for " + std::to_string(vertices) + " points");
    if (!plyScalarType(a.type)) failWrite(path, "attribute " + quoteToken(a.name) + " has unknown type " + quoteToken(a.type));
    properties.push_back({a.name, a.type, [&values = a.values](std::size_t i) { return values[i]; }});
  }
  return properties;
}

void stagePly(OutputBatch& batch, const std::string& path, const PlyContent& content, bool ascii) {
  std::vector<ScalarType> types;
  for (const PlyValues& p : content.properties) {
    const std::optional<ScalarType> type = plyScalarType(p.type);
    if (!type) failWrite(path, "property " + quoteToken(p.name) + " has unknown type " + quoteToken(p.type));
    types.push_back(*type);
  }
  const std::vector<Vector3d>& points = content.points;
  const std::vector<Vector3d>* normals = content.normals;
  const bool properties = !content.properties.empty();
  stage(batch, path, [&](Writer& w) {
    writePlyHeader(w, content, ascii);
    for (std::size_t i = 0; i < points.size(); ++i) {
      if (ascii) {
        w.row(points[i], !normals && !properties);
        if (normals) w.row((*normals)[i], !properties);
        if (properties) {
          writePropertyValues(w, content.properties, types, i, true);
          w.text("\n");
        }
        continue;
      }
      for (int k = 0; k < 3; ++k) w.binary(points[i][k]);
      for (int k = 0; normals && k < 3; ++k) w.binary((*normals)[i][k]);
      writePropertyValues(w, content.properties, types, i, false);
    }
    if (!content.triangles) return;
    for (const Vector3i& t : *content.triangles) {
      if (ascii) {
        w.text("3 ");
        w.row(t);
        continue;
      }
      w.binary(std::uint8_t{3});
      for (int k = 0; k < 3; ++k) w.binary(std::int32_t{t[k]});
    }
  });
}

}  // namespace iires::detail::io
