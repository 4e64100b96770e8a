// OctoMap export benchmark: the deposit of a real slicer's G-code is built once (outside the
// timing), then written as .bt (argument 0) or .ot coloured by layer (argument 1) each
// iteration. process_cpu_ms counts every thread's CPU time (user + sys) of the export, the
// figure to compare on a loaded machine; file_MB is the size written. The export runs on
// all cores; PRINTTWIN_PLAIN=octomap_threads runs it on one (the same bytes).
//
//   PRINTTWIN_DEPOSIT_GCODE=build/benchdata/bench_model.gcode build/bench/octomap_bench
#include <benchmark/benchmark.h>
#include <sys/resource.h>

#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>

#include "deposit/voxel_blocks.hpp"
#include "printtwin/deposit.hpp"
#include "printtwin/simulate.hpp"

namespace printtwin {
namespace {

/// CPU time (user + sys) of the whole process so far, in ms: every thread's.
double process_cpu_ms() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return 1e3 * static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         1e-3 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

/// The deposit of $PRINTTWIN_DEPOSIT_GCODE at 0.05 mm (the default settings), built on first
/// use; an error message when it cannot be.
const VoxelGrid* deposit_grid(std::string& error) {
  static std::optional<DepositResult> deposit;
  static std::string failure;
  if (!deposit && failure.empty()) {
    const char* path = std::getenv("PRINTTWIN_DEPOSIT_GCODE");
    if (path == nullptr) {
      failure = "set PRINTTWIN_DEPOSIT_GCODE to a G-code file";
    } else {
      const auto profile = ender3_marlin2();
      auto moves = interpret_gcode_file(path, profile, SimulateOptions{});
      DepositSettings s;
      s.max_memory_bytes = std::size_t{8} << 30;
      auto r = moves ? deposit_moves(*moves, profile, s) : Result<DepositResult>(moves.error());
      if (r)
        deposit = std::move(r).value();
      else
        failure = r.error().describe();
    }
  }
  error = failure;
  return deposit ? &deposit->grid : nullptr;
}

void BM_OctomapExport(benchmark::State& state) {
  std::string error;
  const VoxelGrid* grid = deposit_grid(error);
  if (grid == nullptr) {
    state.SkipWithError(error.c_str());
    return;
  }
  const auto dir = std::filesystem::temp_directory_path() / "printtwin_octomap_bench";
  std::filesystem::create_directories(dir);
  const auto file = dir / (state.range(0) == 0 ? "part.bt" : "part.ot");
  double cpu_ms = 0;
  for (auto _ : state) {
    const double cpu0 = process_cpu_ms();
    const Status st = write_octomap(*grid, file, VoxelColoring::layer);
    cpu_ms += process_cpu_ms() - cpu0;
    if (!st) {
      state.SkipWithError(st.error().describe().c_str());
      return;
    }
  }
  state.counters["process_cpu_ms"] = cpu_ms / static_cast<double>(state.iterations());
  state.counters["file_MB"] = static_cast<double>(std::filesystem::file_size(file)) / 1e6;
  state.counters["voxels"] = static_cast<double>(grid->count());
  state.counters["blocks"] = static_cast<double>(detail::VoxelBlocks::block_count(*grid));
  state.counters["directory"] =
      static_cast<double>(detail::VoxelBlocks::block_dims(*grid).cast<double>().prod());
  std::filesystem::remove(file);
}
BENCHMARK(BM_OctomapExport)
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(3)
    ->Repetitions(1);

}  // namespace
}  // namespace printtwin

BENCHMARK_MAIN();
