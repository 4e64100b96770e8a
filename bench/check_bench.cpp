// `printtwin check` on a closed ~200k-triangle mesh: a bumpy torus generated in code.
//   check_bench                          # Google Benchmark: each stage and the whole check
//   check_bench --write-mesh=torus.stl   # writes the mesh (binary STL) for bench/check_vs_peers.sh
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>

#include "../tests/support/bumpy_sphere.hpp"
#include "printtwin/check.hpp"
#include "printtwin/machine.hpp"
#include "printtwin/mesh.hpp"

namespace {

using namespace printtwin;

/// Torus lying on the bed (major radius 40 mm, minor 12 mm with 1 mm bumps), `nu` x `nv`
/// quads -> 2 nu nv triangles, closed and outward oriented.
Mesh bumpy_torus(int nu, int nv) {
  constexpr double kPi = 3.14159265358979323846;
  Mesh m;
  m.vertices_mm.reserve(static_cast<std::size_t>(nu) * nv);
  for (int i = 0; i < nu; ++i) {
    const double u = 2 * kPi * i / nu;
    for (int j = 0; j < nv; ++j) {
      const double v = 2 * kPi * j / nv;
      const double r = 12.0 + 1.0 * std::sin(7 * u) * std::cos(5 * v);
      const double R = 40.0 + r * std::cos(v);
      m.vertices_mm.emplace_back(R * std::cos(u), R * std::sin(u), r * std::sin(v));
    }
  }
  auto id = [&](int i, int j) { return static_cast<std::uint32_t>((i % nu) * nv + (j % nv)); };
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      m.triangles.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      m.triangles.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  if (signed_volume_mm3(m) < 0)
    for (auto& t : m.triangles) std::swap(t[1], t[2]);
  return m;
}

const Mesh& bench_mesh() {
  static const Mesh mesh = bumpy_torus(500, 200);  // 200,000 triangles
  return mesh;
}

void BM_Health(benchmark::State& state) {
  for (auto _ : state) benchmark::DoNotOptimize(analyze_mesh_health(bench_mesh()));
  state.counters["triangles"] = static_cast<double>(bench_mesh().triangles.size());
}
BENCHMARK(BM_Health)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();

void BM_SelfIntersections(benchmark::State& state) {
  for (auto _ : state) benchmark::DoNotOptimize(find_self_intersections(bench_mesh()));
}
BENCHMARK(BM_SelfIntersections)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();

void BM_SelfIntersectionsWithHealth(benchmark::State& state) {
  const MeshHealth health = analyze_mesh_health(bench_mesh());
  for (auto _ : state) benchmark::DoNotOptimize(find_self_intersections(bench_mesh(), 5, &health));
}
BENCHMARK(BM_SelfIntersectionsWithHealth)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();

void BM_SelfIntersectionsStar(benchmark::State& state) {  // a blob: star-shaped, no pair
  static const Mesh sphere = test::bumpy_sphere(20, 251, 400, Vec3::Zero());  // 200k triangles
  const MeshHealth health = analyze_mesh_health(sphere);
  for (auto _ : state) benchmark::DoNotOptimize(find_self_intersections(sphere, 5, &health));
  state.counters["triangles"] = static_cast<double>(sphere.triangles.size());
}
BENCHMARK(BM_SelfIntersectionsStar)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();

void BM_Thickness(benchmark::State& state) {
  for (auto _ : state) benchmark::DoNotOptimize(measure_thickness(bench_mesh(), 0.4, 0.45));
}
BENCHMARK(BM_Thickness)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();

void BM_ThicknessWithinLimit(benchmark::State& state) {  // inward rays end at the limit
  for (auto _ : state)
    benchmark::DoNotOptimize(
        measure_thickness(bench_mesh(), 0.4, 0.45, nullptr, Vec3::Zero(), false));
}
BENCHMARK(BM_ThicknessWithinLimit)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();

void BM_Orientation(benchmark::State& state) {
  const CheckSettings settings;
  for (auto _ : state) benchmark::DoNotOptimize(advise_orientation(bench_mesh(), settings));
}
BENCHMARK(BM_Orientation)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();

void BM_Units(benchmark::State& state) {  // the unit guess (`--units auto`)
  for (auto _ : state) benchmark::DoNotOptimize(guess_mesh_units(bench_mesh()));
}
BENCHMARK(BM_Units)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();

void BM_Overhangs(benchmark::State& state) {
  const Mesh placed = place_on_bed(bench_mesh(), 117.5, 117.5);
  for (auto _ : state) benchmark::DoNotOptimize(find_overhangs(placed, CheckSettings{}));
}
BENCHMARK(BM_Overhangs)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();

/// The whole check, self-intersections and thickness included, from a loaded mesh.
void BM_CheckWhole(benchmark::State& state) {
  const PrinterProfile printer = ender3_marlin2();
  for (auto _ : state) {
    auto r = check_printability(bench_mesh(), printer);
    if (!r.ok() || r->health.self_intersections != 0 || !r->health.closed)
      state.SkipWithError("the benchmark mesh must be closed and free of self-intersections");
    benchmark::DoNotOptimize(r);
  }
}
BENCHMARK(BM_CheckWhole)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();

/// Loading the binary STL through assimp (+ validation and welding), then the whole check.
void BM_LoadAndCheck(benchmark::State& state) {
  const auto path = std::filesystem::temp_directory_path() / "printtwin_check_bench.stl";
  if (!save_stl(bench_mesh(), path).ok()) state.SkipWithError("cannot write the STL");
  const PrinterProfile printer = ender3_marlin2();
  for (auto _ : state) {
    auto m = load_mesh(path);
    if (!m.ok()) state.SkipWithError("load failed");
    benchmark::DoNotOptimize(check_printability(*m, printer));
  }
  std::filesystem::remove(path);
}
BENCHMARK(BM_LoadAndCheck)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();

void BM_Load(benchmark::State& state) {
  const auto path = std::filesystem::temp_directory_path() / "printtwin_check_bench_load.stl";
  if (!save_stl(bench_mesh(), path).ok()) state.SkipWithError("cannot write the STL");
  for (auto _ : state) benchmark::DoNotOptimize(load_mesh(path));
  std::filesystem::remove(path);
}
BENCHMARK(BM_Load)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();

/// Loading an ASCII STL: $PRINTTWIN_BENCH_MESH (bench/make_bench_data.sh's bench_model.stl,
/// as OpenSCAD writes it), else the benchmark mesh written as ASCII here (%.9g coordinates).
void BM_LoadAscii(benchmark::State& state) {
  const char* given = std::getenv("PRINTTWIN_BENCH_MESH");
  auto path = std::filesystem::temp_directory_path() / "printtwin_check_bench_ascii.stl";
  const bool own = given == nullptr || *given == '\0';
  if (own) {
    std::FILE* f = std::fopen(path.c_str(), "w");
    if (f == nullptr) {
      state.SkipWithError("cannot write the STL");
      return;
    }
    const Mesh& m = bench_mesh();
    std::fprintf(f, "solid bench\n");
    for (const auto& t : m.triangles) {
      std::fprintf(f, "facet normal 0 0 0\nouter loop\n");
      for (auto v : t)
        std::fprintf(f, "vertex %.9g %.9g %.9g\n", m.vertices_mm[v].x(), m.vertices_mm[v].y(),
                     m.vertices_mm[v].z());
      std::fprintf(f, "endloop\nendfacet\n");
    }
    std::fprintf(f, "endsolid bench\n");
    std::fclose(f);
  } else {
    path = given;
  }
  for (auto _ : state) {
    auto m = load_mesh(path);
    if (!m.ok()) state.SkipWithError("load failed");
    benchmark::DoNotOptimize(m);
  }
  if (own) std::filesystem::remove(path);
}
BENCHMARK(BM_LoadAscii)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();

}  // namespace

int main(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    if (std::strncmp(argv[i], "--write-mesh=", 13) == 0) {
      const auto status = save_stl(bench_mesh(), argv[i] + 13);
      if (!status.ok()) {
        std::fprintf(stderr, "check_bench: %s\n", status.error().describe().c_str());
        return 3;
      }
      std::printf("%s: %zu triangles\n", argv[i] + 13, bench_mesh().triangles.size());
      return 0;
    }
  }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 2;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
