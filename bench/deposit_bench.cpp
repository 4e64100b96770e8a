// Deposit benchmarks: raw voxel write rate of the blocked grid, the bead model on synthetic
// toolpaths, and simulate + deposit of a real slicer's G-code.
//
//   build/bench/deposit_bench                                  # grid and synthetic cases
//   PRINTTWIN_DEPOSIT_GCODE=model.gcode build/bench/deposit_bench   # + the G-code cases
// bench/deposit_bench.sh generates the G-code (openscad + PrusaSlicer) and runs everything.
#include <benchmark/benchmark.h>
#include <sys/resource.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <numbers>
#include <string>
#include <vector>

#include "deposit/voxel_blocks.hpp"
#include "printtwin/deposit.hpp"
#include "printtwin/simulate.hpp"

namespace printtwin {
namespace {

/// Checksum of every occupied voxel and its tag (FNV-1a over keys and tag fields, in the
/// grid's fixed order), 48 bits so that a double counter holds it exactly: two builds that
/// deposit the same voxels with the same tags print the same number.
double grid_checksum(const VoxelGrid& g) {
  std::uint64_t h = 1469598103934665603ull;
  auto mix = [&h](std::uint64_t v) {
    h ^= v;
    h *= 1099511628211ull;
  };
  g.for_each([&](const VoxelKey& k, const VoxelTag& t) {
    mix(static_cast<std::uint32_t>(k.x) |
        static_cast<std::uint64_t>(static_cast<std::uint32_t>(k.y)) << 32);
    mix(static_cast<std::uint32_t>(k.z) | static_cast<std::uint64_t>(t.line) << 32);
    mix(static_cast<std::uint64_t>(static_cast<std::uint32_t>(t.layer)) << 8 |
        static_cast<std::uint64_t>(t.feature));
  });
  return static_cast<double>(h & ((std::uint64_t{1} << 48) - 1));
}

/// CPU time (user + sys) of the whole process so far, in ms: every thread's.
double process_cpu_ms() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return 1e3 * static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         1e-3 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

double peak_rss_mb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_maxrss) / 1024.0;  // ru_maxrss is in KiB on Linux
}

/// Raw writes: runs of 64 voxels (a bead-long row) filling a fresh 512x512x128 grid solid
/// (includes allocating its blocks).
void BM_VoxelGridFillRows(benchmark::State& state) {
  const int n = 512, nz = 128;
  std::size_t written = 0;
  for (auto _ : state) {
    VoxelGrid g(0.05, Vec3::Zero(), Eigen::Vector3i(n, n, nz));
    const auto tag = detail::VoxelBlocks::add_tag(g, VoxelTag{1, 0, Feature::perimeter});
    for (int z = 0; z < nz; ++z)
      for (int y = 0; y < n; ++y)
        for (int x = 0; x + 64 <= n; x += 64)
          written += detail::VoxelBlocks::fill_row(g, y, z, x, x + 64, tag);
    benchmark::DoNotOptimize(g.count());
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(written));
  state.counters["voxels_per_s"] =
      benchmark::Counter(static_cast<double>(written), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_VoxelGridFillRows)->Unit(benchmark::kMillisecond);

/// Raw writes through the deposit's path: whole 8 x 8 tiles of a block's z-slice (the sample
/// tests' output, VoxelGrid::write_tile), every other tile half set (a checkerboard), so half
/// the writes are partial.
void BM_VoxelGridWriteTiles(benchmark::State& state) {
  const int n = 512, nz = 128;
  std::size_t written = 0;
  for (auto _ : state) {
    VoxelGrid g(0.05, Vec3::Zero(), Eigen::Vector3i(n, n, nz));
    const auto tag = detail::VoxelBlocks::add_tag(g, VoxelTag{1, 0, Feature::perimeter});
    for (int z = 0; z < nz; ++z)
      for (int by = 0; by < n / 8; ++by)
        for (int bx = 0; bx < n / 8; ++bx) {
          const std::uint64_t mask =
              (bx + by + z) % 2 == 0 ? ~std::uint64_t{0} : 0xAA55AA55AA55AA55ull;
          written += detail::VoxelBlocks::write_tile(g, bx, by, z, mask, tag);
        }
    benchmark::DoNotOptimize(g.count());
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(written));
  state.counters["voxels_per_s"] =
      benchmark::Counter(static_cast<double>(written), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_VoxelGridWriteTiles)->Unit(benchmark::kMillisecond);

/// Raw writes one voxel at a time (set_index), in row order.
void BM_VoxelGridSetIndex(benchmark::State& state) {
  const int n = 256, nz = 128;
  std::size_t written = 0;
  for (auto _ : state) {
    VoxelGrid g(0.05, Vec3::Zero(), Eigen::Vector3i(n, n, nz));
    const auto tag = detail::VoxelBlocks::add_tag(g, VoxelTag{1, 0, Feature::perimeter});
    for (int z = 0; z < nz; ++z)
      for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x)
          written += detail::VoxelBlocks::set_index(g, VoxelKey{x, y, z}, tag) ? 1 : 0;
    benchmark::DoNotOptimize(g.count());
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(written));
  state.counters["voxels_per_s"] =
      benchmark::Counter(static_cast<double>(written), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_VoxelGridSetIndex)->Unit(benchmark::kMillisecond);

/// Bead model on a synthetic part: 40 layers of a 30 mm cylinder (2 perimeters of 180
/// segments) with 45-degree zig-zag infill, like a slicer's output.
std::vector<Move> synthetic_part(const PrinterProfile& p) {
  std::vector<Move> moves;
  Vec3 pos(0, 0, 0);
  long line = 0;
  const double h = 0.2, w = 0.45;
  const double area = (w - h) * h + std::numbers::pi * h * h / 4;
  auto push = [&](const Vec3& to, bool extrude, int layer, Feature f) {
    Move m;
    m.start_mm = pos;
    m.end_mm = to;
    m.kind = extrude ? MoveKind::extrude : MoveKind::travel;
    m.e_mm = extrude ? area * (to - pos).head<2>().norm() / p.filament_area_mm2() : 0;
    m.line = ++line;
    m.layer = layer;
    m.feature = f;
    moves.push_back(m);
    pos = to;
  };
  const Vec3 c(110, 110, 0);
  for (int layer = 0; layer < 40; ++layer) {
    const double z = h * (layer + 1);
    for (int ring = 0; ring < 2; ++ring) {
      const double r = 15.0 - w / 2 - ring * (w - h * (1 - std::numbers::pi / 4));
      const Feature f = ring == 0 ? Feature::outer_perimeter : Feature::perimeter;
      push(c + Vec3(r, 0, z), false, layer, f);
      for (int i = 1; i <= 180; ++i) {
        const double t = 2 * std::numbers::pi * i / 180;
        push(c + Vec3(r * std::cos(t), r * std::sin(t), z), true, layer, f);
      }
    }
    // Zig-zag infill at 20 % (lines 2.25 mm apart) inside r = 14.
    const double spacing = w / 0.2;
    bool first = true;
    for (double u = -14 + spacing / 2; u < 14; u += spacing) {
      const double half = std::sqrt(14.0 * 14.0 - u * u);
      const Vec3 a = c + Vec3(u, -half, z), b = c + Vec3(u, half, z);
      const bool flip = static_cast<int>(std::floor((u + 14) / spacing)) % 2 == 1;
      push(flip ? b : a, !first, layer, Feature::sparse_infill);
      push(flip ? a : b, true, layer, Feature::sparse_infill);
      first = false;
    }
  }
  return moves;
}

void BM_DepositSyntheticPart(benchmark::State& state) {
  const auto profile = ender3_marlin2();
  const auto moves = synthetic_part(profile);
  DepositSettings s;
  s.voxel_mm = 0.05;
  std::size_t voxels = 0;
  double ratio = 0, checksum = 0;
  for (auto _ : state) {
    auto r = deposit_moves(moves, profile, s);
    if (!r) {
      state.SkipWithError(r.error().message.c_str());
      return;
    }
    voxels = r->voxels;
    ratio = (r->volume_mm3 + r->overlap_mm3) / r->extruded_mm3;
    state.PauseTiming();
    checksum = grid_checksum(r->grid);
    state.ResumeTiming();
  }
  state.counters["checksum"] = checksum;
  state.SetItemsProcessed(static_cast<std::int64_t>(voxels * state.iterations()));
  state.counters["voxels"] = static_cast<double>(voxels);
  state.counters["deposited_plus_overlap_over_extruded"] = ratio;
}
BENCHMARK(BM_DepositSyntheticPart)->Unit(benchmark::kMillisecond);

// --- Real G-code (PRINTTWIN_DEPOSIT_GCODE) -------------------------------------------------

class Collect final : public MoveSink {
 public:
  std::vector<Move> moves;
  void on_move(const Move& m) override { moves.push_back(m); }
};

const char* gcode_path() { return std::getenv("PRINTTWIN_DEPOSIT_GCODE"); }

/// simulate (parse, interpret, plan) + deposit at 0.05 mm: the end-to-end figure.
void BM_SimulateAndDeposit(benchmark::State& state) {
  const char* path = gcode_path();
  if (path == nullptr) {
    state.SkipWithError("set PRINTTWIN_DEPOSIT_GCODE to a G-code file");
    return;
  }
  const auto profile = ender3_marlin2();
  DepositSettings s;
  s.voxel_mm = static_cast<double>(state.range(0)) / 1000.0;
  s.max_memory_bytes = std::size_t{8} << 30;
  DepositResult last;
  long lines = 0;
  for (auto _ : state) {
    Collect sink;
    auto sim = simulate_gcode_file(path, profile, SimulateOptions{}, &sink);
    if (!sim) {
      state.SkipWithError(sim.error().describe().c_str());
      return;
    }
    lines = sim->lines;
    auto r = deposit_moves(sink.moves, profile, s);
    if (!r) {
      state.SkipWithError(r.error().describe().c_str());
      return;
    }
    last = std::move(r).value();
  }
  state.counters["lines"] = static_cast<double>(lines);
  state.counters["voxels"] = static_cast<double>(last.voxels);
  state.counters["extruded_mm3"] = last.extruded_mm3;
  state.counters["volume_mm3"] = last.volume_mm3;
  state.counters["overlap_mm3"] = last.overlap_mm3;
  state.counters["grid_MB"] = static_cast<double>(last.memory_bytes) / (1024.0 * 1024.0);
  state.counters["peak_rss_MB"] = peak_rss_mb();
  state.counters["findings"] = static_cast<double>(last.findings.size());
}
BENCHMARK(BM_SimulateAndDeposit)
    ->Arg(50)
    ->Arg(100)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1)
    ->Repetitions(3);

/// The deposit alone (Moves interpreted once, outside the timing). Argument: conserve
/// volume (1, the default) or lose the overlap (0), to measure what the squeeze costs.
void BM_DepositOnly(benchmark::State& state) {
  const char* path = gcode_path();
  if (path == nullptr) {
    state.SkipWithError("set PRINTTWIN_DEPOSIT_GCODE to a G-code file");
    return;
  }
  const auto profile = ender3_marlin2();
  auto moves = interpret_gcode_file(path, profile, SimulateOptions{});
  if (!moves) {
    state.SkipWithError(moves.error().describe().c_str());
    return;
  }
  DepositSettings s;
  s.max_memory_bytes = std::size_t{8} << 30;
  s.conserve_volume = state.range(0) != 0;
  std::size_t voxels = 0;
  double checksum = 0, overlap = 0, cpu_ms = 0;
  for (auto _ : state) {
    const double cpu0 = process_cpu_ms();
    auto r = deposit_moves(*moves, profile, s);
    cpu_ms += process_cpu_ms() - cpu0;
    if (!r) {
      state.SkipWithError(r.error().describe().c_str());
      return;
    }
    voxels = r->voxels;
    overlap = r->overlap_mm3;
    state.PauseTiming();
    checksum = grid_checksum(r->grid);
    state.ResumeTiming();
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(voxels * state.iterations()));
  state.counters["voxels"] = static_cast<double>(voxels);
  state.counters["overlap_mm3"] = overlap;
  state.counters["checksum"] = checksum;
  // Every thread's CPU time (cpu_time is the benchmark thread's alone, without the writer's).
  state.counters["process_cpu_ms"] = cpu_ms / static_cast<double>(state.iterations());
}
BENCHMARK(BM_DepositOnly)
    ->Arg(1)
    ->Arg(0)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1)
    ->Repetitions(3);

/// Where the overlap of real G-code comes from: the deposit of each feature group alone
/// (overlap within the group: neighbouring beads of one kind) and of everything (the rest is
/// overlap between groups: infill reaching into perimeters, as the slicer intends).
void BM_OverlapByFeature(benchmark::State& state) {
  const char* path = gcode_path();
  if (path == nullptr) {
    state.SkipWithError("set PRINTTWIN_DEPOSIT_GCODE to a G-code file");
    return;
  }
  const auto profile = ender3_marlin2();
  auto moves = interpret_gcode_file(path, profile, SimulateOptions{});
  if (!moves) {
    state.SkipWithError(moves.error().describe().c_str());
    return;
  }
  enum Group { kPerimeters, kSparse, kSolid, kOther, kGroups };
  auto group_of = [](Feature f) {
    switch (f) {
      case Feature::outer_perimeter:
      case Feature::perimeter:
      case Feature::overhang_perimeter:
        return kPerimeters;
      case Feature::sparse_infill:
        return kSparse;
      case Feature::solid_infill:
      case Feature::top_solid_infill:
      case Feature::bridge_infill:
      case Feature::gap_fill:
        return kSolid;
      default:
        return kOther;
    }
  };
  const char* names[kGroups] = {"perimeters", "sparse", "solid", "other"};
  DepositSettings s;
  s.max_memory_bytes = std::size_t{8} << 30;
  for (auto _ : state) {
    double within = 0;
    for (int g = 0; g < kGroups; ++g) {
      std::vector<Move> part = *moves;
      for (auto& m : part)
        if (m.kind == MoveKind::extrude && group_of(m.feature) != g)
          m.kind = MoveKind::travel, m.e_mm = 0;
      auto r = deposit_moves(part, profile, s);
      if (!r) {
        state.SkipWithError(r.error().describe().c_str());
        return;
      }
      within += r->overlap_mm3;
      state.counters[std::string("extruded_mm3_") + names[g]] = r->extruded_mm3;
      state.counters[std::string("overlap_mm3_within_") + names[g]] = r->overlap_mm3;
    }
    auto all = deposit_moves(*moves, profile, s);
    if (!all) {
      state.SkipWithError(all.error().describe().c_str());
      return;
    }
    state.counters["overlap_mm3_total"] = all->overlap_mm3;
    state.counters["overlap_mm3_between_groups"] = all->overlap_mm3 - within;
    state.counters["extruded_mm3"] = all->extruded_mm3;
  }
}
BENCHMARK(BM_OverlapByFeature)->Unit(benchmark::kMillisecond)->Iterations(1);

/// The simulation alone, for the split of the end-to-end figure.
void BM_SimulateOnly(benchmark::State& state) {
  const char* path = gcode_path();
  if (path == nullptr) {
    state.SkipWithError("set PRINTTWIN_DEPOSIT_GCODE to a G-code file");
    return;
  }
  const auto profile = ender3_marlin2();
  for (auto _ : state) {
    auto sim = simulate_gcode_file(path, profile, SimulateOptions{});
    if (!sim) {
      state.SkipWithError(sim.error().describe().c_str());
      return;
    }
    benchmark::DoNotOptimize(sim->print_time_s);
  }
}
BENCHMARK(BM_SimulateOnly)->Unit(benchmark::kMillisecond)->Iterations(1)->Repetitions(3);

}  // namespace
}  // namespace printtwin

BENCHMARK_MAIN();
