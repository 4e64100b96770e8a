#pragma once
// Sliced 3MF files: the ".gcode.3mf" that Bambu Studio and OrcaSlicer export for a printer
// (and send to it). The archive holds the project (3D/, Metadata/*.config, thumbnails) and the
// G-code of each sliced plate as Metadata/plate_<n>.gcode. printtwin reads that G-code as if
// it were the file given: simulate, verify and the printer detection see the plate's text.
#include <filesystem>
#include <string>
#include <string_view>

#include "printtwin/result.hpp"

namespace printtwin {

/// True when the file starts like a zip archive (a 3MF), whatever its name.
[[nodiscard]] bool is_gcode_3mf_file(const std::filesystem::path& path);

/// True when the bytes start like a zip archive.
[[nodiscard]] bool looks_like_gcode_3mf(std::string_view head);

/// The G-code of a sliced 3MF held in memory (`source` names it in errors): its one
/// Metadata/plate_<n>.gcode. Errors (bad input): a damaged archive; no plate G-code (a
/// project that was never sliced); G-code of several plates (the message lists them and
/// says how to take one out).
[[nodiscard]] Result<std::string> gcode_of_3mf(std::string_view archive, const std::string& source);

/// The same, read from a file.
[[nodiscard]] Result<std::string> read_gcode_3mf(const std::filesystem::path& path);

}  // namespace printtwin
