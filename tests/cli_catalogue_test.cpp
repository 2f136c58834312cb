// SPDX-License-Identifier: GPL-3.0-or-later
// The bad-input catalogue (DESIGN §6, issue 9): every tool that reads a cloud, every entry. A rejected input
// must give exit code 2, a message naming the file and the problem, no output file (not even a temporary one)
// and an untouched input. The degenerate-but-valid entries (a planar cloud, a small object far from the origin)
// must succeed with a correct result.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "iires/io.hpp"
#include "shapes.hpp"
#include "test_util.hpp"

namespace iires::test {
namespace {

namespace fs = std::filesystem;

/// How one tool is called: `name INPUT ...` with its output, count flag and the catalogue entries it supports.
struct ToolSpec {
  const char* name;
  const char* outputExtension;  ///< of the main output
  const char* countFlag;        ///< the option that sets the point count
  long long goodCount;          ///< a small valid count
  long long minCount;           ///< smallest valid count
  bool badTarget = false;       ///< iires-register: the file under test is TARGET (SOURCE is a good cloud)
};

std::ostream& operator<<(std::ostream& os, const ToolSpec& spec) { return os << spec.name; }

const ToolSpec kResample{"iires-resample", ".ply", "-n", 200, 1};
const ToolSpec kReconstruct{"iires-reconstruct", ".ply", "-n", 200, 4};
// iires-register reads two clouds: every entry runs once with the bad file as SOURCE and once as TARGET.
const ToolSpec kRegister{"iires-register", ".ply", "-m", 60, 50};
const ToolSpec kRegisterTarget{"iires-register", ".ply", "-m", 60, 50, true};

bool isRegister(const ToolSpec& spec) { return std::string(spec.name) == "iires-register"; }

std::string quote(const std::string& s) { return "'" + s + "'"; }

std::string bytesOf(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

void writeBytes(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

std::vector<std::string> listing(const std::string& dir) {
  std::vector<std::string> names;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) names.push_back(entry.path().string());
  std::sort(names.begin(), names.end());
  return names;
}

/// A binary little-endian PLY header for @p vertices float vertices (x y z).
std::string plyHeader(std::size_t vertices) {
  return "ply\nformat binary_little_endian 1.0\nelement vertex " + std::to_string(vertices) +
         "\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
}

std::string floatBytes(const std::vector<Eigen::Vector3d>& points) {
  std::string body;
  for (const auto& p : points)
    for (int k = 0; k < 3; ++k) {
      const float f = static_cast<float>(p[k]);
      char b[4];
      std::memcpy(b, &f, 4);
      body.append(b, 4);
    }
  return body;
}

/// Points of a small sphere for inputs that must be valid (the register target, the tests' base cloud).
PointCloud smallSphere(std::size_t n = 400, const Eigen::Vector3d& centre = Eigen::Vector3d::Zero()) {
  PointCloud cloud;
  for (const auto& p : fibonacciSphere(n)) cloud.points.push_back(centre + p);
  return cloud;
}

class Catalogue : public ::testing::TestWithParam<ToolSpec> {
 protected:
  void SetUp() override {
    spec_ = GetParam();
    if (!fileExists(tool(spec_.name))) GTEST_SKIP() << spec_.name << " is not built";
    dir_ = tempDir();
    other_ = dir_ + "/other.ply";
    writePointCloud(other_, smallSphere(300));
  }

  /// The tool's command line for @p input, @p output and @p count (plus @p extra options).
  std::string command(const std::string& input, const std::string& output, long long count,
                      const std::string& extra = "") const {
    std::string cmd = quote(tool(spec_.name)) + " ";
    if (!isRegister(spec_))
      cmd += quote(input) + " " + quote(output);
    else  // with all three of its outputs, none of which may appear on a rejection
      cmd += (spec_.badTarget ? quote(other_) + " " + quote(input) : quote(input) + " " + quote(other_)) + " -o " +
             quote(output) + " --transform " + quote(dir_ + "/T.txt") + " --report " + quote(dir_ + "/report.json");
    return cmd + " " + spec_.countFlag + " " + std::to_string(count) + " --threads 2 " + extra;
  }

  std::string output() const { return dir_ + "/out" + spec_.outputExtension; }

  /// Runs the tool on @p input and checks the rejection contract; @p problems are substrings the message must
  /// hold (besides @p named, the path it must name, by default @p input).
  void expectRejected(const std::string& input, const std::vector<std::string>& problems,
                      std::string out = "", long long count = kGoodCount, const std::string& prefix = "",
                      std::string named = "") {
    if (out.empty()) out = output();
    if (count == kGoodCount) count = spec_.goodCount;
    if (named.empty()) named = input;
    const bool inputIsFile = fs::is_regular_file(input), outputExisted = fs::exists(out);
    const std::string before = inputIsFile ? bytesOf(input) : "";
    const auto files = listing(dir_);
    std::string message;
    const int code = run(prefix + command(input, out, count), &message);
    EXPECT_EQ(code, 2) << message;
    EXPECT_NE(message.find(named), std::string::npos) << "the message does not name " << named << ":\n"
                                                      << message;
    for (const std::string& p : problems)
      EXPECT_NE(message.find(p), std::string::npos) << "expected \"" << p << "\" in:\n" << message;
    EXPECT_EQ(message.find("terminate called"), std::string::npos) << message;
    EXPECT_NE(message.find(std::string(spec_.name) + ": error: "), std::string::npos) << message;
    if (!outputExisted) {
      EXPECT_FALSE(fs::exists(out)) << "output written: " << out;
    }
    EXPECT_EQ(listing(dir_), files) << "files appeared or disappeared in " << dir_;
    if (inputIsFile) {
      EXPECT_EQ(bytesOf(input), before) << "the input changed";
    }
  }

  static constexpr long long kGoodCount = std::numeric_limits<long long>::min();  ///< "the tool's good count"
  ToolSpec spec_;
  std::string dir_;
  std::string other_;  ///< iires-register: the other cloud (TARGET, or SOURCE when the file under test is TARGET)
};

TEST_P(Catalogue, MissingFile) { expectRejected(dir_ + "/nothing.ply", {"no such file"}); }

TEST_P(Catalogue, DirectoryInsteadOfFile) {
  const std::string input = dir_ + "/cloud.ply";
  fs::create_directory(input);
  expectRejected(input, {"is a directory"});
}

TEST_P(Catalogue, UnreadableFile) {
  const std::string input = dir_ + "/locked.ply";
  writePointCloud(input, smallSphere());
  ASSERT_EQ(::chmod(input.c_str(), 0), 0);
  std::string prefix;
  if (::geteuid() == 0) {
    // root reads anything: run the tool as nobody (who may write the directory, so only the read fails).
    if (run("runuser -u nobody -- true") != 0) GTEST_SKIP() << "running as root and runuser is unavailable";
    fs::permissions(dir_, fs::perms::all);
    fs::permissions(other_, fs::perms::all);
    if (run("runuser -u nobody -- test -x " + quote(tool(spec_.name))) != 0)
      GTEST_SKIP() << "running as root and nobody cannot execute " << tool(spec_.name);
    prefix = "runuser -u nobody -- ";
  }
  expectRejected(input, {"cannot open for reading", "Permission denied"}, "", kGoodCount, prefix);
  ::chmod(input.c_str(), 0644);
}

TEST_P(Catalogue, UnknownExtension) {
  const std::string input = dir_ + "/cloud.abc";
  writeBytes(input, "0 0 0\n1 0 0\n0 1 0\n0 0 1\n");
  expectRejected(input, {"unknown point cloud extension", ".abc"});
}

TEST_P(Catalogue, EmptyFile) {
  const std::string input = dir_ + "/empty.xyz";
  writeBytes(input, "");
  expectRejected(input, {"empty"});
}

TEST_P(Catalogue, HeaderOnlyPly) {
  // A header that declares no vertices, and one that declares 100 with no body after it.
  const std::string none = dir_ + "/none.ply", declared = dir_ + "/declared.ply";
  writeBytes(none, plyHeader(0));
  writeBytes(declared, plyHeader(100));
  expectRejected(none, {"no points"});
  expectRejected(declared, {"truncated"});
}

TEST_P(Catalogue, TruncatedBinaryPly) {
  // The header says 1,000 vertices; 100 bytes follow (Open3D 0.16 would return 1,000 points, DESIGN §2).
  const std::string input = dir_ + "/truncated.ply";
  writeBytes(input, plyHeader(1000) + floatBytes(smallSphere(1000).points).substr(0, 100));
  expectRejected(input, {"truncated"});
}

TEST_P(Catalogue, CorruptedHeader) {
  const std::string magic = dir_ + "/magic.ply", format = dir_ + "/format.ply", count = dir_ + "/count.ply";
  const std::string body = floatBytes(smallSphere(50).points);
  writeBytes(magic, "plz\n" + plyHeader(50).substr(4) + body);
  std::string badFormat = plyHeader(50);
  badFormat.replace(badFormat.find("binary_little_endian"), 20, "binary_middle_endian");
  writeBytes(format, badFormat + body);
  std::string badCount = plyHeader(50);
  badCount.replace(badCount.find("vertex 50"), 9, "vertex 5x");
  writeBytes(count, badCount + body);
  for (const std::string& input : {magic, format, count}) expectRejected(input, {"header"});
}

TEST_P(Catalogue, NanCoordinates) {
  const std::string input = dir_ + "/nan.xyz";
  std::string text;
  const auto points = smallSphere(200).points;
  for (std::size_t i = 0; i < points.size(); ++i)
    text += (i == 17 ? std::string("nan") : std::to_string(points[i].x())) + " " + std::to_string(points[i].y()) +
            " " + std::to_string(points[i].z()) + "\n";
  writeBytes(input, text);
  expectRejected(input, {"NaN"});
}

// Points filling a solid ball (a volume scan, a simulation's particles) sample no surface: a mesh or a resampled
// "surface" of them was junk (CGAL's blobby.xyz meshed to genus 28 in 8 parts).
TEST_P(Catalogue, PointsFillingAVolume) {
  const std::string input = dir_ + "/solid.xyz";
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::string text;
  for (int kept = 0; kept < 3000;) {
    const double x = u(rng), y = u(rng), z = u(rng);
    if (x * x + y * y + z * z > 1) continue;
    text += std::to_string(x) + " " + std::to_string(y) + " " + std::to_string(z) + "\n";
    ++kept;
  }
  writeBytes(input, text);
  expectRejected(input, {"fill a volume"});
}

TEST_P(Catalogue, InfCoordinates) {
  const std::string input = dir_ + "/inf.ply";
  auto points = smallSphere(200).points;
  points[42].z() = std::numeric_limits<double>::infinity();
  writeBytes(input, plyHeader(points.size()) + floatBytes(points));
  expectRejected(input, {"Inf"});
}

TEST_P(Catalogue, SinglePoint) {
  const std::string input = dir_ + "/single.xyz";
  writeBytes(input, "0.5 0.25 1\n");
  expectRejected(input, {"point"});
}

TEST_P(Catalogue, AllPointsIdentical) {
  const std::string input = dir_ + "/same.xyz";
  std::string text;
  for (int i = 0; i < 500; ++i) text += "1.5 -2 3\n";
  writeBytes(input, text);
  expectRejected(input, {"distinct"});
}

TEST_P(Catalogue, CollinearPoints) {
  const std::string input = dir_ + "/line.xyz";
  std::string text;
  for (int i = 0; i < 500; ++i) text += std::to_string(0.01 * i) + " " + std::to_string(0.02 * i) + " 1\n";
  writeBytes(input, text);
  expectRejected(input, {"collinear"});
}

// CLI11 wrapped --seed -1 around to 2^64 − 1 and saturated 2^64: both ran with exit 0.
TEST_P(Catalogue, SeedOutsideItsRange) {
  const std::string input = dir_ + "/cloud.ply";
  writePointCloud(input, smallSphere());
  for (const char* seed : {"-1", "18446744073709551616", "1e3"}) {
    std::string message;
    EXPECT_EQ(run(command(input, output(), spec_.goodCount, std::string("--seed ") + seed), &message), 2) << seed;
    EXPECT_NE(message.find("--seed"), std::string::npos) << message;
    EXPECT_FALSE(fs::exists(output()));
  }
}

TEST_P(Catalogue, CountNotPositive) {
  const std::string input = dir_ + "/cloud.ply";
  writePointCloud(input, smallSphere());
  for (const long long count : {0LL, -5LL, spec_.minCount - 1})
    expectRejected(input, {spec_.countFlag, "at least"}, "", count, "", spec_.countFlag);
}

TEST_P(Catalogue, CountAbsurdlyLarge) {
  const std::string input = dir_ + "/cloud.ply";
  writePointCloud(input, smallSphere());
  expectRejected(input, {"absurdly large"}, "", 1000000000000LL, "", spec_.countFlag);
  // Within the hard limit but beyond any machine's memory at these bytes per point.
  expectRejected(input, {"memory"}, "", 99000000LL, "", spec_.countFlag);
}

TEST_P(Catalogue, OutputIsInput) {
  const std::string input = dir_ + "/cloud" + spec_.outputExtension;
  writePointCloud(input, smallSphere());
  expectRejected(input, {"refusing to overwrite the input"}, input);
  // The same file spelled differently, and through a symbolic link.
  expectRejected(input, {"refusing to overwrite the input"}, dir_ + "/./../" + fs::path(dir_).filename().string() + "/cloud" + spec_.outputExtension,
                 kGoodCount, "", input);
  fs::create_symlink(input, dir_ + "/link" + spec_.outputExtension);
  expectRejected(input, {"refusing to overwrite the input"}, dir_ + "/link" + spec_.outputExtension);
}

TEST_P(Catalogue, OutputDirectoryMissing) {
  const std::string input = dir_ + "/cloud.ply";
  writePointCloud(input, smallSphere());
  const std::string out = dir_ + "/no/such/dir/out" + spec_.outputExtension;
  expectRejected(input, {"director"}, out, kGoodCount, "", dir_ + "/no/such/dir");
}

// --- degenerate but valid inputs: must succeed with a correct result -------------------------------------------
// iires-register's output is the SOURCE mapped into TARGET's coordinates: there the other cloud is a second
// sampling of the same surface, and the aligned output must lie on that surface.

/// Points of the tool's output: the cloud, or the vertices of the mesh.
std::vector<Eigen::Vector3d> outputPoints(const ToolSpec& spec, const std::string& path) {
  if (std::string(spec.name) == "iires-reconstruct") return readMesh(path).vertices;
  return readPointCloud(path).points;
}

TEST_P(Catalogue, PlanarCloudSucceeds) {
  // A flat square is a valid (open) surface: users expect it resampled/meshed/registered, not rejected.
  const std::string input = dir_ + "/square.ply";
  writePointCloud(input, planeCloud(1500, 2.0));
  if (isRegister(spec_)) writePointCloud(other_, planeCloud(1200, 2.0, 1.0, 7));
  // Boundary samples may sit slightly beyond the outermost input points (the MLS surface extends a little past
  // them): allow half the output spacing. Registration of a square to a square is right up to the square's
  // symmetries and as accurate as its working samples (-m of them) resolve: allow one of their spacings (a square
  // sampled by 60 is matched to within a few degrees and per cent of scale, which moves its corners by about that).
  const double spacing = std::sqrt(4.0 / static_cast<double>(spec_.goodCount));
  const double margin = isRegister(spec_) ? spacing : 0.5 * spacing;
  const std::size_t expected = !isRegister(spec_) ? static_cast<std::size_t>(spec_.goodCount)
                               : spec_.badTarget  ? 1200u
                                                  : 1500u;
  const std::string before = bytesOf(input);
  std::string message;
  ASSERT_EQ(run(command(input, output(), spec_.goodCount), &message), 0) << message;
  const auto points = outputPoints(spec_, output());
  EXPECT_EQ(points.size(), expected);
  const double flat = isRegister(spec_) ? 1e-6 : 1e-9;  // a similarity transform rounds
  for (const auto& p : points) {
    EXPECT_NEAR(p.z(), 0.0, flat);
    EXPECT_GE(p.x(), -margin);
    EXPECT_LE(p.x(), 2.0 + margin);
    EXPECT_GE(p.y(), -margin);
    EXPECT_LE(p.y(), 2.0 + margin);
  }
  EXPECT_EQ(bytesOf(input), before);
}

TEST_P(Catalogue, HugeCoordinateOffsetSucceeds) {
  // A unit sphere 1e7 away from the origin: the output must lie on it as closely as for the same sphere at the
  // origin (no loss of precision from the offset). Measured: 4.3e-5 both ways without denoising; with the
  // default MLS denoising 1.05e-3 both ways (the denoiser's shrinkage on a clean 2,000-point sphere, not the
  // offset).
  const Eigen::Vector3d centre(1e7, 1e7, 1e7);
  const bool resampler = std::string(spec_.name) == "iires-resample";
  auto worstDistance = [&](const Eigen::Vector3d& c, const std::string& extra) {
    const std::string input = dir_ + "/sphere.ply", out = dir_ + "/sphere_out" + spec_.outputExtension;
    writePointCloud(input, smallSphere(2000, c));
    if (isRegister(spec_)) writePointCloud(other_, smallSphere(300, c));
    const std::size_t expected = !isRegister(spec_) ? static_cast<std::size_t>(spec_.goodCount)
                                 : spec_.badTarget  ? 300u
                                                    : 2000u;
    std::string message;
    EXPECT_EQ(run(command(input, out, isRegister(spec_) ? 200 : spec_.goodCount, extra), &message), 0) << message;
    const auto points = outputPoints(spec_, out);
    EXPECT_EQ(points.size(), expected);
    double worst = points.empty() ? 1e300 : 0.0;
    for (const auto& p : points) worst = std::max(worst, std::abs((p - c).norm() - 1.0));
    return worst;
  };
  const double far = worstDistance(centre, ""), near = worstDistance(Eigen::Vector3d::Zero(), "");
  if (isRegister(spec_)) {
    // The aligned sphere's error is the registration's own (scale and centre from 200 samples a cloud), measured
    // 0.004-0.021 at the origin and 0.009-0.011 at 1e7 (-m 60: 0.044 and 0.059): it varies from run to run
    // more than any rounding at 1e7 could matter, so no ratio test. Lost precision (e.g. floats at 1e7) would
    // show as errors of the order of the radius.
    EXPECT_LT(far, 0.04) << "at the origin " << near;
    EXPECT_LT(near, 0.04);
    return;
  }
  EXPECT_LT(far, 2e-3);
  EXPECT_LE(far, 1.1 * near + 1e-6) << "the offset costs precision; at the origin " << near;
  if (resampler) {
    const double exact = worstDistance(centre, "--no-denoise");
    EXPECT_LT(exact, 1e-3) << "without denoising the output must lie on the sphere";
  }
}

INSTANTIATE_TEST_SUITE_P(Tools, Catalogue, ::testing::Values(kResample, kReconstruct, kRegister, kRegisterTarget),
                         [](const ::testing::TestParamInfo<ToolSpec>& info) {
                           std::string name = info.param.name;
                           name.erase(std::remove(name.begin(), name.end(), '-'), name.end());
                           return info.param.badTarget ? name + "Target" : name;
                         });

// --- the shared plumbing: --version, usage errors, progress ---------------------------------------------------

class Plumbing : public ::testing::TestWithParam<const char*> {};

TEST_P(Plumbing, VersionPrintsAndExitsZero) {
  if (!fileExists(tool(GetParam()))) GTEST_SKIP() << GetParam() << " is not built";
  std::string out;
  EXPECT_EQ(run(quote(tool(GetParam())) + " --version", &out), 0) << out;
  EXPECT_EQ(out.rfind("iires ", 0), 0u) << out;
}

TEST_P(Plumbing, UsageErrorIsExitTwoWithAClearMessage) {
  if (!fileExists(tool(GetParam()))) GTEST_SKIP() << GetParam() << " is not built";
  std::string out;
  const std::string args = std::string(GetParam()) == "iires-sample-mesh" ? " in.off out.ply -n 5" : " in.ply out.ply";
  EXPECT_EQ(run(quote(tool(GetParam())) + args + " --no-such-option", &out), 2) << out;
  EXPECT_NE(out.find("--no-such-option"), std::string::npos) << out;
  EXPECT_EQ(run(quote(tool(GetParam())), &out), 2) << out;  // required positionals missing
  EXPECT_NE(out.find("required"), std::string::npos) << out;
}

TEST_P(Plumbing, HelpExitsZero) {
  if (!fileExists(tool(GetParam()))) GTEST_SKIP() << GetParam() << " is not built";
  std::string out;
  EXPECT_EQ(run(quote(tool(GetParam())) + " --help", &out), 0) << out;
  EXPECT_NE(out.find("--version"), std::string::npos) << out;
}

INSTANTIATE_TEST_SUITE_P(Tools, Plumbing,
                         ::testing::Values("iires-resample", "iires-reconstruct", "iires-sample-mesh",
                                           "iires-register"),
                         [](const ::testing::TestParamInfo<const char*>& info) {
                           std::string name = info.param;
                           name.erase(std::remove(name.begin(), name.end(), '-'), name.end());
                           return name;
                         });

// iires-reconstruct --quality-only MESH reads a mesh besides the reference cloud: the file entries of the
// catalogue for it, and NaN/Inf in either input.
TEST(ReconstructQualityOnly, BadMeshOrReferenceIsExitTwoAndWritesNothing) {
  if (!fileExists(tool("iires-reconstruct"))) GTEST_SKIP() << "iires-reconstruct is not built";
  const std::string dir = tempDir(), reference = dir + "/reference.ply", report = dir + "/report.json";
  writePointCloud(reference, smallSphere(400));
  const std::string tetra = "4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";
  const std::string good = dir + "/good.off";
  writeBytes(good, "OFF\n" + tetra);
  std::string message;
  auto check = [&](const std::string& cloud, const std::string& mesh, const std::string& named,
                   const std::vector<std::string>& problems) {
    const auto files = listing(dir);
    const int code = run(quote(tool("iires-reconstruct")) + " " + quote(cloud) + " --quality-only " + quote(mesh) +
                             " --report " + quote(report) + " --threads 2",
                         &message);
    EXPECT_EQ(code, 2) << message;
    EXPECT_NE(message.find("iires-reconstruct: error: "), std::string::npos) << message;
    EXPECT_NE(message.find(named), std::string::npos) << "the message does not name " << named << ":\n" << message;
    for (const std::string& p : problems)
      EXPECT_NE(message.find(p), std::string::npos) << "expected \"" << p << "\" in:\n" << message;
    EXPECT_EQ(listing(dir), files) << "files appeared or disappeared in " << dir;
  };
  const std::string header = "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\n"
                             "property float y\nproperty float z\nelement face 4\n"
                             "property list uchar int vertex_indices\nend_header\n";
  struct Case {
    std::string name, bytes;
    std::vector<std::string> problems;
  };
  const std::vector<Case> cases = {
      {"unknown.abc", "OFF\n" + tetra, {"unknown mesh extension", ".abc"}},
      {"empty.off", "", {"empty"}},
      {"header_only.ply",
       "ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\n"
       "element face 0\nproperty list uchar int vertex_indices\nend_header\n",
       {"no points"}},
      {"truncated.ply", header + floatBytes({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}) + "\x03", {"truncated"}},
      {"corrupted.off", "OFX\n" + tetra, {"header"}},
      {"nan.off", "OFF\n4 4 0\n0 0 0\n1 nan 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n", {"NaN"}},
      {"inf.off", "OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 inf\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n", {"Inf"}},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    writeBytes(dir + "/" + c.name, c.bytes);
    check(reference, dir + "/" + c.name, dir + "/" + c.name, c.problems);
  }
  check(reference, dir + "/nothing.off", dir + "/nothing.off", {"no such file"});
  fs::create_directory(dir + "/folder.off");
  check(reference, dir + "/folder.off", dir + "/folder.off", {"is a directory"});
  // A reference cloud with NaN coordinates is named as well.
  writeBytes(dir + "/nan.xyz", "0 0 0\n1 0 0\nnan 1 0\n0 0 1\n0.5 0.5 0.5\n");
  check(dir + "/nan.xyz", good, dir + "/nan.xyz", {"NaN"});
  // The good pair passes: the rejections above are about the files, not the command line.
  ASSERT_EQ(run(quote(tool("iires-reconstruct")) + " " + quote(reference) + " --quality-only " + quote(good) +
                    " --report " + quote(report) + " --threads 2 -q",
                &message),
            0)
      << message;
  EXPECT_TRUE(fileExists(report));
}

TEST(Progress, ForcedProgressNamesStagesAndQuietSilencesIt) {
  const std::string dir = tempDir(), input = dir + "/sphere.ply";
  writePointCloud(input, smallSphere(1000));
  std::string out;
  // stderr is a pipe here: no progress unless asked.
  ASSERT_EQ(run(quote(tool("iires-resample")) + " " + input + " " + dir + "/a.ply -n 100 -q", &out), 0) << out;
  EXPECT_EQ(out, "");
  ASSERT_EQ(run("(" + quote(tool("iires-resample")) + " " + input + " " + dir + "/b.ply -n 100 --progress 2>&1 >/dev/null)",
                &out),
            0)
      << out;
  for (const char* stage : {"iires-resample: read", "normals", "initialise", "resample", "100%"})
    EXPECT_NE(out.find(stage), std::string::npos) << "no \"" << stage << "\" in:\n" << out;
  ASSERT_EQ(run(quote(tool("iires-resample")) + " " + input + " " + dir + "/c.ply -n 100 --progress -q", &out), 0);
  EXPECT_EQ(out, "");
  // Progress does not change the result.
  EXPECT_EQ(bytesOf(dir + "/a.ply"), bytesOf(dir + "/b.ply"));
}

TEST(SampleMesh, GuardsItsOutputAndCount) {
  const std::string dir = tempDir(), mesh = dir + "/tri.off";
  writeBytes(mesh, "OFF\n4 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 3\n");
  const std::string before = bytesOf(mesh);
  std::string out;
  EXPECT_EQ(run(quote(tool("iires-sample-mesh")) + " " + mesh + " " + dir + "/missing/out.ply -n 10", &out), 2);
  EXPECT_NE(out.find("does not exist"), std::string::npos) << out;
  EXPECT_EQ(run(quote(tool("iires-sample-mesh")) + " " + mesh + " " + dir + "/out.ply -n 1000000000000", &out), 2);
  EXPECT_NE(out.find("absurdly large"), std::string::npos) << out;
  EXPECT_EQ(run(quote(tool("iires-sample-mesh")) + " " + mesh + " " + dir + "/out.ply -n 0", &out), 2);
  EXPECT_FALSE(fileExists(dir + "/out.ply"));
  EXPECT_EQ(bytesOf(mesh), before);
  EXPECT_EQ(run(quote(tool("iires-sample-mesh")) + " " + mesh + " " + dir + "/out.ply -n 50", &out), 0) << out;
  EXPECT_EQ(readPointCloud(dir + "/out.ply").size(), 50u);
}

}  // namespace
}  // namespace iires::test
