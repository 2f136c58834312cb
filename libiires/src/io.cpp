// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/io.hpp"

#include "atomic_file.hpp"
#include "io_format.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <string_view>
#include <vector>

namespace iires {
namespace {

using namespace detail::io;
namespace fs = std::filesystem;

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

void checkTriangles(const std::string& path, const TriangleMesh& mesh) {
  const auto count = static_cast<int>(mesh.vertices.size());
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
    if (mesh.triangles[t].minCoeff() < 0 || mesh.triangles[t].maxCoeff() >= count)
      failWrite(path, "triangle " + std::to_string(t) + " refers to a vertex out of range (the mesh has " +
                          std::to_string(count) + " vertices)");
}

}  // namespace

namespace {

/// The file's geometry as readPointCloud() and readSurfacePoints() take it.
Geometry readCloudGeometry(const std::string& path, const std::vector<std::string>& columns) {
  if (columns.empty()) return load(path, false);
  checkRegularFile(path);
  if (extensionOf(path) != ".xyz") fail(path, "column names apply to .xyz files only");
  Geometry geometry = parseXyzNamedColumns(path, readFile(path, Signature::kText), columns);
  if (geometry.points.empty()) fail(path, "the file holds no points");
  return geometry;
}

PointCloud toCloud(Geometry geometry) {
  PointCloud cloud;
  cloud.points = std::move(geometry.points);
  cloud.normals = std::move(geometry.normals);
  cloud.attributes = std::move(geometry.attributes);
  return cloud;
}

}  // namespace

PointCloud readPointCloud(const std::string& path) { return readPointCloud(path, {}); }

PointCloud readPointCloud(const std::string& path, const std::vector<std::string>& columns) {
  Geometry geometry = readCloudGeometry(path, columns);
  if (geometry.normals.empty() && !geometry.triangles.empty()) {
    // Mesh vertices: area-weighted face normals, oriented by the winding (exact where PCA would guess).
    std::vector<Vector3d> normals(geometry.points.size(), Vector3d::Zero());
    for (const Eigen::Vector3i& t : geometry.triangles) {
      const Vector3d& a = geometry.points[t[0]];
      const Vector3d n = (geometry.points[t[1]] - a).cross(geometry.points[t[2]] - a);
      for (int k = 0; k < 3; ++k) normals[t[k]] += n;
    }
    const bool complete = std::all_of(normals.begin(), normals.end(), [](const Vector3d& n) {
      return n.squaredNorm() > 0 && n.allFinite();
    });
    if (complete) {
      for (Vector3d& n : normals) n.normalize();
      geometry.normals = std::move(normals);
    }
  }
  return toCloud(std::move(geometry));
}

PointCloud readSurfacePoints(const std::string& path, const std::vector<std::string>& columns) {
  // Normals the file does not give are left to the resampler's estimate from the dense points: the area-weighted
  // ones of a coarse polyhedron's vertices lean over its creases (3torus.off, 19 vertices: spacing cv 0.28 at 1,000
  // points with them or with the faces' normals, 0.063 without).
  Geometry geometry = readCloudGeometry(path, columns);
  if (!geometry.triangles.empty()) addFaceSamples(geometry);
  return toCloud(std::move(geometry));
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
    PlyContent content{cloud.points, normals ? &cloud.normals : nullptr,
                       plyProperties(path, cloud.attributes, cloud.size())};
    stagePly(*this, path, content, ascii);
  } else if (extension == ".xyz" || extension == ".xyzn") {
    if (extension == ".xyzn" && !normals) failWrite(path, ".xyzn needs normals and the cloud has none");
    stage(*this, path, [&](Writer& w) { writeXyz(w, cloud, extension == ".xyzn"); });
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
  if (extension == ".ply") {
    PlyContent content{mesh.vertices, nullptr, plyProperties(path, mesh.vertexAttributes, mesh.vertices.size())};
    content.triangles = &mesh.triangles;
    stagePly(*this, path, content, false);
  } else {
    stage(*this, path, [&](Writer& w) { extension == ".obj" ? writeObj(w, mesh) : writeOff(w, mesh); });
  }
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
  return extension == ".pwn" ? ".xyzn" : extension;  // CGAL's points with normals: the same text format
}

}  // namespace iires
