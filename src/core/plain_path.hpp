#pragma once
// The benchmark switch of the special paths (SIMD kernels, helper threads, memory tricks).
//
// Every special path has a plain twin that gives the same results. `bench/RESULTS.md`
// measures each special path against its twin, side by side, by running the same binary
// with PRINTTWIN_PLAIN set: a comma-separated list of path names, or `all`. A path whose
// name is listed takes its plain twin. Nothing else reads the variable; users never need it.
#include <cstdlib>
#include <string_view>

namespace printtwin::detail {

/// True when the environment variable PRINTTWIN_PLAIN lists `path` (or says `all`).
inline bool plain_path(std::string_view path) {
  const char* env = std::getenv("PRINTTWIN_PLAIN");
  if (env == nullptr) return false;
  std::string_view list(env);
  while (!list.empty()) {
    const std::size_t comma = list.find(',');
    const std::string_view item = list.substr(0, comma);
    if (item == "all" || item == path) return true;
    if (comma == std::string_view::npos) break;
    list.remove_prefix(comma + 1);
  }
  return false;
}

}  // namespace printtwin::detail
