// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Shared helpers for the test suite: data paths, temporary directories, running the tools.
#include <string>

#include "iires/types.hpp"

namespace iires::test {

/// Path of a file of CGAL's data archive in the dataset cache (e.g. "meshes/bunny00.off").
/// Fails the calling test (and throws) when the file is missing: run datasets/fetch.sh first.
std::string dataPath(const std::string& relative);

/// A fresh, empty temporary directory (removed at process exit is not guaranteed; under /tmp).
std::string tempDir();

/// Path of a built tool, e.g. tool("iires-resample").
std::string tool(const std::string& name);

/// Run a shell command, capture stdout+stderr into @p output, return the exit code.
int run(const std::string& command, std::string* output = nullptr);

/// Read a whole text file.
std::string readText(const std::string& path);

bool fileExists(const std::string& path);

}  // namespace iires::test
