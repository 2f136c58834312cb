// SPDX-License-Identifier: GPL-3.0-or-later
// The compiled part of the `iires` Python package (python/iires/__init__.py wraps it): numpy arrays in and
// out, keyword parameters named after the command-line flags, the GIL released while the library computes.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "iires/reconstruct/mesh_quality.hpp"
#include "iires/reconstruct/reconstruct.hpp"
#include "iires/register/registration.hpp"
#include "iires/resample.hpp"
#include "iires/io.hpp"
#include "iires/knn.hpp"
#include "iires/detail/parallel.hpp"
#include "iires/types.hpp"
#include "iires/validate.hpp"
#include "params.hpp"

namespace py = pybind11;

namespace iires::python {
namespace {

using Points = std::vector<Eigen::Vector3d>;

/// Largest point count any call accepts for n (the command-line tools' limit).
constexpr long long kMaxCount = 100'000'000;

/// An (n, 3) array of any real dtype as points: the one copy of the call (float64 input is read in place).
Points toPoints(const py::handle& object, const char* what) {
  const auto array = py::array_t<double, py::array::forcecast>::ensure(object);
  if (!array || array.ndim() != 2 || array.shape(1) != 3)
    throw py::value_error(std::string(what) + ": expected an (n, 3) array of coordinates");
  const auto view = array.unchecked<2>();
  Points points(static_cast<std::size_t>(view.shape(0)));
  for (py::ssize_t i = 0; i < view.shape(0); ++i) points[static_cast<std::size_t>(i)] = {view(i, 0), view(i, 1), view(i, 2)};
  return points;
}

/// @p points as an (n, 3) float64 array that owns them (no copy: the vector moves into the array's capsule).
py::array_t<double> fromPoints(Points&& points) {
  auto* owned = new Points(std::move(points));
  py::capsule release(owned, [](void* p) { delete static_cast<Points*>(p); });
  const auto n = static_cast<py::ssize_t>(owned->size());
  return py::array_t<double>({n, py::ssize_t{3}}, {py::ssize_t{3 * sizeof(double)}, py::ssize_t{sizeof(double)}},
                             owned->empty() ? nullptr : owned->front().data(), release);
}

/// The report JSON of a result as a Python dict.
py::object toDict(const std::string& json) { return py::module_::import("json").attr("loads")(json); }

/// Library messages name the cloud "input"; in Python it is the argument @p name.
[[noreturn]] void rethrowNamed(const InputError& e, const std::string& name) {
  std::string message = e.what();
  if (message.rfind("input", 0) == 0) message = name + message.substr(5);
  throw py::value_error(message);
}

/// A per-point colour array (n, 3|4), uint8 or real, as red/green/blue[/alpha] attributes.
void addColours(PointCloud& cloud, const py::handle& colours) {
  const py::array raw = py::array::ensure(colours);
  if (!raw || raw.ndim() != 2 || (raw.shape(1) != 3 && raw.shape(1) != 4) ||
      raw.shape(0) != static_cast<py::ssize_t>(cloud.size()))
    throw py::value_error("colors: expected an (n, 3) or (n, 4) array, one row per point");
  const bool bytes = raw.dtype().is(py::dtype::of<std::uint8_t>());
  if (!bytes && raw.dtype().kind() != 'f')
    throw py::value_error("colors: expected uint8 (0-255) or floating-point values");
  const auto converted = py::array_t<double, py::array::forcecast>::ensure(raw);  // kept alive for the view
  const auto values = converted.unchecked<2>();
  const char* names[] = {"red", "green", "blue", "alpha"};
  for (py::ssize_t c = 0; c < values.shape(1); ++c) {
    PointAttribute a{names[c], AttributeKind::kColor, bytes ? "uchar" : "float", {}};
    a.values.resize(cloud.size());
    for (py::ssize_t i = 0; i < values.shape(0); ++i) a.values[static_cast<std::size_t>(i)] = values(i, c);
    cloud.attributes.push_back(std::move(a));
  }
}

/// Named 1-D arrays (a dict) as attributes: integer dtypes are labels (majority), real ones scalars (mean).
void addAttributes(PointCloud& cloud, const py::handle& attributes) {
  for (const auto& [key, value] : py::reinterpret_borrow<py::dict>(attributes)) {
    const std::string name = py::str(key);
    const py::array raw = py::array::ensure(value);
    if (!raw || raw.ndim() != 1 || raw.shape(0) != static_cast<py::ssize_t>(cloud.size()))
      throw py::value_error("attributes: \"" + name + "\" must be a 1-D array with one value per point");
    const char kind = raw.dtype().kind();
    if (kind != 'f' && kind != 'i' && kind != 'u' && kind != 'b')
      throw py::value_error("attributes: \"" + name + "\" must hold numbers");
    const auto converted = py::array_t<double, py::array::forcecast>::ensure(raw);  // kept alive for the view
    const auto values = converted.unchecked<1>();
    PointAttribute a{name, kind == 'f' ? AttributeKind::kScalar : AttributeKind::kLabel, kind == 'f' ? "double" : "int", {}};
    a.values.assign(values.data(0), values.data(0) + values.shape(0));
    cloud.attributes.push_back(std::move(a));
  }
}

/// The colour attributes of @p cloud as an (n, c) array of @p dtype (uint8: rounded and clamped).
py::array takeColours(const std::vector<PointAttribute>& attributes, std::size_t channels, const py::dtype& dtype) {
  const std::size_t n = attributes.empty() ? 0 : attributes[0].values.size();
  const bool bytes = dtype.is(py::dtype::of<std::uint8_t>());
  py::array out(dtype, {static_cast<py::ssize_t>(n), static_cast<py::ssize_t>(channels)});
  auto* u8 = static_cast<std::uint8_t*>(out.mutable_data());
  auto* f64 = static_cast<double*>(out.mutable_data());
  auto* f32 = static_cast<float*>(out.mutable_data());
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t c = 0; c < channels; ++c) {
      const double v = attributes[c].values[i];
      if (bytes) u8[i * channels + c] = static_cast<std::uint8_t>(std::clamp(std::round(v), 0.0, 255.0));
      else if (dtype.itemsize() == 4) f32[i * channels + c] = static_cast<float>(v);
      else f64[i * channels + c] = v;
    }
  return out;
}

/// Generic attributes back as a dict of 1-D arrays (labels int64, scalars float64), from index @p first on.
py::dict takeAttributes(const std::vector<PointAttribute>& attributes, std::size_t first) {
  py::dict out;
  for (std::size_t a = first; a < attributes.size(); ++a) {
    const std::vector<double>& v = attributes[a].values;
    if (attributes[a].kind == AttributeKind::kLabel) {
      py::array_t<std::int64_t> labels(static_cast<py::ssize_t>(v.size()));
      std::transform(v.begin(), v.end(), labels.mutable_data(), [](double x) { return static_cast<std::int64_t>(x); });
      out[py::str(attributes[a].name)] = labels;
    } else {
      out[py::str(attributes[a].name)] = py::array_t<double>(static_cast<py::ssize_t>(v.size()), v.data());
    }
  }
  return out;
}

/// A file's attributes as (colors, attributes): red green blue [alpha] first (as read_point_cloud finds them)
/// become an (n, 3|4) array, uint8 when stored as bytes, else float64; the others a dict.
std::pair<py::object, py::dict> splitColours(std::vector<PointAttribute> attributes) {
  static const char* const kChannels[] = {"red", "green", "blue", "alpha"};
  std::vector<PointAttribute> colours;
  for (const char* channel : kChannels) {
    const auto it = std::find_if(attributes.begin(), attributes.end(), [&](const PointAttribute& a) {
      return a.kind == AttributeKind::kColor && a.name == channel;
    });
    if (it == attributes.end()) break;
    colours.push_back(std::move(*it));
    attributes.erase(it);
  }
  if (colours.size() < 3) {  // not a colour: keep the channels as plain attributes
    attributes.insert(attributes.begin(), colours.begin(), colours.end());
    return {py::none(), takeAttributes(attributes, 0)};
  }
  const bool bytes = std::all_of(colours.begin(), colours.end(), [](const PointAttribute& a) { return a.type == "uchar"; });
  return {takeColours(colours, colours.size(), bytes ? py::dtype::of<std::uint8_t>() : py::dtype::of<double>()),
          takeAttributes(attributes, 0)};
}

void checkCount(long long n, long long minimum, const char* name) {
  if (n < minimum)
    throw py::value_error(std::string(name) + " must be at least " + std::to_string(minimum) + " (got " +
                          std::to_string(n) + ")");
  if (n > kMaxCount)
    throw py::value_error(std::string(name) + " = " + std::to_string(n) + " exceeds the limit of " +
                          std::to_string(kMaxCount) + " points");
}

py::tuple resampleBinding(const py::handle& points, long long n, const py::handle& normals, const py::handle& colours,
                          const py::handle& attributes, const py::dict& kwargs) {
  checkCount(n, 1, "n");
  PointCloud cloud;
  cloud.points = toPoints(points, "points");
  if (!normals.is_none()) {
    cloud.normals = toPoints(normals, "normals");
    if (cloud.normals.size() != cloud.size()) throw py::value_error("normals: expected one row per point");
  }
  std::size_t channels = 0;
  py::object colourType = py::none();
  if (!colours.is_none()) {
    addColours(cloud, colours);
    channels = cloud.attributes.size();
    const py::dtype in = py::array::ensure(colours).dtype();
    colourType = in.is(py::dtype::of<std::uint8_t>()) || in.itemsize() == 4 ? in : py::dtype::of<double>();
  }
  if (!attributes.is_none()) addAttributes(cloud, attributes);
  Execution exec;
  ResampleParams params = resampleParams(kwargs, exec);
  params.targetCount = static_cast<std::size_t>(n);
  ResampleResult result;
  try {
    py::gil_scoped_release release;
    result = resample(std::move(cloud), params, exec);
  } catch (const InputError& e) {
    rethrowNamed(e, "points");
  }
  const std::string report = result.toJson();
  py::object colourArray = channels ? py::object(takeColours(result.cloud.attributes, channels, colourType)) : py::none();
  py::dict other = takeAttributes(result.cloud.attributes, channels);
  return py::make_tuple(fromPoints(std::move(result.cloud.points)), fromPoints(std::move(result.cloud.normals)),
                        colourArray, other, toDict(report));
}

py::tuple registerBinding(const py::handle& source, const py::handle& target, const py::dict& kwargs) {
  PointCloud s, t;
  s.points = toPoints(source, "source");
  t.points = toPoints(target, "target");
  Execution exec;
  const reg::RegistrationParams params = registrationParams(kwargs, exec);
  reg::RegistrationResult result;
  {
    py::gil_scoped_release release;
    result = reg::registerClouds(s, t, params, exec);
  }
  py::array_t<double> matrix({4, 4});
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) matrix.mutable_at(r, c) = result.T_target_source(r, c);
  return py::make_tuple(matrix, toDict(result.toJson()));
}

py::tuple reconstructBinding(const py::handle& points, long long n, const py::handle& normals, const py::dict& kwargs) {
  checkCount(n, 4, "n");
  PointCloud cloud;
  cloud.points = toPoints(points, "points");
  if (!normals.is_none()) {
    cloud.normals = toPoints(normals, "normals");
    if (cloud.normals.size() != cloud.size()) throw py::value_error("normals: expected one row per point");
  }
  Execution exec;
  ReconstructParams params = reconstructParams(kwargs, exec);
  params.targetCount = static_cast<std::size_t>(n);
  ReconstructResult result;
  try {
    py::gil_scoped_release release;
    result = reconstruct(cloud, params, exec);
  } catch (const InputError& e) {
    rethrowNamed(e, "points");
  }
  py::array_t<std::int32_t> faces({static_cast<py::ssize_t>(result.mesh.triangles.size()), py::ssize_t{3}});
  std::int32_t* f = faces.mutable_data();
  for (const Eigen::Vector3i& t : result.mesh.triangles) f = std::copy(t.data(), t.data() + 3, f);
  const std::string report = result.toJson();
  return py::make_tuple(fromPoints(std::move(result.mesh.vertices)), faces, toDict(report));
}

/// Faces as an (m, 3) integer array of vertex indices, all in range.
std::vector<Eigen::Vector3i> toFaces(const py::handle& object, std::size_t vertices) {
  const py::array raw = py::array::ensure(object);
  if (!raw || raw.ndim() != 2 || raw.shape(1) != 3 || (raw.dtype().kind() != 'i' && raw.dtype().kind() != 'u'))
    throw py::value_error("faces: expected an (m, 3) integer array of vertex indices");
  const auto converted = py::array_t<std::int64_t, py::array::forcecast>::ensure(raw);  // kept alive for the view
  const auto view = converted.unchecked<2>();
  std::vector<Eigen::Vector3i> faces(static_cast<std::size_t>(view.shape(0)));
  for (py::ssize_t t = 0; t < view.shape(0); ++t)
    for (int k = 0; k < 3; ++k) {
      const std::int64_t v = view(t, k);
      if (v < 0 || v >= static_cast<std::int64_t>(vertices))
        throw py::value_error("faces: face " + std::to_string(t) + " refers to vertex " + std::to_string(v) +
                              " (the mesh has " + std::to_string(vertices) + " vertices)");
      faces[static_cast<std::size_t>(t)][k] = static_cast<int>(v);
    }
  return faces;
}

py::tuple readPointCloudBinding(const std::string& path, const std::vector<std::string>& columns) {
  PointCloud cloud;
  {
    py::gil_scoped_release release;
    cloud = readPointCloud(path, columns);
  }
  auto [colours, attributes] = splitColours(std::move(cloud.attributes));
  const bool normals = cloud.hasNormals();
  return py::make_tuple(fromPoints(std::move(cloud.points)),
                        normals ? py::object(fromPoints(std::move(cloud.normals))) : py::none(), colours, attributes);
}

void writePointCloudBinding(const std::string& path, const py::handle& points, const py::handle& normals,
                            const py::handle& colours, const py::handle& attributes, bool ascii) {
  PointCloud cloud;
  cloud.points = toPoints(points, "points");
  if (!normals.is_none()) {
    cloud.normals = toPoints(normals, "normals");
    if (cloud.normals.size() != cloud.size()) throw py::value_error("normals: expected one row per point");
  }
  if (!colours.is_none()) addColours(cloud, colours);
  if (!attributes.is_none()) addAttributes(cloud, attributes);
  py::gil_scoped_release release;
  writePointCloud(path, cloud, ascii);
}

py::tuple readMeshBinding(const std::string& path) {
  TriangleMesh mesh;
  {
    py::gil_scoped_release release;
    mesh = readMesh(path);
  }
  py::array_t<std::int32_t> faces({static_cast<py::ssize_t>(mesh.triangles.size()), py::ssize_t{3}});
  std::int32_t* f = faces.mutable_data();
  for (const Eigen::Vector3i& t : mesh.triangles) f = std::copy(t.data(), t.data() + 3, f);
  return py::make_tuple(fromPoints(std::move(mesh.vertices)), faces);
}

void writeMeshBinding(const std::string& path, const py::handle& vertices, const py::handle& faces,
                      const py::handle& colours) {
  TriangleMesh mesh;
  mesh.vertices = toPoints(vertices, "vertices");
  mesh.triangles = toFaces(faces, mesh.vertices.size());
  if (!colours.is_none()) {
    PointCloud carrier;  // addColours checks the row count against the points
    carrier.points = mesh.vertices;
    addColours(carrier, colours);
    mesh.vertexAttributes = std::move(carrier.attributes);
  }
  py::gil_scoped_release release;
  writeMesh(path, mesh);
}

/// Distance from each query to its nearest point of @p points; without queries, from each point to its
/// nearest other point (the spacing).
py::array_t<double> nearestDistancesBinding(const py::handle& points, const py::handle& queries) {
  const Points p = toPoints(points, "points");
  if (p.empty()) throw py::value_error("points: the cloud is empty");
  const bool self = queries.is_none();
  const Points q = self ? Points{} : toPoints(queries, "queries");
  const Points& at = self ? p : q;
  py::array_t<double> out(static_cast<py::ssize_t>(at.size()));
  double* d = out.mutable_data();
  {
    py::gil_scoped_release release;
    const KnnIndex index(p);
    parallelFor(at.size(), 0, [&](std::size_t i) {
      thread_local std::vector<std::uint32_t> idx;
      thread_local std::vector<double> d2;
      const std::size_t found = index.knn(at[i], self ? 2 : 1, idx, d2);
      d[i] = found == 0 ? 0.0 : std::sqrt(d2[self && found > 1 ? 1 : 0]);
    });
  }
  return out;
}

/// Q_t of every triangle (mesh_quality.hpp: 1 for equilateral, 0 for degenerate).
py::array_t<double> triangleQualitiesBinding(const py::handle& vertices, const py::handle& faces) {
  const Points v = toPoints(vertices, "vertices");
  const std::vector<Eigen::Vector3i> f = toFaces(faces, v.size());
  py::array_t<double> out(static_cast<py::ssize_t>(f.size()));
  double* q = out.mutable_data();
  for (std::size_t t = 0; t < f.size(); ++t) q[t] = triangleQuality(v[f[t][0]], v[f[t][1]], v[f[t][2]]);
  return out;
}

py::object meshQualityBinding(const py::handle& vertices, const py::handle& faces, const py::handle& reference,
                              const py::dict& kwargs) {
  TriangleMesh mesh;
  mesh.vertices = toPoints(vertices, "vertices");
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i)
    if (!mesh.vertices[i].allFinite())
      throw py::value_error("vertices: vertex " + std::to_string(i) + " has a non-finite coordinate (NaN or Inf)");
  mesh.triangles = toFaces(faces, mesh.vertices.size());
  if (mesh.triangles.empty()) throw py::value_error("faces: the mesh has no triangles");
  PointCloud cloud;
  if (!reference.is_none()) {
    cloud.points = toPoints(reference, "reference");
    try {
      validateCloud(cloud, 1, "reference");
    } catch (const InputError& e) {
      throw py::value_error(e.what());
    }
  }
  Execution exec;
  const MeshQualityParams params = meshQualityParams(kwargs, exec);
  MeshQuality quality;
  {
    py::gil_scoped_release release;
    quality = evaluateMesh(mesh, reference.is_none() ? nullptr : &cloud, params, exec);
  }
  return toDict(quality.toJson());
}

}  // namespace
}  // namespace iires::python

PYBIND11_MODULE(_iires, m) {
  using namespace iires::python;
  m.doc() = "Compiled core of the iires package; use the functions of `iires` instead.";
  m.attr("__version__") = IIRES_VERSION;
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const iires::InputError& e) {
      PyErr_SetString(PyExc_ValueError, e.what());
    }
  });
  m.def("resample", &resampleBinding, py::arg("points"), py::arg("n"), py::arg("normals"), py::arg("colors"),
        py::arg("attributes"), py::arg("params"));
  m.def("register", &registerBinding, py::arg("source"), py::arg("target"), py::arg("params"));
  m.def("reconstruct", &reconstructBinding, py::arg("points"), py::arg("n"), py::arg("normals"), py::arg("params"));
  m.def("mesh_quality", &meshQualityBinding, py::arg("vertices"), py::arg("faces"), py::arg("reference"),
        py::arg("params"));
  m.def("nearest_distances", &nearestDistancesBinding, py::arg("points"), py::arg("queries"));
  m.def("triangle_qualities", &triangleQualitiesBinding, py::arg("vertices"), py::arg("faces"));
  m.def("read_point_cloud", &readPointCloudBinding, py::arg("path"), py::arg("columns"));
  m.def("write_point_cloud", &writePointCloudBinding, py::arg("path"), py::arg("points"), py::arg("normals"),
        py::arg("colors"), py::arg("attributes"), py::arg("ascii"));
  m.def("read_mesh", &readMeshBinding, py::arg("path"));
  m.def("write_mesh", &writeMeshBinding, py::arg("path"), py::arg("vertices"), py::arg("faces"), py::arg("colors"));
}
