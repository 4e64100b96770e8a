#pragma once
// Internals shared by profile.cpp, printer_library.cpp, printer_detect.cpp and
// klipper_config.cpp.
#include <functional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "printtwin/machine.hpp"

namespace printtwin {

/// Finds the profile a JSON profile's "base" names.
using ProfileBaseLookup = std::function<Result<PrinterProfile>(const std::string&)>;

/// ender3 / ender3-marlin1 / ender3-klipper or a library id.
[[nodiscard]] Result<PrinterProfile> builtin_printer(std::string_view name);

/// parse_printer_profile with a custom base lookup; every key the text sets is recorded in
/// profile.origin with `origin_source` ("library" or "config") and the source name.
[[nodiscard]] Result<PrinterProfile> parse_printer_profile_with(std::string_view json_text,
                                                                std::string_view source,
                                                                const ProfileBaseLookup& lookup,
                                                                const std::string& origin_source);

/// The embedded printers/*.json: (file name, text) pairs (generated at build time).
[[nodiscard]] const std::vector<std::pair<std::string_view, std::string_view>>&
embedded_printer_files();

/// Lowercase words of a name ("Original Prusa MK4S 0.4 nozzle" -> original prusa mk4s 0 4 nozzle).
[[nodiscard]] std::vector<std::string> name_words(std::string_view name);

}  // namespace printtwin
