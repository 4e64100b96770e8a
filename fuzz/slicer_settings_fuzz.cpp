// libFuzzer target: the slicer settings embedded in a G-code (every slicer's header and
// config block) through parse_slicer_settings, then stated_printer (bed shape, limits,
// flavour, temperatures) and the printer library's name matching. The first byte splits
// the rest into a head and a tail window, as read_slicer_settings cuts a big file.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "printtwin/printer.hpp"

namespace {
void check_finite(const auto& value) {
  if (value && !std::isfinite(value->value)) __builtin_trap();
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::string_view text(reinterpret_cast<const char*>(data + 1), size - 1);
  const std::size_t split = text.size() * data[0] / 255;
  // Head and tail overlap unless the split is at an end, as on a small file.
  const std::string_view head = text.substr(0, std::max(split, text.size() / 2));
  const std::string_view tail = text.substr(std::min(split, text.size() / 2));
  const auto settings = printtwin::parse_slicer_settings(head, tail, 1);
  const auto stated = printtwin::stated_printer(settings);
  check_finite(stated.max_z_mm);
  check_finite(stated.nozzle_diameter_mm);
  check_finite(stated.filament_diameter_mm);
  for (int axis = 0; axis < 4; ++axis) {
    check_finite(stated.max_feedrate_mm_s[axis]);
    check_finite(stated.max_accel_mm_s2[axis]);
    check_finite(stated.jerk_mm_s[axis]);
  }
  for (const auto& name : stated.names) (void)printtwin::match_library_printer(name);
  return 0;
}
