// SPDX-License-Identifier: GPL-3.0-or-later
// PointStreamWriter: a binary PLY written in chunks.
#include <fstream>

#include "atomic_file.hpp"
#include "iires/point_stream.hpp"
#include "io_format.hpp"

namespace iires {

struct PointStreamWriter::Impl {
  detail::TemporaryFile file;
  std::ofstream out;
  detail::io::Writer writer{out};
  std::size_t count, written = 0;
  bool normals;
  Impl(const std::string& path, std::size_t n, bool withNormals)
      : file(path), out(file.path(), std::ios::binary), count(n), normals(withNormals) {}
};

PointStreamWriter::PointStreamWriter(const std::string& path, std::size_t count, bool normals) {
  if (extensionOf(path) != ".ply") detail::io::failWrite(path, "written in chunks as .ply only");
  impl_ = std::make_unique<Impl>(path, count, normals);
  if (!impl_->out) detail::io::failWrite(path, "cannot create the file");
  impl_->writer.text("ply\nformat binary_little_endian 1.0\ncomment written by iires\nelement vertex " +
                     std::to_string(count) + "\nproperty double x\nproperty double y\nproperty double z\n");
  if (normals) impl_->writer.text("property double nx\nproperty double ny\nproperty double nz\n");
  impl_->writer.text("end_header\n");
}

PointStreamWriter::~PointStreamWriter() = default;

void PointStreamWriter::write(const PointCloud& chunk) {
  Impl& s = *impl_;
  if (s.written + chunk.size() > s.count)
    detail::io::failWrite(s.file.target(), "more points than the declared " + std::to_string(s.count));
  if (s.normals && !chunk.hasNormals()) detail::io::failWrite(s.file.target(), "a chunk without normals");
  for (std::size_t i = 0; i < chunk.size(); ++i) {
    for (int k = 0; k < 3; ++k) s.writer.binary(chunk.points[i][k]);
    for (int k = 0; s.normals && k < 3; ++k) s.writer.binary(chunk.normals[i][k]);
  }
  s.written += chunk.size();
  s.writer.flush();
  if (!s.out) detail::io::failWrite(s.file.target(), "write failed (is the disk full?)");
}

void PointStreamWriter::finish() {
  Impl& s = *impl_;
  if (s.written != s.count)
    detail::io::failWrite(s.file.target(), std::to_string(s.written) + " points written, " +
                                               std::to_string(s.count) + " declared");
  s.writer.flush();
  s.out.close();
  if (!s.out) detail::io::failWrite(s.file.target(), "write failed (is the disk full?)");
  if (const std::string problem = s.file.commit(); !problem.empty()) detail::io::failWrite(s.file.target(), problem);
}

}  // namespace iires
