#pragma once
// Helpers shared by the CLI subcommands: exit codes, error printing, terminal detection.
#include <cstdio>
#include <string>

#include "printtwin/result.hpp"

namespace printtwin::cli {

/// Exit codes of every subcommand (README, docs/cli.md).
enum Exit : int { kPass = 0, kFail = 1, kUsage = 2, kBadInput = 3, kInternal = 4 };

/// Prints "printtwin: error: <file:line: message>" to stderr and returns the exit code.
inline int report_error(const Error& e) {
  std::fprintf(stderr, "printtwin: error: %s\n", e.describe().c_str());
  switch (e.code) {
    case ErrorCode::usage: return kUsage;
    case ErrorCode::bad_input: return kBadInput;
    case ErrorCode::internal: return kInternal;
  }
  return kInternal;
}

/// True when progress may be drawn: stderr is a terminal and CI is not set.
bool show_progress();

}  // namespace printtwin::cli
