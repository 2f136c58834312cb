// SPDX-License-Identifier: GPL-3.0-or-later
#include "common.hpp"

#include <unistd.h>

#include <algorithm>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <new>
#include <sstream>
#include <stdexcept>

#include "iires/io.hpp"
#include "iires/types.hpp"

namespace iires::tools {
namespace {

namespace fs = std::filesystem;

[[noreturn]] void failWrite(const std::string& path, const std::string& problem) {
  throw InputError("cannot write " + path + ": " + problem);
}

/// True when @p a and @p b name the same file: the same inode if both exist, else the same canonical path.
bool sameFile(const fs::path& a, const fs::path& b) {
  std::error_code ec;
  if (fs::exists(a, ec) && fs::exists(b, ec)) {
    const bool same = fs::equivalent(a, b, ec);
    if (!ec) return same;
  }
  const fs::path ca = fs::weakly_canonical(fs::absolute(a, ec), ec);
  const fs::path cb = fs::weakly_canonical(fs::absolute(b, ec), ec);
  return !ec && ca == cb;
}

std::string humanBytes(double bytes) {
  const char* units[] = {"B", "KiB", "MiB", "GiB", "TiB", "PiB"};
  int u = 0;
  while (bytes >= 1024 && u < 5) bytes /= 1024, ++u;
  std::ostringstream os;
  os.precision(3);
  os << bytes << " " << units[u];
  return os.str();
}

}  // namespace

int guardedMain(const std::string& toolName, const std::function<int()>& body) {
  removeTemporariesOnSignal();
  try {
    return body();
  } catch (const InputError& e) {
    std::cerr << toolName << ": error: " << e.what() << "\n";
    return kBadInput;
  } catch (const std::invalid_argument& e) {
    std::cerr << toolName << ": error: " << e.what() << "\n";
    return kBadInput;
  } catch (const std::bad_alloc&) {
    std::cerr << toolName << ": error: out of memory\n";
    return kComputeFailure;
  } catch (const std::exception& e) {
    std::cerr << toolName << ": error: " << e.what() << "\n";
    return kComputeFailure;
  } catch (...) {
    std::cerr << toolName << ": error: unknown failure\n";
    return kComputeFailure;
  }
}

int parseArgs(CLI::App& app, int argc, char** argv) {
  try {
    app.parse(argc, argv);
    return kContinue;
  } catch (const CLI::Success& e) {  // --help, --version (CallForHelp etc. derive from Success)
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    const std::string name = app.get_name().empty() ? std::string(argc > 0 ? argv[0] : "iires") : app.get_name();
    std::string message = e.what();
    std::replace(message.begin(), message.end(), '\n', ' ');
    std::cerr << fs::path(name).filename().string() << ": error: " << message
              << " (run with --help for the options)\n";
    return kBadInput;
  }
}

void checkOutputPath(const std::string& output, const std::vector<std::string>& inputs) {
  if (output.empty()) return;
  const fs::path target(output);
  for (const std::string& input : inputs)
    if (!input.empty() && sameFile(target, fs::path(input)))
      failWrite(output, "refusing to overwrite the input " + input);
  const fs::path directory = target.has_parent_path() ? target.parent_path() : fs::path(".");
  std::error_code ec;
  if (!fs::exists(directory, ec)) failWrite(output, "directory " + directory.string() + " does not exist");
  if (!fs::is_directory(directory, ec)) failWrite(output, directory.string() + " is not a directory");
  if (::access(directory.c_str(), W_OK | X_OK) != 0)
    failWrite(output, "directory " + directory.string() + " is not writable");
  if (fs::is_directory(target, ec)) failWrite(output, "it is a directory");
}

void checkOutputPaths(const CLI::App& app, const std::vector<std::pair<std::string, std::string>>& outputs,
                      const std::vector<std::string>& inputs) {
  std::vector<std::pair<std::string, std::string>> given;
  for (const auto& [option, path] : outputs) {
    if (app.count(option) == 0) continue;
    if (path.empty()) failWrite("\"\"", "the file name is empty (" + option + ")");
    checkOutputPath(path, inputs);
    for (const auto& [earlier, earlierPath] : given)
      if (sameFile(fs::path(path), fs::path(earlierPath)))
        failWrite(path, earlier + " and " + option + " name the same file");
    given.emplace_back(option, path);
  }
}

std::size_t availableMemory() {
  std::ifstream meminfo("/proc/meminfo");
  std::string key;
  std::size_t kib = 0;
  std::string unit;
  while (meminfo >> key >> kib >> unit)
    if (key == "MemAvailable:") return kib * 1024;
  const long pages = ::sysconf(_SC_AVPHYS_PAGES), pageSize = ::sysconf(_SC_PAGESIZE);
  return pages > 0 && pageSize > 0 ? static_cast<std::size_t>(pages) * static_cast<std::size_t>(pageSize) : 0;
}

void checkCount(const std::string& flag, long long count, std::size_t bytesPerPoint) {
  if (count > kMaxCount)
    throw InputError(flag + " " + std::to_string(count) + " is absurdly large: at most " +
                     std::to_string(kMaxCount) + " points are supported");
  const double need = static_cast<double>(count) * static_cast<double>(bytesPerPoint);
  const std::size_t available = availableMemory();
  if (available > 0 && need > static_cast<double>(available))
    throw InputError(flag + " " + std::to_string(count) + " needs about " + humanBytes(need) +
                     " of memory, but only " + humanBytes(static_cast<double>(available)) + " is available");
}

std::string versionString() { return std::string("iires ") + IIRES_VERSION; }

const CLI::Validator& seedValidator() {
  static const CLI::Validator check(
      [](const std::string& text) -> std::string {
        const bool digits = !text.empty() && text.size() <= 20 &&
                            std::all_of(text.begin(), text.end(), [](char c) { return c >= '0' && c <= '9'; });
        if (digits && (text.size() < 20 || text <= "18446744073709551615")) return "";
        return "the seed must be a whole number from 0 to 18446744073709551615, got " + text;
      },
      "UINT64");
  return check;
}

void refuseFlags(const CLI::App& app, std::initializer_list<const char*> flags, const std::string& why) {
  for (const char* flag : flags)
    if (app.count(flag) > 0) throw InputError(std::string(flag) + " has no effect with " + why);
}

}  // namespace iires::tools
