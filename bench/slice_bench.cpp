// Slicing speed: a 20 mm cube, a cylinder and a ~200k-triangle sphere built in code, sliced
// with the default (PrusaSlicer Ender-3) settings, G-code text included, time estimate off.
// Side by side with PrusaSlicer: bench/slice_vs_prusa.sh.
#include <benchmark/benchmark.h>

#include <cmath>
#include <numbers>

#include "printtwin/machine.hpp"
#include "printtwin/mesh.hpp"
#include "printtwin/slice.hpp"

namespace {

using printtwin::Mesh;
using printtwin::Vec3;

// Closed cylinder with `n` sides.
Mesh cylinder(double r, double h, int n) {
  Mesh m;
  m.vertices_mm.push_back(Vec3(0, 0, 0));
  m.vertices_mm.push_back(Vec3(0, 0, h));
  for (int i = 0; i < n; ++i) {
    const double a = 2 * std::numbers::pi * i / n;
    m.vertices_mm.push_back(Vec3(r * std::cos(a), r * std::sin(a), 0));
    m.vertices_mm.push_back(Vec3(r * std::cos(a), r * std::sin(a), h));
  }
  for (std::uint32_t i = 0; i < static_cast<std::uint32_t>(n); ++i) {
    const std::uint32_t j = (i + 1) % static_cast<std::uint32_t>(n);
    const std::uint32_t b0 = 2 + 2 * i, t0 = b0 + 1, b1 = 2 + 2 * j, t1 = b1 + 1;
    m.triangles.push_back({0, b1, b0});
    m.triangles.push_back({1, t0, t1});
    m.triangles.push_back({b0, b1, t1});
    m.triangles.push_back({b0, t1, t0});
  }
  return m;
}

// UV sphere with `rings` x `sectors` quads (2 triangles each): 316 x 316 ~ 200k triangles.
Mesh sphere(double r, int rings, int sectors) {
  Mesh m;
  m.vertices_mm.push_back(Vec3(0, 0, -r));
  for (int i = 1; i < rings; ++i) {
    const double phi = std::numbers::pi * i / rings - std::numbers::pi / 2;
    for (int j = 0; j < sectors; ++j) {
      const double th = 2 * std::numbers::pi * j / sectors;
      m.vertices_mm.push_back(Vec3(r * std::cos(phi) * std::cos(th),
                                   r * std::cos(phi) * std::sin(th), r * std::sin(phi)));
    }
  }
  m.vertices_mm.push_back(Vec3(0, 0, r));
  const auto S = static_cast<std::uint32_t>(sectors);
  auto v = [&](int ring, int j) {
    return 1 + static_cast<std::uint32_t>(ring - 1) * S + static_cast<std::uint32_t>(j % sectors);
  };
  const auto top = static_cast<std::uint32_t>(m.vertices_mm.size() - 1);
  for (int j = 0; j < sectors; ++j) m.triangles.push_back({0, v(1, j + 1), v(1, j)});
  for (int i = 1; i + 1 < rings; ++i)
    for (int j = 0; j < sectors; ++j) {
      m.triangles.push_back({v(i, j), v(i, j + 1), v(i + 1, j + 1)});
      m.triangles.push_back({v(i, j), v(i + 1, j + 1), v(i + 1, j)});
    }
  for (int j = 0; j < sectors; ++j)
    m.triangles.push_back({top, v(rings - 1, j), v(rings - 1, j + 1)});
  return m;
}

void run(benchmark::State& state, const Mesh& mesh) {
  const auto printer = printtwin::ender3_marlin2();
  printtwin::SliceSettings s;
  s.estimate_time = false;
  std::size_t bytes = 0;
  for (auto _ : state) {
    auto out = printtwin::slice_mesh(mesh, printer, s);
    if (!out) {
      state.SkipWithError(out.error().message.c_str());
      return;
    }
    bytes = out->gcode.size();
    benchmark::DoNotOptimize(out->gcode.data());
  }
  state.counters["triangles"] = static_cast<double>(mesh.triangles.size());
  state.counters["gcode_MB"] = static_cast<double>(bytes) / 1e6;
}

void BM_SliceCube20(benchmark::State& state) {
  static const Mesh m = printtwin::make_box_mesh(Vec3(0, 0, 0), Vec3(20, 20, 20));
  run(state, m);
}
void BM_SliceCylinder(benchmark::State& state) {
  static const Mesh m = cylinder(15, 30, 256);
  run(state, m);
}
void BM_SliceSphere200k(benchmark::State& state) {
  static const Mesh m = sphere(30, 316, 316);
  run(state, m);
}

BENCHMARK(BM_SliceCube20)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_SliceCylinder)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_SliceSphere200k)->Unit(benchmark::kMillisecond)->Iterations(3);

}  // namespace

BENCHMARK_MAIN();
