// libFuzzer target: arbitrary bytes through the line reader, the parser, the interpreter
// and the planner. The first byte picks the profile and options; the rest is the G-code.
// Besides crashes and sanitizer reports, it traps when a result is not finite or when the
// accounting does not add up.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>

#include "printtwin/simulate.hpp"

namespace {
struct Check final : printtwin::MoveSink {
  double last_end_s = 0;
  void on_move(const printtwin::Move& m) override {
    if (!m.start_mm.allFinite() || !m.end_mm.allFinite() || !std::isfinite(m.e_mm))
      __builtin_trap();
  }
  void on_segment(const printtwin::MotionSegment& s) override {
    if (!std::isfinite(s.duration_s()) || s.duration_s() < 0) __builtin_trap();
    if (s.start_time_s + 1e-6 < last_end_s) __builtin_trap();
    last_end_s = s.end_time_s();
  }
};
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::uint8_t mode = data[0];
  std::string text(reinterpret_cast<const char*>(data + 1), size - 1);
  printtwin::PrinterProfile profile =
      (mode & 1) ? printtwin::ender3_marlin1() : printtwin::ender3_marlin2();
  if (mode & 2) profile.firmware_retraction = true;
  printtwin::SimulateOptions options;
  options.interpreter.strict = (mode & 4) != 0;
  options.interpreter.prevent_cold_extrusion = (mode & 8) == 0;
  options.limits_from_gcode = (mode & 16) != 0;
  std::istringstream in(text);
  Check check;
  auto r = printtwin::simulate_gcode(in, profile, options, &check);
  if (r.ok()) {
    const auto& s = *r;
    if (!std::isfinite(s.print_time_s) || !std::isfinite(s.filament_mm)) __builtin_trap();
    const double sum = s.motion_time_s + s.homing_time_s + s.dwell_time_s + s.heating_time_s;
    if (std::fabs(sum - s.print_time_s) > 1e-6 * (1 + s.print_time_s)) __builtin_trap();
    (void)printtwin::simulation_to_json(s, "fuzz");
  } else if (r.error().message.empty()) {
    __builtin_trap();
  }
  return 0;
}
