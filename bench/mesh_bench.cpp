// The as-printed mesh (`--deposit-mesh`) alone, on a deposit made once.
//
//   mesh_bench [RUNS [OUT.stl]]   deposits $PRINTTWIN_BENCH_GCODE (default: the 10 mm cube
//                                 sample) at $PRINTTWIN_BENCH_VOXEL (0.05) mm, then builds the
//                                 mesh RUNS times (default 3) as `simulate --deposit-mesh`
//                                 does and writes it to OUT.stl (default: a temporary file)
//                                 each time; prints the process CPU time (user + sys, all
//                                 threads) of each build and each write, and the mesh's size.
// Under load, compare two binaries by their CPU time, run alternately (A B A B).
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <string>

#include "deposit/mesh_export.hpp"
#include "printtwin/deposit.hpp"
#include "printtwin/deviation.hpp"
#include "printtwin/planner.hpp"
#include "printtwin/simulate.hpp"

namespace {

using namespace printtwin;

/// The moves of the G-code, in order.
struct Moves final : MoveSink {
  std::vector<Move> all;
  void on_move(const Move& m) override { all.push_back(m); }
};

/// Process CPU time (all threads), seconds.
double cpu_s() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

}  // namespace

int main(int argc, char** argv) {
  const int runs = argc > 1 ? std::atoi(argv[1]) : 3;
  const std::filesystem::path out =
      argc > 2 ? std::filesystem::path(argv[2])
               : std::filesystem::temp_directory_path() / "printtwin_mesh_bench.stl";
  const char* gcode_env = std::getenv("PRINTTWIN_BENCH_GCODE");
  const char* voxel_env = std::getenv("PRINTTWIN_BENCH_VOXEL");
  const std::string gcode =
      gcode_env != nullptr && *gcode_env != '\0'
          ? std::string(gcode_env)
          : std::string(PRINTTWIN_SOURCE_DIR) + "/samples/gcode/prusa_cube10.gcode";
  auto profile = load_printer_profile("ender3");
  if (!profile) return 2;
  Moves c;
  std::ifstream in(gcode, std::ios::binary);
  auto sim = simulate_gcode(in, *profile, {}, &c);
  if (!sim) {
    std::fprintf(stderr, "%s\n", sim.error().describe().c_str());
    return 2;
  }
  DepositSettings ds;
  ds.voxel_mm = voxel_env != nullptr && *voxel_env != '\0' ? std::stod(voxel_env) : 0.05;
  auto dep = deposit_moves(c.all, *profile, ds);
  if (!dep) {
    std::fprintf(stderr, "%s\n", dep.error().describe().c_str());
    return 2;
  }
  const std::vector<SurfaceBead> beads = surface_beads(c.all, *profile);
  const DepositMeshOptions options;
  for (int r = 0; r < runs; ++r) {
    const double t0 = cpu_s();
    auto mesh = build_deposit_mesh(dep->grid, options, beads);
    const double t1 = cpu_s();
    if (!mesh) {
      std::fprintf(stderr, "%s\n", mesh.error().describe().c_str());
      return 3;
    }
    if (auto st = write_deposit_mesh(*mesh, out); !st) {
      std::fprintf(stderr, "%s\n", st.error().describe().c_str());
      return 3;
    }
    const double t2 = cpu_s();
    std::printf(
        "run %d: build %.3f s CPU (%.3f s wall), write %.3f s CPU; %zu triangles, "
        "volume %.1f mm3\n",
        r, t1 - t0, mesh->seconds, t2 - t1, mesh->mesh.triangles.size(), mesh->volume_mm3);
  }
  return 0;
}
