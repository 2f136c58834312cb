// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Shared plumbing of the iires command-line tools: error → exit-code mapping, argument parsing, the
// input/output guards every tool runs before any work, and the version string.
#include <CLI/CLI.hpp>
#include <cstddef>
#include <functional>
#include <initializer_list>
#include <string>
#include <vector>

namespace iires::tools {

/// Exit codes of every tool (DESIGN §6).
enum ExitCode : int { kOk = 0, kComputeFailure = 1, kBadInput = 2 };

/// Sentinel returned by parseArgs() when the tool should go on.
constexpr int kContinue = -1;

/// Largest point count any tool accepts for -n (the memory guard's hard limit).
constexpr long long kMaxCount = 100'000'000;

/// @brief Run a tool's body. iires::InputError and std::invalid_argument print "<tool>: error: <message>"
/// and return 2; std::bad_alloc prints "out of memory" and returns 1; any other exception prints the same
/// "<tool>: error: ..." line and returns 1. Never lets an exception escape.
int guardedMain(const std::string& toolName, const std::function<int()>& body);

/// @brief Parse the command line with CLI11.
/// @return kContinue when the tool should run; 0 after --help or --version (printed on stdout); 2 after a usage
/// error, printed on stderr as one line "<tool>: error: <CLI11 message> (run with --help for the options)".
int parseArgs(CLI::App& app, int argc, char** argv);

/// @brief Guards on an output path, checked before any computation.
/// @throws InputError "cannot write OUTPUT: refusing to overwrite the input INPUT" when @p output names the
/// same file as one of @p inputs (after resolving symlinks, `.`/`..` and hard links); "cannot write OUTPUT:
/// directory D does not exist" (or "is not a directory", "is not writable") for a bad directory; "cannot
/// write OUTPUT: it is a directory" when OUTPUT itself is a directory. An empty @p output is not checked.
void checkOutputPath(const std::string& output, const std::vector<std::string>& inputs);

/// @brief Guards on every output of a run, checked before any computation: each one given on the command line
/// (as @p app counts it) passes checkOutputPath() and is not empty, and no two of them name the same file.
/// @param outputs pairs (option name as CLI11 knows it, e.g. "OUTPUT" or "--report"; its path)
/// @throws InputError "cannot write P: the file name is empty (OPTION)" or "cannot write P: OPTION1 and OPTION2
/// name the same file", and as checkOutputPath().
void checkOutputPaths(const CLI::App& app, const std::vector<std::pair<std::string, std::string>>& outputs,
                      const std::vector<std::string>& inputs);

/// @brief Bytes of memory available to this process: MemAvailable from /proc/meminfo, else
/// sysconf(_SC_AVPHYS_PAGES) · page size; 0 when unknown.
std::size_t availableMemory();

/// @brief The memory guard for a requested point count.
/// @param flag how the option is spelled in messages, e.g. "-n"
/// @param count the requested count (already checked to be >= the tool's minimum)
/// @param bytesPerPoint a generous estimate of the memory one output point costs in the tool's pipeline
/// @throws InputError when @p count exceeds kMaxCount, or count · bytesPerPoint exceeds availableMemory().
void checkCount(const std::string& flag, long long count, std::size_t bytesPerPoint);

/// @brief --seed's check: a whole number in [0, 2^64 − 1], written in decimal digits (CLI11 wraps "-1" around
/// and saturates 2^64 otherwise).
const CLI::Validator& seedValidator();

/// @brief A flag that would change nothing is refused rather than ignored.
/// @throws InputError "FLAG has no effect with WHY" for the first of @p flags given on the command line.
void refuseFlags(const CLI::App& app, std::initializer_list<const char*> flags, const std::string& why);

/// "iires <version>" for --version.
std::string versionString();

}  // namespace iires::tools
