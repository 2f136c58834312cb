// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/io.hpp"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "test_util.hpp"

namespace iires {
namespace {

namespace fs = std::filesystem;
using Eigen::Vector3d;
using Eigen::Vector3i;

::testing::AssertionResult contains(const std::string& text, const std::string& part) {
  if (text.find(part) != std::string::npos) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "\"" << text << "\" does not contain \"" << part << "\"";
}

/// The message of the InputError that @p f throws; a test failure and "" when it throws none.
template <class F>
std::string inputError(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "no InputError thrown";
  return "";
}

/// Bytes of a scalar, little- or big-endian.
template <class T>
std::string bytes(T value, bool bigEndian = false) {
  std::string out(sizeof value, '\0');
  std::memcpy(out.data(), &value, sizeof value);
  if (bigEndian) std::reverse(out.begin(), out.end());
  return out;
}

/// LZF (liblzf's format) using literal runs, and distance-1 back references for runs of a repeated byte.
std::string lzfCompress(const std::string& in) {
  std::string out, literal;
  const auto flushLiteral = [&] {
    for (std::size_t i = 0; i < literal.size(); i += 32)
      out += char(std::min<std::size_t>(32, literal.size() - i) - 1) + literal.substr(i, 32);
    literal.clear();
  };
  for (std::size_t i = 0; i < in.size();) {
    std::size_t run = 0;
    while (i > 0 && i + run < in.size() && in[i + run] == in[i - 1] && run < 264) ++run;
    if (run < 3) {
      literal += in[i++];
      continue;
    }
    flushLiteral();
    const std::size_t length = run - 2;
    out += length < 7 ? std::string(1, char(length << 5)) : std::string{char(7 << 5), char(length - 7)};
    out += '\0';  // distance 1
    i += run;
  }
  flushLiteral();
  return out;
}

std::vector<std::string> listDir(const std::string& dir) {
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(dir)) names.push_back(entry.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

class IoTest : public ::testing::Test {
 protected:
  /// Writes @p content to a file called @p name in the test's directory and returns its path.
  std::string file(const std::string& name, const std::string& content) {
    const std::string path = dir_ + "/" + name;
    std::ofstream(path, std::ios::binary) << content;
    return path;
  }

  std::string path(const std::string& name) const { return dir_ + "/" + name; }

  /// readPointCloud(@p name) throws an InputError naming the file and containing @p problem.
  void expectCloudError(const std::string& name, const std::string& problem) {
    const std::string message = inputError([&] { readPointCloud(path(name)); });
    EXPECT_TRUE(contains(message, name));
    EXPECT_TRUE(contains(message, problem));
  }

  void expectMeshError(const std::string& name, const std::string& problem) {
    const std::string message = inputError([&] { readMesh(path(name)); });
    EXPECT_TRUE(contains(message, name));
    EXPECT_TRUE(contains(message, problem));
  }

  static PointCloud sampleCloud() {
    PointCloud cloud;
    cloud.points = {{0.1, 1.0 / 3.0, -2.5e-7}, {123456.789012345, -0.0, 1e300}, {5e-324, 2.0, -1.0 / 7.0}};
    cloud.normals = {
        {0, 0, 1}, {0.6, 0.8, 0}, {-1.0 / std::sqrt(3.0), 1.0 / std::sqrt(3.0), 1.0 / std::sqrt(3.0)}};
    return cloud;
  }

  static TriangleMesh sampleMesh() {
    return {{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1.0 / 3.0}},
            {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}},
            {}};
  }

  std::string dir_ = test::tempDir();
};

// ------------------------------------------------------------------------------------------------ writing

TEST(ExtensionOf, LowerCaseWithDot) {
  EXPECT_EQ(extensionOf("a/b/Bunny.PLY"), ".ply");
  EXPECT_EQ(extensionOf("cloud.xyzn"), ".xyzn");
  EXPECT_EQ(extensionOf("cube.Pwn"), ".xyzn");  // CGAL's name for the same format
  EXPECT_EQ(extensionOf("archive.tar.GZ"), ".gz");
  EXPECT_EQ(extensionOf("dir.d/noext"), "");
  EXPECT_EQ(extensionOf(""), "");
}

TEST_F(IoTest, PlyRoundTripBinaryAndAsciiWithNormals) {
  const PointCloud cloud = sampleCloud();
  for (const bool ascii : {false, true}) {
    SCOPED_TRACE(ascii ? "ascii" : "binary");
    const std::string out = path(ascii ? "ascii.ply" : "binary.ply");
    writePointCloud(out, cloud, ascii);
    const std::string text = test::readText(out);
    EXPECT_TRUE(contains(text, ascii ? "format ascii 1.0" : "format binary_little_endian 1.0"));
    EXPECT_TRUE(contains(text, "property double x\n"));
    EXPECT_TRUE(contains(text, "property double nz\n"));
    const PointCloud back = readPointCloud(out);
    EXPECT_EQ(back.points, cloud.points);  // exact: doubles, shortest round-trip text in ascii
    EXPECT_EQ(back.normals, cloud.normals);
  }
}

TEST_F(IoTest, PlyRoundTripWithoutNormals) {
  PointCloud cloud = sampleCloud();
  cloud.normals.clear();
  writePointCloud(path("p.ply"), cloud);
  EXPECT_FALSE(contains(test::readText(path("p.ply")), "property double nx"));
  const PointCloud back = readPointCloud(path("p.ply"));
  EXPECT_EQ(back.points, cloud.points);
  EXPECT_FALSE(back.hasNormals());
}

TEST_F(IoTest, XyzAndXyznRoundTrip) {
  const PointCloud cloud = sampleCloud();
  writePointCloud(path("p.xyz"), cloud);
  PointCloud back = readPointCloud(path("p.xyz"));
  EXPECT_EQ(back.points, cloud.points);
  EXPECT_TRUE(back.normals.empty());

  writePointCloud(path("p.xyzn"), cloud);
  back = readPointCloud(path("p.xyzn"));
  EXPECT_EQ(back.points, cloud.points);
  EXPECT_EQ(back.normals, cloud.normals);
}

TEST_F(IoTest, XyznNeedsNormals) {
  PointCloud cloud = sampleCloud();
  cloud.normals.clear();
  EXPECT_TRUE(contains(inputError([&] { writePointCloud(path("p.xyzn"), cloud); }), "p.xyzn"));
  EXPECT_TRUE(listDir(dir_).empty());
}

TEST_F(IoTest, MeshRoundTripPlyObjOff) {
  const TriangleMesh mesh = sampleMesh();
  for (const std::string name : {"m.ply", "m.obj", "m.off"}) {
    SCOPED_TRACE(name);
    writeMesh(path(name), mesh);
    const TriangleMesh back = readMesh(path(name));
    EXPECT_EQ(back.vertices, mesh.vertices);
    EXPECT_EQ(back.triangles, mesh.triangles);
    EXPECT_EQ(readPointCloud(path(name)).points, mesh.vertices);
  }
}

TEST_F(IoTest, WriteMeshRejectsBadIndicesAndExtensions) {
  TriangleMesh mesh = sampleMesh();
  EXPECT_TRUE(contains(inputError([&] { writeMesh(path("m.stl"), mesh); }), "m.stl"));
  mesh.triangles.push_back({0, 1, 4});
  EXPECT_TRUE(contains(inputError([&] { writeMesh(path("m.off"), mesh); }), "m.off"));
  EXPECT_TRUE(listDir(dir_).empty());
}

TEST_F(IoTest, WriteTextFile) {
  writeTextFile(path("report.json"), "{\"a\": 1}\n");
  EXPECT_EQ(test::readText(path("report.json")), "{\"a\": 1}\n");
  writeTextFile(path("report.json"), "x");  // replaces
  EXPECT_EQ(test::readText(path("report.json")), "x");
  EXPECT_EQ(listDir(dir_), std::vector<std::string>{"report.json"});
}

TEST_F(IoTest, AtomicWriteToMissingDirectoryLeavesNothing) {
  const std::string target = path("missing/out.ply");
  const std::string message = inputError([&] { writePointCloud(target, sampleCloud()); });
  EXPECT_TRUE(contains(message, "out.ply"));
  EXPECT_TRUE(contains(message, "does not exist"));
  EXPECT_FALSE(fs::exists(path("missing")));
  EXPECT_TRUE(listDir(dir_).empty());
  EXPECT_TRUE(contains(inputError([&] { writeTextFile(path("missing/r.txt"), "x"); }), "r.txt"));
}

TEST_F(IoTest, AtomicWriteLeavesNoTemporaryFiles) {
  writePointCloud(path("a.ply"), sampleCloud());
  writePointCloud(path("a.xyz"), sampleCloud());
  writeMesh(path("m.obj"), sampleMesh());
  EXPECT_EQ(listDir(dir_), (std::vector<std::string>{"a.ply", "a.xyz", "m.obj"}));
}

TEST_F(IoTest, FailedRenameRemovesTemporaryFile) {
  fs::create_directory(path("taken.ply"));  // the target is a directory
  EXPECT_TRUE(contains(inputError([&] { writePointCloud(path("taken.ply"), sampleCloud()); }), "taken.ply"));
  EXPECT_EQ(listDir(dir_), std::vector<std::string>{"taken.ply"});
}

TEST_F(IoTest, UnknownOutputExtensionWritesNothing) {
  const std::string message = inputError([&] { writePointCloud(path("p.las"), sampleCloud()); });
  EXPECT_TRUE(contains(message, "p.las"));
  EXPECT_TRUE(contains(message, ".xyzn"));
  EXPECT_TRUE(listDir(dir_).empty());
}

// ------------------------------------------------------------------------------------------------ reading

TEST_F(IoTest, ReadsAsciiPlyWithMixedTypesCrlfAndFaces) {
  file("a.ply",
       "ply\r\nformat ascii 1.0\r\ncomment made by hand\r\nelement vertex 4\r\nproperty float x\r\n"
       "property double y\r\nproperty int z\r\nproperty uchar red\r\nproperty float nx\r\nproperty float "
       "ny\r\n"
       "property float nz\r\nelement face 1\r\nproperty list uchar int vertex_indices\r\nend_header\r\n"
       "0 0 0 255 0 0 1\r\n1 0 0 7 0 0 1\r\n1 1.5 0 7 0 0 1\r\n0 1 -3 7 0 0 1\r\n4 0 1 2 3\r\n");
  const PointCloud cloud = readPointCloud(path("a.ply"));
  ASSERT_EQ(cloud.size(), 4u);
  EXPECT_EQ(cloud.points[2], Vector3d(1, 1.5, 0));
  EXPECT_EQ(cloud.points[3], Vector3d(0, 1, -3));
  ASSERT_TRUE(cloud.hasNormals());
  EXPECT_EQ(cloud.normals[1], Vector3d(0, 0, 1));
  const TriangleMesh mesh = readMesh(path("a.ply"));
  EXPECT_EQ(mesh.triangles, (std::vector<Vector3i>{{0, 1, 2}, {0, 2, 3}}));
}

TEST_F(IoTest, ReadsBigEndianBinaryPly) {
  std::string body;
  const float xyz[3][3] = {{1, 2, 3}, {-1, 0.5f, 0}, {4, 5, 6}};
  for (const auto& v : xyz)
    body += bytes(v[0], true) + bytes(v[1], true) + bytes(v[2], true) + bytes<uint8_t>(9);
  body += bytes<uint8_t>(3) + bytes<uint32_t>(2, true) + bytes<uint32_t>(1, true) + bytes<uint32_t>(0, true);
  file("be.ply",
       "ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty float32 x\nproperty float32 y\n"
       "property float32 z\nproperty uint8 quality\nelement face 1\nproperty list uint8 uint32 vertex_index\n"
       "end_header\n" +
           body);
  const TriangleMesh mesh = readMesh(path("be.ply"));
  ASSERT_EQ(mesh.vertices.size(), 3u);
  EXPECT_EQ(mesh.vertices[1], Vector3d(-1, 0.5, 0));
  EXPECT_EQ(mesh.triangles, std::vector<Vector3i>{Vector3i(2, 1, 0)});
}

TEST_F(IoTest, ReadsXyzWithCommentsCrlfAndOptionalNormals) {
  file("a.xyz", "# comment\r\n1 2 3\r\n\r\n  4\t5 6   # trailing\r\n-7e-1 +8 9\r\n");
  const PointCloud cloud = readPointCloud(path("a.xyz"));
  EXPECT_EQ(cloud.points, (std::vector<Vector3d>{{1, 2, 3}, {4, 5, 6}, {-0.7, 8, 9}}));
  EXPECT_FALSE(cloud.hasNormals());

  file("n.xyz", "1 2 3 0 0 1\n4 5 6 1 0 0\n");
  EXPECT_EQ(readPointCloud(path("n.xyz")).normals, (std::vector<Vector3d>{{0, 0, 1}, {1, 0, 0}}));
  file("a.xyzn", "1 2 3 0 0 1\n");
  EXPECT_EQ(readPointCloud(path("a.xyzn")).normals, std::vector<Vector3d>{Vector3d(0, 0, 1)});
}

// CGAL's points with normals (.pwn, as in its data archive: x y z nx ny nz per line) read and write as .xyzn.
TEST_F(IoTest, CgalPointsWithNormals) {
  file("s.pwn", "2.78865 0.400948 -9.59493 0.27886 0.0400935 -0.959495\n4 0 1 1 0 0\n");
  const PointCloud cloud = readPointCloud(path("s.pwn"));
  EXPECT_EQ(cloud.points, (std::vector<Vector3d>{{2.78865, 0.400948, -9.59493}, {4, 0, 1}}));
  EXPECT_EQ(cloud.normals, (std::vector<Vector3d>{{0.27886, 0.0400935, -0.959495}, {1, 0, 0}}));
  writePointCloud(path("t.PWN"), cloud);
  EXPECT_EQ(readPointCloud(path("t.PWN")).normals, cloud.normals);
  file("bad.pwn", "1 2 3\n");  // no normals: an error, as in a .xyzn
  expectCloudError("bad.pwn", "line 1");
}

// Text files as other tools write them: a header naming the columns ("x y z", CloudCompare's "//X Y Z"), a UTF-8
// byte-order mark, commas (CSV) or semicolons between the values. A semicolon file's decimal commas are no
// numbers: an error, never values read in the wrong columns.
TEST_F(IoTest, ReadsXyzWithHeadersByteOrderMarksAndSeparators) {
  const std::vector<Vector3d> expected{{1, 2, 3}, {4.5, 5, 6}};
  for (const auto& [name, text] : std::vector<std::pair<std::string, std::string>>{
           {"h.xyz", "x y z\n1 2 3\n4.5 5 6\n"},
           {"cc.xyz", "//X Y Z\r\n1 2 3\r\n4.5 5 6\r\n"},
           {"bom.xyz", "\xEF\xBB\xBF" "1 2 3\n4.5 5 6\n"},
           {"csv.xyz", "x,y,z\n1,2,3\n4.5, 5, 6\n"},
           {"semicolon.xyz", "1;2;3\n4.5;5;6\n"},
           {"h.pts", "X Y Z\n2\n1 2 3\n4.5 5 6\n"}}) {
    file(name, text);
    EXPECT_EQ(readPointCloud(path(name)).points, expected) << name;
  }
  file("comma.xyz", "1,0;2,0;3,0\n");
  expectCloudError("comma.xyz", "malformed number");
  file("words.xyz", "x y z\nfoo bar baz\n");
  expectCloudError("words.xyz", "line 2: malformed number");
}

TEST_F(IoTest, ReadsPtsWithAndWithoutCount) {
  file("a.pts", "2\n1 2 3 -1200 255 0 0\n4 5 6 -800 0 255 0\n");
  EXPECT_EQ(readPointCloud(path("a.pts")).points, (std::vector<Vector3d>{{1, 2, 3}, {4, 5, 6}}));
  file("b.pts", "1 2 3\n4 5 6 10\n");
  EXPECT_EQ(readPointCloud(path("b.pts")).size(), 2u);
}

TEST_F(IoTest, ReadsOffVariants) {
  file("a.off",
       "OFF\n# a square and a triangle\n5 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n2 2 2\n4 0 1 2 3\n3 1 4 2\n");
  const TriangleMesh mesh = readMesh(path("a.off"));
  EXPECT_EQ(mesh.vertices.size(), 5u);
  EXPECT_EQ(mesh.triangles, (std::vector<Vector3i>{{0, 1, 2}, {0, 2, 3}, {1, 4, 2}}));

  file("n.off", "NOFF 2 0 0\n0 0 0 0 0 1\n1 0 0 0 1 0\n");
  const PointCloud cloud = readPointCloud(path("n.off"));
  EXPECT_EQ(cloud.normals, (std::vector<Vector3d>{{0, 0, 1}, {0, 1, 0}}));
}

// A mesh read as a surface (the tools' INPUT) is a sampling of it, not its corners alone: a cube's 8 vertices sample
// nothing of its faces (a CAD part's vertices lie on its faces' rims), so its faces get points, with their
// corners' attributes (blended; an integer label: the nearest corner's).
TEST_F(IoTest, MeshFacesAreSampledWhenTheirVerticesDoNotSampleThem) {
  std::ostringstream ply;
  ply << "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
         "property uchar red\nproperty int label\nelement face 2\nproperty list uchar int vertex_indices\n"
         "end_header\n0 0 0 0 1\n1 0 0 100 1\n1 1 0 200 2\n0 1 0 100 2\n3 0 1 2\n3 0 2 3\n";
  file("square.ply", ply.str());
  EXPECT_EQ(readPointCloud(path("square.ply")).size(), 4u);  // a cloud: the vertices
  const PointCloud square = readSurfacePoints(path("square.ply"));
  ASSERT_GT(square.size(), 50000u);
  EXPECT_TRUE(square.normals.empty());  // the file has none: the resampler estimates them
  ASSERT_EQ(square.attributes.size(), 2u);
  for (std::size_t i = 0; i < square.size(); ++i) {
    const Vector3d& p = square.points[i];
    ASSERT_TRUE(p.x() >= 0 && p.x() <= 1 && p.y() >= 0 && p.y() <= 1 && p.z() == 0) << p.transpose();
    const double red = square.attributes[0].values[i], label = square.attributes[1].values[i];
    ASSERT_NEAR(red, 100 * p.x() + 100 * p.y(), 1e-6);  // the corners' values blended (linear here)
    ASSERT_TRUE(label == 1 || label == 2) << label;
  }
  // A mesh as fine as its vertices, with more of them than the surface needs (a 400 × 400 grid, 160,801), is read
  // as its vertices.
  const int k = 400;
  std::ostringstream off;
  off << "OFF\n" << (k + 1) * (k + 1) << " " << 2 * k * k << " 0\n";
  for (int i = 0; i <= k; ++i)
    for (int j = 0; j <= k; ++j) off << i / double(k) << " " << j / double(k) << " 0\n";
  for (int i = 0; i < k; ++i)
    for (int j = 0; j < k; ++j) {
      const int a = i * (k + 1) + j;
      off << "3 " << a << " " << a + k + 1 << " " << a + k + 2 << "\n";
      off << "3 " << a << " " << a + k + 2 << " " << a + 1 << "\n";
    }
  file("grid.off", off.str());
  EXPECT_EQ(readSurfacePoints(path("grid.off")).size(), std::size_t((k + 1) * (k + 1)));
}

TEST_F(IoTest, ReadsObjFaceFormsAndNegativeIndices) {
  file("a.obj",
       "# cube corner\r\nmtllib x.mtl\r\no thing\r\nv 0 0 0\r\nv 1 0 0\r\nv 1 1 0 1.0\r\nvt 0 0\r\nvn 0 0 "
       "1\r\n"
       "f 1/1/1 2/1/1 3/1/1\r\nv 0 1 0\r\nf -4//1 -2//1 -1//1\r\nf 1/1 2/1 3/1 4/1\r\nusemtl red\r\ns "
       "off\r\n");
  const TriangleMesh mesh = readMesh(path("a.obj"));
  EXPECT_EQ(mesh.vertices.size(), 4u);
  EXPECT_EQ(mesh.triangles, (std::vector<Vector3i>{{0, 1, 2}, {0, 2, 3}, {0, 1, 2}, {0, 2, 3}}));
}

TEST_F(IoTest, ReadsAsciiAndBinaryStl) {
  file("a.stl",
       "solid square\n facet normal 0 0 1\n  outer loop\n   vertex 0 0 0\n   vertex 1 0 0\n   vertex 1 1 0\n"
       "  endloop\n endfacet\n facet normal 0 0 1\n  outer loop\n   vertex 0 0 0\n   vertex 1 1 0\n"
       "   vertex 0 1 0\n  endloop\n endfacet\nendsolid square\n");
  const TriangleMesh ascii = readMesh(path("a.stl"));
  EXPECT_EQ(ascii.vertices.size(), 4u);  // shared corners are merged
  EXPECT_EQ(ascii.triangles, (std::vector<Vector3i>{{0, 1, 2}, {0, 2, 3}}));

  std::string binary = "solid but binary" + std::string(64, ' ') + bytes<uint32_t>(2);
  const float corners[2][3][3] = {{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}}, {{0, 0, 0}, {1, 1, 0}, {0, 1, 0}}};
  for (const auto& triangle : corners) {
    binary += std::string(12, '\0');
    for (const auto& corner : triangle) binary += bytes(corner[0]) + bytes(corner[1]) + bytes(corner[2]);
    binary += std::string(2, '\0');
  }
  file("b.stl", binary);
  const TriangleMesh fromBinary = readMesh(path("b.stl"));
  EXPECT_EQ(fromBinary.vertices, ascii.vertices);
  EXPECT_EQ(fromBinary.triangles, ascii.triangles);

  file("short.stl", binary.substr(0, binary.size() - 30));
  expectMeshError("short.stl", "truncated");
  file("open.stl", "solid x\n facet normal 0 0 1\n  outer loop\n   vertex 0 0 0\n");
  expectMeshError("open.stl", "endsolid");
}

TEST_F(IoTest, ReadsPcdAndChecksItsCount) {
  const std::string header =
      "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\n"
      "COUNT 1 1 1\nWIDTH 3\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 3\nDATA ascii\n";
  file("a.pcd", header + "1 2 3\n4 5 6\n7 8 9\n");
  EXPECT_EQ(readPointCloud(path("a.pcd")).points, (std::vector<Vector3d>{{1, 2, 3}, {4, 5, 6}, {7, 8, 9}}));
  file("short.pcd", header + "1 2 3\n");
  expectCloudError("short.pcd", "truncated");
  file("bad.pcd", "VERSION 0.7\nFIELDS x y z\n");
  expectCloudError("bad.pcd", "corrupted header");
  file("value.pcd", header + "1 2 3\n4 x 6\n7 8 9\n");
  expectCloudError("value.pcd", "line 13: malformed number");
  // An organised cloud's pixels that measured nothing (NaN, PCL's convention) are no points.
  file("organised.pcd", header + "nan nan nan\n4 5 6\nnan nan nan\n");
  EXPECT_EQ(readPointCloud(path("organised.pcd")).points, std::vector<Vector3d>{Vector3d(4, 5, 6)});
}

TEST_F(IoTest, ReadsBinaryAndCompressedPcdWithNormals) {
  const std::string header =
      "VERSION 0.7\nFIELDS x y z rgb normal_x normal_y normal_z\nSIZE 4 4 4 4 4 4 4\nTYPE F F F U F F F\n"
      "COUNT 1 1 1 1 1 1 1\nWIDTH 2\nHEIGHT 1\nPOINTS 2\nDATA ";
  const float values[2][7] = {{1, 2, 3, 0, 0, 0, 1}, {-4, 5.5f, 6, 0, 1, 0, 0}};
  std::string records, columns;  // binary: one record per point; compressed: one column per field
  for (const auto& point : values)
    for (const float v : point) records += bytes(v);
  for (int f = 0; f < 7; ++f)
    for (const auto& point : values) columns += bytes(point[f]);
  const std::string lzf = lzfCompress(columns);
  ASSERT_LT(lzf.size(), columns.size());  // back references in use
  file("b.pcd", header + "binary\n" + records);
  file("c.pcd",
       header + "binary_compressed\n" + bytes<uint32_t>(lzf.size()) + bytes<uint32_t>(columns.size()) + lzf);
  for (const std::string name : {"b.pcd", "c.pcd"}) {
    SCOPED_TRACE(name);
    const PointCloud cloud = readPointCloud(path(name));
    EXPECT_EQ(cloud.points, (std::vector<Vector3d>{{1, 2, 3}, {-4, 5.5, 6}}));
    EXPECT_EQ(cloud.normals, (std::vector<Vector3d>{{0, 0, 1}, {1, 0, 0}}));
  }
  file("short.pcd", header + "binary\n" + records.substr(0, 40));
  expectCloudError("short.pcd", "truncated binary body: header declares 2 points, file holds 1");
  file("cshort.pcd", header + "binary_compressed\n" + bytes<uint32_t>(lzf.size()) +
                         bytes<uint32_t>(columns.size()) + lzf.substr(0, 20));
  expectCloudError("cshort.pcd", "truncated");
}

TEST_F(IoTest, NonFiniteCoordinatesAreReadNotRejected) {
  file("nan.xyz", "nan 0 0\n1 inf -inf\n");
  const PointCloud cloud = readPointCloud(path("nan.xyz"));
  ASSERT_EQ(cloud.size(), 2u);
  EXPECT_TRUE(std::isnan(cloud.points[0].x()));
  EXPECT_TRUE(std::isinf(cloud.points[1].y()));
}

// ------------------------------------------------------------------------------------------------ bad input

TEST_F(IoTest, MissingFileAndDirectory) {
  expectCloudError("absent.ply", "no such file");
  expectMeshError("absent.off", "no such file");
  fs::create_directory(path("folder.ply"));
  expectCloudError("folder.ply", "directory");
}

TEST_F(IoTest, UnreadableFile) {
  if (::geteuid() == 0) GTEST_SKIP() << "root reads files without read permission";
  file("locked.xyz", "1 2 3\n");
  fs::permissions(path("locked.xyz"), fs::perms::none);
  expectCloudError("locked.xyz", "cannot open");
}

TEST_F(IoTest, UnknownExtensionListsSupportedOnes) {
  file("cloud.las", "1 2 3\n");
  expectCloudError("cloud.las", ".ply .pcd .xyz .xyzn .pts .obj .off .stl");
  file("cloud.xyz", "1 2 3\n");
  expectMeshError("cloud.xyz", ".ply .obj .off .stl");
}

TEST_F(IoTest, EmptyAndPointlessFiles) {
  file("empty.xyz", "");
  expectCloudError("empty.xyz", "empty");
  file("comments.xyz", "# nothing here\n\n");
  expectCloudError("comments.xyz", "holds no points");
  file("header.ply",
       "ply\nformat binary_little_endian 1.0\nelement vertex 0\nproperty float x\n"
       "property float y\nproperty float z\nend_header\n");
  expectCloudError("header.ply", "holds no points");
  file("points.ply",
       "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
       "property float z\nend_header\n1 2 3\n");
  expectMeshError("points.ply", "no triangles");
}

TEST_F(IoTest, TruncatedBinaryPly) {
  // Debian's Open3D 0.16 warns and returns 1,000 points for this file.
  file("bunny.ply",
       "ply\nformat binary_little_endian 1.0\nelement vertex 1000\nproperty double x\n"
       "property double y\nproperty double z\nend_header\n" +
           std::string(100, '\1'));
  const std::string message = inputError([&] { readPointCloud(path("bunny.ply")); });
  EXPECT_TRUE(contains(message, path("bunny.ply") + ": truncated binary body"));
  EXPECT_TRUE(contains(message, "declares 1000 vertices, file holds 4"));
}

TEST_F(IoTest, BadPlyFiles) {
  const std::string vertex3 = "element vertex 2\nproperty float x\nproperty float y\nproperty float z\n";
  file("magic.ply", "plx\nformat ascii 1.0\n" + vertex3 + "end_header\n1 2 3\n4 5 6\n");
  expectCloudError("magic.ply", "corrupted header");
  file("format.ply", "ply\nformat binary_middle_endian 1.0\n" + vertex3 + "end_header\n");
  expectCloudError("format.ply", "corrupted header");
  file("type.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty floot x\nend_header\n1\n");
  expectCloudError("type.ply", "corrupted header");
  file("noend.ply", "ply\nformat ascii 1.0\n" + vertex3 + "1 2 3\n4 5 6\n");
  expectCloudError("noend.ply", "corrupted header");
  file("noxyz.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float u\nend_header\n1\n");
  expectCloudError("noxyz.ply", "corrupted header");
  file("short.ply", "ply\nformat ascii 1.0\n" + vertex3 + "end_header\n1 2 3\n");
  expectCloudError("short.ply", "declares 2 vertices, file holds 1");
  file("long.ply", "ply\nformat ascii 1.0\n" + vertex3 + "end_header\n1 2 3\n4 5 6\n7 8 9\n");
  expectCloudError("long.ply", "after the last element");
  file("value.ply", "ply\nformat ascii 1.0\n" + vertex3 + "end_header\n1 2 3\n4 five 6\n");
  expectCloudError("value.ply", "line 9: malformed number \"five\"");
  file("few.ply", "ply\nformat ascii 1.0\n" + vertex3 + "end_header\n1 2 3\n4 5\n");
  expectCloudError("few.ply", "line 9");
  file("face.ply",
       "ply\nformat ascii 1.0\n" + vertex3 +
           "element face 1\nproperty list uchar int vertex_indices\nend_header\n1 2 3\n4 5 6\n3 0 1 2\n");
  expectMeshError("face.ply", "out of range");
  expectCloudError("face.ply", "out of range");
  std::string body;
  for (int i = 0; i < 6; ++i) body += bytes(1.0f);
  file("extra.ply", "ply\nformat binary_little_endian 1.0\n" + vertex3 + "end_header\n" + body + "junk");
  expectCloudError("extra.ply", "after the last element");
}

TEST_F(IoTest, BadTextFiles) {
  file("a.xyz", "1 2 3\n1 2 abc\n");
  expectCloudError("a.xyz", "line 2: malformed number \"abc\"");
  file("b.xyz", "1 2 3\n1 2\n");
  expectCloudError("b.xyz", "line 2");
  file("c.xyz", "1 2 3\n1 2 3 0 0 1\n");
  expectCloudError("c.xyz", "line 2");
  file("a.xyzn", "1 2 3\n");
  expectCloudError("a.xyzn", "line 1");
  file("a.pts", "3\n1 2 3\n4 5 6\n");
  expectCloudError("a.pts", "declares 3 points, the file holds 2");
  file("b.pts", "1 2 3\n4 5\n");
  expectCloudError("b.pts", "line 2");
}

TEST_F(IoTest, BadOffAndObjFiles) {
  file("magic.off", "OFX\n1 0 0\n0 0 0\n");
  expectCloudError("magic.off", "corrupted header");
  file("counts.off", "OFF\nthree 0 0\n0 0 0\n");
  expectCloudError("counts.off", "corrupted header");
  file("short.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n");
  expectCloudError("short.off", "declares 3 vertices, the file holds 2");
  file("faces.off", "OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  expectMeshError("faces.off", "declares 2 faces, the file holds 1");
  file("range.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n");
  expectMeshError("range.off", "line 6: vertex index 3 out of range");
  file("vertex.off", "OFF\n2 0 0\n0 0 0\n1 0 x\n");
  expectCloudError("vertex.off", "line 4");
  file("zero.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n");
  expectMeshError("zero.obj", "line 4");
  file("range.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n");
  expectMeshError("range.obj", "out of range");
  file("negative.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n");
  expectMeshError("negative.obj", "out of range");
  file("vertex.obj", "v 0 0\n");
  expectCloudError("vertex.obj", "line 1");
  file("lines.obj", "v 0 0 0\nv 1 0 0\nl 1 2\n");
  expectMeshError("lines.obj", "no triangles");
}

// ------------------------------------------------------------------------------------------------ real data

TEST(IoRealData, CgalBunnyOff) {
  const std::string path = test::dataPath("meshes/bunny00.off");
  const TriangleMesh mesh = readMesh(path);
  EXPECT_EQ(mesh.vertices.size(), 37706u);
  EXPECT_EQ(mesh.triangles.size(), 75408u);
  EXPECT_EQ(readPointCloud(path).size(), 37706u);
  // Read as a surface: its vertices first, then points on its faces (at least about 100,000 over the surface).
  const PointCloud cloud = readSurfacePoints(path);
  ASSERT_GE(cloud.size(), 100000u);
  EXPECT_TRUE(std::equal(mesh.vertices.begin(), mesh.vertices.end(), cloud.points.begin()));
}

TEST(IoRealData, CgalKittenXyzHasNormals) {
  const PointCloud cloud = readPointCloud(test::dataPath("points_3/kitten.xyz"));
  EXPECT_GT(cloud.size(), 5000u);
  ASSERT_TRUE(cloud.hasNormals());
  EXPECT_NEAR(cloud.normals[0].norm(), 1.0, 1e-3);
}

TEST(IoRealData, CgalHippoBinaryPly) {
  const PointCloud cloud = readPointCloud(test::dataPath("points_3/hippo1.ply"));
  EXPECT_EQ(cloud.size(), 6104u);
  ASSERT_TRUE(cloud.hasNormals());
  for (const Vector3d& p : cloud.points) ASSERT_TRUE(p.allFinite());
  EXPECT_NEAR(cloud.normals[0].norm(), 1.0, 1e-3);
}

}  // namespace
}  // namespace iires
