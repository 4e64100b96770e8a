#pragma once
// File helpers shared by every stage: whole-file reads with clear errors, and atomic writes
// (temporary file in the same folder, then rename) so that a failed run never leaves a
// half-written output that looks complete.
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

#include "printtwin/result.hpp"

namespace printtwin {

/// Reads a whole file. Errors name the file: missing, a directory, unreadable.
[[nodiscard]] Result<std::string> read_file(const std::filesystem::path& path);

/// Size of an input file without reading it; the same errors as read_file.
[[nodiscard]] Result<std::uint64_t> input_file_size(const std::filesystem::path& path);
/// The first `max_bytes` bytes of a file (fewer when it is shorter): a format's header can
/// be checked before the whole body is read. The same errors as read_file.
[[nodiscard]] Result<std::string> read_file_head(const std::filesystem::path& path,
                                                 std::size_t max_bytes);

/// Writes `content` to `path` atomically (creates parent folders).
[[nodiscard]] Status write_file_atomic(const std::filesystem::path& path, std::string_view content);

/// Shortest round-trip decimal form of `v`, locale-independent (std::to_chars).
[[nodiscard]] std::string format_number(double v);
/// Fixed-point form with `decimals` digits, locale-independent; "-0" printed as "0".
[[nodiscard]] std::string format_fixed(double v, int decimals);

/// Duration as slicers print it in G-code comments: "1h 2m 3s", "25m 53s", "48s"
/// (PrusaSlicer's `estimated printing time` style).
[[nodiscard]] std::string format_duration_compact(double seconds);
/// Duration for reports: "1 h 02 min", "25 min 53 s", "48 s"; "—" when not finite or negative.
[[nodiscard]] std::string format_duration(double seconds);

/// SHA-256 of a byte string as lowercase hex (for report provenance).
/// Uses the CPU's SHA extensions when present (x86-64), a portable implementation otherwise.
[[nodiscard]] std::string sha256_hex(std::string_view bytes);
/// The portable implementation alone (same digest; for tests and benchmarks).
[[nodiscard]] std::string sha256_hex_portable(std::string_view bytes);

}  // namespace printtwin
