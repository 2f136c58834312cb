// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/point_stream.hpp"

#include <gtest/gtest.h>

#include <fstream>

#include "iires/io.hpp"
#include "shapes.hpp"
#include "test_util.hpp"

namespace {

/// Every point of @p path, read in chunks of @p chunk.
iires::PointCloud readChunked(const std::string& path, std::size_t chunk) {
  iires::PointStream stream(path);
  iires::PointCloud all, part;
  while (stream.next(part, chunk)) {
    EXPECT_LE(part.size(), chunk);
    all.points.insert(all.points.end(), part.points.begin(), part.points.end());
    all.normals.insert(all.normals.end(), part.normals.begin(), part.normals.end());
  }
  return all;
}

TEST(PointStream, ChunksReadWhatTheWholeFileReaderReads) {
  const std::string dir = iires::test::tempDir();
  const iires::PointCloud cloud = iires::test::sphereCloud(1001, 1.0, 3);
  iires::PointCloud positions;
  positions.points = cloud.points;
  iires::writePointCloud(dir + "/a.ply", cloud);
  iires::writePointCloud(dir + "/b.ply", cloud, true);
  iires::writePointCloud(dir + "/c.xyz", positions);
  iires::writePointCloud(dir + "/d.xyzn", cloud);
  for (const char* name : {"a.ply", "b.ply", "c.xyz", "d.xyzn"}) {
    const std::string path = dir + "/" + name;
    const iires::PointCloud whole = iires::readPointCloud(path);
    for (std::size_t chunk : {1u, 7u, 1000u, 5000u}) {
      const iires::PointCloud read = readChunked(path, chunk);
      EXPECT_EQ(read.points, whole.points) << name << " in chunks of " << chunk;
      EXPECT_EQ(read.normals, whole.normals) << name;
    }
    iires::PointStream stream(path);
    EXPECT_NEAR(static_cast<double>(stream.estimatedCount()), 1001.0, 100.0) << name;
    iires::PointCloud part;
    while (stream.next(part, 100)) {
    }
    stream.rewind();
    ASSERT_TRUE(stream.next(part, 1));
    EXPECT_EQ(part.points[0], whole.points[0]) << "rewind starts again at the first point";
  }
}

TEST(PointStream, BigEndianAndExtraPropertiesAndTrailingFaces) {
  const std::string dir = iires::test::tempDir();
  {
    std::ofstream out(dir + "/be.ply", std::ios::binary);
    out << "ply\nformat binary_big_endian 1.0\nelement vertex 2\nproperty uchar red\nproperty float x\n"
           "property float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
    const unsigned char body[] = {7, 0x3f, 0x80, 0, 0, 0x40, 0, 0, 0, 0x40, 0x40, 0, 0,
                                  9, 0xbf, 0x80, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0,
                                  3, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 1};
    out.write(reinterpret_cast<const char*>(body), sizeof body);
  }
  const iires::PointCloud read = readChunked(dir + "/be.ply", 1);
  ASSERT_EQ(read.size(), 2u);
  EXPECT_EQ(read.points[0], Eigen::Vector3d(1, 2, 3));
  EXPECT_EQ(read.points[1], Eigen::Vector3d(-1, 0, 0));
  EXPECT_TRUE(read.normals.empty());
}

TEST(PointStream, BrokenFilesAreInputErrors) {
  const std::string dir = iires::test::tempDir();
  auto write = [&](const std::string& name, const std::string& text) {
    std::ofstream(dir + "/" + name, std::ios::binary) << text;
    return dir + "/" + name;
  };
  EXPECT_THROW(iires::PointStream(dir + "/missing.ply"), iires::InputError);
  EXPECT_THROW(iires::PointStream(write("a.pcd", "x")), iires::InputError);
  EXPECT_THROW(iires::PointStream(write("b.ply", "ply\nformat ascii 1.0\nelement vertex 1\n")), iires::InputError);
  const std::string truncated =
      write("c.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty double x\n"
                     "property double y\nproperty double z\nend_header\n" + std::string(30, '\0'));
  iires::PointCloud part;
  iires::PointStream stream(truncated);
  EXPECT_THROW(while (stream.next(part, 2)) {}, iires::InputError);
  iires::PointStream bad(write("d.xyz", "0 0 0\n1 1\n"));
  try {
    while (bad.next(part, 10)) {
    }
    FAIL() << "a short line is an error";
  } catch (const iires::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("line 2"), std::string::npos) << e.what();
  }
  iires::PointStream nan(write("e.xyz", "0 0 0\nnan 1 1\n"));
  EXPECT_THROW(while (nan.next(part, 10)) {}, iires::InputError);
}

}  // namespace
