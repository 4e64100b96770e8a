// Binary G-code against its text twin: the same print simulated from each, the decoding
// alone, and the fixed cost of opening a file (header, metadata and thumbnail blocks, the
// slicer's deflated settings; bgcode.hpp). The ratio BM_SimulateBinary / BM_SimulateText is
// the cost of reading .bgcode instead of text.
//
//   build/bench/bgcode_bench --benchmark_repetitions=9 --benchmark_report_aggregates_only=true
//                                      # PrusaSlicer's MK4S pair in the shared real-world folder
//   PRINTTWIN_BENCH_GCODE=part.gcode PRINTTWIN_BENCH_BGCODE=part.bgcode build/bench/bgcode_bench
//
// Both files are read into memory once; each iteration streams one through the pipeline
// (text: std::istringstream; binary: BgcodeGcodeStream over the bytes, blocks decoded as the
// interpreter reads), so the figures exclude disk I/O. Without the files nothing runs.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "printtwin/bgcode.hpp"
#include "printtwin/io.hpp"
#include "printtwin/simulate.hpp"

namespace {

std::string pair_path(const char* env, const char* file) {
  if (const char* p = std::getenv(env); p != nullptr && *p != '\0') return p;
  for (const std::filesystem::path& dir :
       {std::filesystem::path(PRINTTWIN_SOURCE_DIR) / "../shared/realworld/gcode",
        std::filesystem::path("/work/shared/realworld/gcode")})
    if (std::error_code ec; std::filesystem::exists(dir / file, ec)) return (dir / file).string();
  return {};
}

struct Pair {
  std::string text, binary;
};

const Pair& files() {
  static const Pair pair = [] {
    Pair p;
    const auto t =
        pair_path("PRINTTWIN_BENCH_GCODE", "prusaslicer-2.8.1_MK4S_mini_cube_arcs.gcode");
    const auto b =
        pair_path("PRINTTWIN_BENCH_BGCODE", "prusaslicer-2.8.1_MK4S_mini_cube_arcs_BINARY.bgcode");
    if (auto r = printtwin::read_file(t)) p.text = std::move(*r);
    if (auto r = printtwin::read_file(b)) p.binary = std::move(*r);
    return p;
  }();
  return pair;
}

/// A longer print made of the binary file: its G-code blocks repeated `kRepeats` times
/// (each block is a self-contained stream with its own CRC, so the file stays valid), and
/// its text twin, the decoded text of that file. The metadata's fixed cost then weighs
/// as little as in a print of an hour or more.
constexpr int kRepeats = 20;
const Pair& long_print() {
  static const Pair pair = [] {
    Pair p;
    auto meta = printtwin::read_bgcode_metadata(files().binary, "bench.bgcode");
    if (!meta || meta->first_gcode_block_offset == 0) return p;
    const std::string& b = files().binary;
    const auto first = static_cast<std::size_t>(meta->first_gcode_block_offset);
    p.binary = b.substr(0, first);
    for (int i = 0; i < kRepeats; ++i) p.binary += b.substr(first);
    if (auto text = printtwin::decode_bgcode(p.binary, "bench.bgcode")) p.text = std::move(*text);
    return p;
  }();
  return pair;
}

const Pair& pair_for(const benchmark::State& state) {
  return state.range(0) == 0 ? files() : long_print();
}

void BM_SimulateText(benchmark::State& state) {
  for (auto _ : state) {
    std::istringstream in(pair_for(state).text);
    auto r = printtwin::simulate_gcode(in, printtwin::ender3_marlin2(), {});
    if (!r) state.SkipWithError(r.error().describe().c_str());
    benchmark::DoNotOptimize(r);
  }
  state.SetBytesProcessed(
      static_cast<std::int64_t>(state.iterations() * pair_for(state).text.size()));
}

void BM_SimulateBinary(benchmark::State& state) {
  for (auto _ : state) {
    auto in = printtwin::BgcodeGcodeStream::from_memory(pair_for(state).binary, "bench.bgcode");
    if (!in) {
      state.SkipWithError(in.error().describe().c_str());
      break;
    }
    auto r = printtwin::simulate_gcode(**in, printtwin::ender3_marlin2(), {});
    if (!r || (*in)->error()) state.SkipWithError("simulate failed");
    benchmark::DoNotOptimize(r);
  }
  state.SetBytesProcessed(
      static_cast<std::int64_t>(state.iterations() * pair_for(state).binary.size()));
}

void BM_DecodeBinary(benchmark::State& state) {
  std::size_t text_bytes = 0;
  for (auto _ : state) {
    auto text = printtwin::decode_bgcode(pair_for(state).binary, "bench.bgcode");
    if (!text) state.SkipWithError(text.error().describe().c_str());
    text_bytes = text ? text->size() : 0;
    benchmark::DoNotOptimize(text);
  }
  state.counters["text_bytes"] = static_cast<double>(text_bytes);
  state.SetBytesProcessed(
      static_cast<std::int64_t>(state.iterations() * pair_for(state).binary.size()));
}

/// Opening alone: the metadata blocks read and the G-code stream set up, nothing decoded.
void BM_OpenBinary(benchmark::State& state) {
  for (auto _ : state) {
    auto in = printtwin::BgcodeGcodeStream::from_memory(pair_for(state).binary, "bench.bgcode");
    if (!in) state.SkipWithError(in.error().describe().c_str());
    benchmark::DoNotOptimize(in);
  }
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (files().text.empty() || files().binary.empty()) {
    std::cerr << "bgcode_bench: no text/binary pair (set PRINTTWIN_BENCH_GCODE and "
                 "PRINTTWIN_BENCH_BGCODE)\n";
    return 0;
  }
  // Argument 0: the file as it is; 1: its G-code repeated kRepeats times.
  for (auto* b : {benchmark::RegisterBenchmark("BM_SimulateText", BM_SimulateText),
                  benchmark::RegisterBenchmark("BM_SimulateBinary", BM_SimulateBinary),
                  benchmark::RegisterBenchmark("BM_DecodeBinary", BM_DecodeBinary),
                  benchmark::RegisterBenchmark("BM_OpenBinary", BM_OpenBinary)})
    b->Arg(0)
        ->Arg(1)
        ->Unit(benchmark::kMillisecond)
        ->ComputeStatistics("min", [](const std::vector<double>& v) {
          return *std::min_element(v.begin(), v.end());
        });
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
