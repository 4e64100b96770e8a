// The G-code's side of verify: simulate on the twin, then deposit (PrintedGcode).
#include <algorithm>
#include <sstream>

#include "printtwin/bgcode.hpp"
#include "printtwin/gcode_3mf.hpp"
#include "printtwin/planner.hpp"
#include "printtwin/simulate.hpp"
#include "verify/pipeline.hpp"

namespace printtwin {

using verify_detail::count_severities;
using verify_detail::StageClock;
using verify_detail::validate_verify_settings;

namespace {

/// Collects every interpreted Move (the deposit and the registration need them all).
class CollectMoves final : public MoveSink {
 public:
  std::vector<Move> moves;
  void on_move(const Move& move) override { moves.push_back(move); }
};

}  // namespace

namespace verify_detail {

Result<PrintedGcode> print_gcode_with(const PrinterProfile& printer, const VerifySettings& settings,
                                      GcodeInput gcode,
                                      const std::function<void(std::string_view)>& on_stage,
                                      const std::function<void(const PartExtent&)>& on_extent) {
  auto stage = [&](std::string_view name) {
    if (on_stage) on_stage(name);
  };
  if (auto st = validate_verify_settings(settings); !st) return st.error();
  PrintedGcode printed;
  printed.name = gcode.name;
  printed.source = gcode.source;
  printed.inputs = std::move(gcode.inputs);
  printed.findings = std::move(gcode.findings);
  printed.printer = printer;
  if (gcode.source == "printtwin slice") printed.timings.push_back({"slice", gcode.slice_time_s});
  StageClock clock(printed.timings);

  // Simulate, collecting the moves.
  stage("simulate");
  CollectMoves collector;
  // About a move per line: reserved up front, the list is never copied as it grows (the
  // capacity no move reaches is never touched).
  collector.moves.reserve(
      static_cast<std::size_t>(std::count(gcode.text.begin(), gcode.text.end(), '\n')) + 1);
  SimulateOptions sim_options;
  sim_options.source_name = gcode.name;
  if (looks_like_gcode_3mf(gcode.text)) {  // a sliced 3MF: its plate's G-code
    auto text = gcode_of_3mf(gcode.text, gcode.name);
    if (!text) return text.error();
    gcode.text = std::move(*text);
  }
  auto sim = [&]() -> Result<SimulationResult> {
    if (is_bgcode_input(gcode.text,
                        gcode.name)) {  // binary G-code (bgcode.hpp): decoded block by block
      auto stream = BgcodeGcodeStream::from_memory(gcode.text, gcode.name);
      if (!stream) return stream.error();
      auto r = simulate_gcode(**stream, printer, sim_options, &collector);
      if ((*stream)->error()) return *(*stream)->error();
      return r;
    }
    std::istringstream gcode_stream(std::move(gcode.text));
    return simulate_gcode(gcode_stream, printer, sim_options, &collector);
  }();
  if (!sim) return sim.error();
  {
    SimulationSummary& s = printed.simulation;
    s.slicer = gcode.source == "printtwin slice" ? std::string("printtwin") : sim->slicer;
    s.gcode_lines = static_cast<std::size_t>(sim->lines);
    s.moves = static_cast<std::size_t>(sim->moves);
    for (const auto& m : collector.moves) s.extrusion_moves += m.kind == MoveKind::extrude ? 1 : 0;
    s.layers = static_cast<int>(sim->layers.size());
    s.print_time_s = sim->print_time_s;
    s.filament_mm = sim->filament_mm;
    s.extruded_volume_mm3 = sim->filament_mm3;
    s.extrusion_bbox_mm = sim->extrusion_bounds_mm;
    count_severities(sim->findings, s.errors, s.warnings, s.infos);
    printed.findings.insert(printed.findings.end(), sim->findings.begin(), sim->findings.end());
  }
  clock.lap("simulate");

  // Where the slicer put the part (the registration itself needs the mesh: measure_printed).
  printed.extent = find_part_extent(collector.moves, sim->object_names);
  if (!settings.place_mm && printed.extent.moves == 0)
    return bad_input("the G-code has no extrusion of the part to register the mesh against",
                     gcode.name);
  if (on_extent) on_extent(printed.extent);

  // Deposit.
  stage("deposit");
  DepositSettings dep_settings;
  dep_settings.voxel_mm = settings.voxel_mm;
  dep_settings.conserve_volume = settings.conserve_volume;
  auto deposit = deposit_moves(collector.moves, printer, dep_settings);
  if (!deposit) return deposit.error();
  printed.beads = surface_beads(collector.moves, printer);
  collector.moves = {};
  printed.findings.insert(printed.findings.end(), deposit->findings.begin(),
                          deposit->findings.end());
  deposit->findings.clear();
  printed.deposit = std::move(*deposit);
  clock.lap("deposit");
  return printed;
}

}  // namespace verify_detail

Result<PrintedGcode> print_gcode(const PrinterProfile& printer, const VerifySettings& settings,
                                 GcodeInput gcode,
                                 const std::function<void(std::string_view)>& on_stage) {
  return verify_detail::print_gcode_with(printer, settings, std::move(gcode), on_stage, {});
}

}  // namespace printtwin
