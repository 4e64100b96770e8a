// libFuzzer target: printer profile JSON through parse_printer_profile. A profile that parses
// must write itself out as JSON that parses back to the same text.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "printtwin/machine.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  auto profile = printtwin::parse_printer_profile(text, "fuzz.json");
  if (!profile) {
    if (profile.error().message.empty()) __builtin_trap();
    return 0;
  }
  const std::string json = printtwin::printer_profile_to_json(*profile);
  auto again = printtwin::parse_printer_profile(json, "round-trip.json");
  if (!again || printtwin::printer_profile_to_json(*again) != json) __builtin_trap();
  return 0;
}
