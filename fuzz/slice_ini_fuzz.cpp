// libFuzzer target: a PrusaSlicer .ini through apply_prusa_ini and the settings' validation,
// then the settings listed back (every value formatted).
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "printtwin/slice.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  printtwin::SliceSettings settings;
  auto applied = printtwin::apply_prusa_ini(settings, text, "fuzz.ini");
  if (!applied) {
    if (applied.error().message.empty()) __builtin_trap();
    return 0;
  }
  if (auto st = printtwin::validate_slice_settings(settings); st) {
    (void)printtwin::slice_settings_entries(settings);
    (void)printtwin::resolve_widths(settings);
  }
  return 0;
}
