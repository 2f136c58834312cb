// SPDX-License-Identifier: GPL-3.0-or-later
// iires-resample-mpi: iires-resample's tiled run with the tiles spread over the ranks of an MPI job
// (`mpirun -n R iires-resample-mpi IN OUT -n N --tiles auto|SIZE`). Every rank reads the input and spills its
// own tiles into its own scratch directory; rank 0 writes the output. Same output as iires-resample --tiles.
#include <CLI/CLI.hpp>
#include <exception>
#include <string>

#include "common.hpp"
#include "progress.hpp"
#include "tiling.hpp"
#include "iires/mpi/tiled_mpi.hpp"

int main(int argc, char** argv) {
  const iires::MpiSession mpi(argc, argv);
  iires::MpiTileExecutor executor;
  const std::string name = executor.rank() == 0 ? std::string("iires-resample-mpi")
                                                : "iires-resample-mpi (rank " + std::to_string(executor.rank()) + ")";
  return iires::tools::guardedMain(name, [&]() -> int {
    CLI::App app{"Resample a point cloud to exactly N points on its surface (isotropic), out of core, with the "
                 "tiles spread over the ranks of an MPI job."};
    iires::tools::ResampleOptions options;
    options.addRunFlags(app);
    options.addTilingFlags(app);
    app.set_version_flag("--version", iires::tools::versionString());
    // Every rank parses the same arguments: a usage error stops all of them alike, before any MPI call.
    if (const int code = iires::tools::parseArgs(app, argc, argv); code != iires::tools::kContinue) return code;
    // The checks below look at this rank's view of the file system: a failure on one rank stops every rank.
    std::exception_ptr failure;
    try {
      if (options.tiling.tiles == "off") throw iires::InputError("iires-resample-mpi always runs tiled (--tiles off)");
      if (options.tiling.tiles.empty()) options.tiling.tiles = "auto";
      if (executor.rank() == 0) options.checkOutputs(app);
      options.applyToParams(true);
      options.params.validate();
      options.tiling.defaultMemory();
    } catch (...) {
      failure = std::current_exception();
    }
    executor.agree(failure);
    const bool root = executor.rank() == 0;
    iires::tools::Progress progress(name, root && options.showProgress, !root || options.quiet);
    options.exec.progress = progress.callback();
    return iires::tools::runTiled(options, progress, executor);
  });
}
