#include "common.hpp"

#include <CLI/CLI.hpp>
#include <exception>
#include <iostream>
#include <new>
#include <stdexcept>

#include "iires/types.hpp"

namespace iires::tools {

int guardedMain(const std::string& toolName, const std::function<int()>& body) {
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
  }
}

std::string versionString() { return std::string("iires ") + IIRES_VERSION; }

}  // namespace iires::tools
