// Report generation on a ~200k-triangle part (synthetic sphere of radius 12 mm with a known
// deviation field, 0.72 M mesh samples at 0.05 mm and 2.2 M deposit samples), one thread:
//   build-*/bench/report_bench --benchmark_filter=. --benchmark_min_time=1
// BM_ReportFiles is the whole report (renders, PNGs, cross-sections, HTML, JUnit, Markdown);
// the counter html_MB is the size of report.html.
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include "../tests/report/synthetic_report.hpp"
#include "printtwin/report.hpp"
#include "report/heatmap.hpp"

namespace {

using namespace printtwin;

const VerifyReport& big_report() {
  // 2 * 316 * 315 = 199k triangles; 1810 mm2 of surface at 0.05 mm spacing.
  static const VerifyReport r = [] {
    test::SyntheticSpec spec;
    spec.segments = 316;
    spec.rings = 316;
    spec.radius_mm = 12.0;
    spec.spacing_mm = 0.05;
    spec.deposit_per_mesh_sample = 3;
    return test::make_synthetic_report(spec);
  }();
  return r;
}

void BM_ReportFiles(benchmark::State& state) {
  tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
  const auto& r = big_report();
  std::size_t html = 0;
  for (auto _ : state) {
    auto files = build_report_files(r);
    if (!files) state.SkipWithError(files.error().message.c_str());
    html = files->front().content.size();
    benchmark::DoNotOptimize(files);
  }
  state.counters["triangles"] = static_cast<double>(r.placed_mesh.triangles.size());
  state.counters["mesh_samples"] = static_cast<double>(r.deviation.mesh_samples.size());
  state.counters["deposit_samples"] = static_cast<double>(r.deviation.deposit_samples.size());
  state.counters["html_MB"] = static_cast<double>(html) / 1e6;
}
BENCHMARK(BM_ReportFiles)->Unit(benchmark::kMillisecond);

void BM_RenderViews(benchmark::State& state) {
  tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
  const auto& r = big_report();
  for (auto _ : state) {
    auto assets = render_report_assets(r);
    benchmark::DoNotOptimize(assets);
  }
}
BENCHMARK(BM_RenderViews)->Unit(benchmark::kMillisecond);

/// The same with the BVH and the traced views built beforehand (HeatmapCache), as for
/// compare's variants after the first: colours, region markers and PNGs only.
void BM_RenderViewsCached(benchmark::State& state) {
  tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
  const auto& r = big_report();
  ReportOptions options;
  auto cache = build_heatmap_cache(r.placed_mesh, options.views);
  if (!cache) {
    state.SkipWithError(cache.error().message.c_str());
    return;
  }
  for (auto _ : state) {
    auto assets = detail::render_report_assets(r, options, &*cache);
    benchmark::DoNotOptimize(assets);
  }
}
BENCHMARK(BM_RenderViewsCached)->Unit(benchmark::kMillisecond);

void BM_CutMesh(benchmark::State& state) {
  const auto& r = big_report();
  std::vector<double> z;
  for (const auto& l : r.deviation.per_layer) z.push_back(l.z_mm - 0.1);
  for (auto _ : state) benchmark::DoNotOptimize(cut_mesh(r.placed_mesh, z, 0.02));
  state.counters["layers"] = static_cast<double>(z.size());
}
BENCHMARK(BM_CutMesh)->Unit(benchmark::kMillisecond);

/// The pieces of BM_RenderViews: every view traced (rasterised), the largest view alone,
/// PNG encoding.
void BM_TraceViews(benchmark::State& state) {
  const auto& r = big_report();
  const auto views = default_views();
  for (auto _ : state) benchmark::DoNotOptimize(build_heatmap_cache(r.placed_mesh, views));
}
BENCHMARK(BM_TraceViews)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();

void BM_RenderIsoView(benchmark::State& state) {
  tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
  const auto& r = big_report();
  SurfaceDeviationField field;
  field.sample_positions_mm = r.deviation.mesh_samples.positions_mm;
  field.sample_distances_mm = r.deviation.mesh_samples.distances_mm;
  field.vertex_deviation_mm = r.deviation.vertex_deviation_mm;
  field.sample_spacing_mm = r.settings.mesh_sample_spacing_mm;
  const auto scale = make_color_scale(r.deviation);
  const ViewSpec view = default_views().front();
  for (auto _ : state) benchmark::DoNotOptimize(render_heatmap(r.placed_mesh, field, scale, view));
}
BENCHMARK(BM_RenderIsoView)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();

void BM_EncodePngs(benchmark::State& state) {
  const auto& r = big_report();
  auto assets = render_report_assets(r);
  std::size_t bytes = 0;
  for (auto _ : state) {
    bytes = 0;
    for (const auto& v : assets->views) bytes += encode_png(v.image)->size();
  }
  state.counters["png_kB"] = static_cast<double>(bytes) / 1e3;
}
BENCHMARK(BM_EncodePngs)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();

/// report.html alone from rendered assets (charts, layer viewer data, tables).
void BM_ReportHtml(benchmark::State& state) {
  const auto& r = big_report();
  auto assets = render_report_assets(r);
  for (auto _ : state) benchmark::DoNotOptimize(report_html(r, *assets));
}
BENCHMARK(BM_ReportHtml)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();

}  // namespace

BENCHMARK_MAIN();
