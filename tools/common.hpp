#pragma once
// Shared plumbing of the iires command-line tools: error → exit-code mapping and version string.
#include <functional>
#include <string>

namespace iires::tools {

/// Exit codes of every tool (DESIGN §6).
enum ExitCode : int { kOk = 0, kComputeFailure = 1, kBadInput = 2 };

/// Run a tool's body. iires::InputError, std::invalid_argument and CLI11 usage errors print
/// "<tool>: error: <message>" and return 2; any other exception prints the same and returns 1.
int guardedMain(const std::string& toolName, const std::function<int()>& body);

/// "iires <version>" for --version.
std::string versionString();

}  // namespace iires::tools
