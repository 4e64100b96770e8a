#pragma once
// Helpers shared by the CLI subcommands: exit codes, error printing, terminal detection.
#include <cstdio>
#include <filesystem>
#include <initializer_list>
#include <string>
#include <system_error>
#include <tuple>

#include "printtwin/result.hpp"

namespace printtwin::cli {

/// Exit codes of every subcommand (README, docs/cli.md).
enum Exit : int { kPass = 0, kFail = 1, kUsage = 2, kBadInput = 3, kInternal = 4 };

/// Prints "printtwin: error: <file:line: message>" to stderr and returns the exit code.
inline int report_error(const Error& e) {
  std::fprintf(stderr, "printtwin: error: %s\n", e.describe().c_str());
  switch (e.code) {
    case ErrorCode::usage:
      return kUsage;
    case ErrorCode::bad_input:
      return kBadInput;
    case ErrorCode::internal:
      return kInternal;
  }
  return kInternal;
}

/// What an output option names: a folder (a report) or a file.
enum class OutputKind { folder, file };

/// Checks an output path before any work is done, so that a run does not compute for
/// minutes and then fail to write: a folder output may not be an existing file, a file
/// output may not be an existing folder, and no part of the parent path may be a file.
/// Empty paths (option not given) pass. Errors are usage errors naming the option.
inline Status check_output_path(const std::string& path, const char* option, OutputKind kind) {
  namespace fs = std::filesystem;
  if (path.empty()) return Ok{};
  std::error_code ec;
  const fs::path p(path);
  const auto st = fs::status(p, ec);
  if (kind == OutputKind::folder && fs::exists(st) && !fs::is_directory(st))
    return usage_error(std::string(option) + " " + path +
                       ": exists and is a file, expected a folder for the report");
  if (kind == OutputKind::file && fs::is_directory(st))
    return usage_error(std::string(option) + " " + path + ": is a folder, expected a file name");
  for (fs::path up = p.parent_path(); !up.empty(); up = up.parent_path()) {
    const auto ust = fs::status(up, ec);
    if (fs::exists(ust) && !fs::is_directory(ust))
      return usage_error(std::string(option) + " " + path + ": " + up.string() +
                         " is a file, not a folder");
    if (up == up.parent_path()) break;
  }
  return Ok{};
}

/// check_output_path for several options; the first problem.
inline Status check_output_paths(
    std::initializer_list<std::tuple<const std::string&, const char*, OutputKind>> outs) {
  for (const auto& [path, option, kind] : outs)
    if (auto st = check_output_path(path, option, kind); !st) return st;
  return Ok{};
}

/// True when progress may be drawn: stderr is a terminal and CI is not set.
bool show_progress();

}  // namespace printtwin::cli
