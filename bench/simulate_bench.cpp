// Throughput of the G-code stage: parse only, and parse + interpret + plan (simulate_gcode).
//
//   build/bench/simulate_bench                                   # the committed fixtures
//   PRINTTWIN_BENCH_GCODE=/tmp/big.gcode build/bench/simulate_bench   # any G-code file
//
// The file is read into memory once; each iteration streams it through the pipeline from
// an in-memory stream, so the figures exclude disk I/O. Counters: lines/s and moves/s.
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include "printtwin/gcode.hpp"
#include "printtwin/io.hpp"
#include "printtwin/simulate.hpp"

namespace {

const std::string& gcode_text() {
  static const std::string text = [] {
    const char* env = std::getenv("PRINTTWIN_BENCH_GCODE");
    const std::string path = env != nullptr ? std::string(env)
                                            : std::string(PRINTTWIN_SOURCE_DIR) +
                                                  "/samples/gcode/prusa_thin_walls.gcode";
    auto t = printtwin::read_file(path);
    return t.ok() ? *t : std::string();
  }();
  return text;
}

long count_lines(const std::string& s) {
  long n = 0;
  for (char c : s) n += c == '\n';
  return n;
}

void BM_ParseLines(benchmark::State& state) {
  const std::string& text = gcode_text();
  const long lines = count_lines(text);
  printtwin::GcodeCommand cmd;
  for (auto _ : state) {
    std::istringstream in(text);
    printtwin::GcodeLineReader reader(in);
    std::string_view line;
    long ok = 0;
    while (reader.next(line)) ok += parse_gcode_line(line, reader.line_number(), cmd).ok();
    benchmark::DoNotOptimize(ok);
  }
  state.counters["lines_per_s"] =
      benchmark::Counter(static_cast<double>(lines), benchmark::Counter::kIsIterationInvariantRate);
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations()) *
                          static_cast<std::int64_t>(text.size()));
}
BENCHMARK(BM_ParseLines)->Unit(benchmark::kMillisecond);

void BM_Simulate(benchmark::State& state, printtwin::PrinterProfile profile,
                 bool limits_from_gcode) {
  const std::string& text = gcode_text();
  const long lines = count_lines(text);
  long moves = 0;
  for (auto _ : state) {
    std::istringstream in(text);
    printtwin::SimulateOptions options;
    options.limits_from_gcode = limits_from_gcode;
    auto r = printtwin::simulate_gcode(in, profile, options);
    if (!r.ok()) {
      state.SkipWithError(r.error().describe().c_str());
      return;
    }
    moves = r->moves;
    benchmark::DoNotOptimize(r->print_time_s);
  }
  state.counters["lines_per_s"] =
      benchmark::Counter(static_cast<double>(lines), benchmark::Counter::kIsIterationInvariantRate);
  state.counters["moves_per_s"] =
      benchmark::Counter(static_cast<double>(moves), benchmark::Counter::kIsIterationInvariantRate);
  state.counters["lines"] = static_cast<double>(lines);
}
BENCHMARK_CAPTURE(BM_Simulate, marlin2_junction_deviation, printtwin::ender3_marlin2(), false)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Simulate, marlin1_classic_jerk, printtwin::ender3_marlin1(), false)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Simulate, klipper, printtwin::ender3_klipper(), false)
    ->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
