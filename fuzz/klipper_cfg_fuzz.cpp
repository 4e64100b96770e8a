// libFuzzer target: a Klipper printer.cfg through load_klipper_printer_cfg (the section
// reader, SAVE_CONFIG blocks, [include] of relative files and globs, the profile mapping).
// The reader takes a path, so each input is written to printer.cfg in a private directory
// of its own; "[include *]" can then reach only that file (a cycle, which must be
// reported). Inputs naming absolute or parent paths are skipped: they would read the
// machine's files (and /proc files that never end), not the fuzzer's bytes.
#include <unistd.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <string_view>

#include "printtwin/machine.hpp"
#include "printtwin/printer.hpp"

namespace {
const std::string& private_dir() {
  static const std::string dir = [] {
    std::string t = "/tmp/printtwin_klipper_fuzz_XXXXXX";
    if (mkdtemp(t.data()) == nullptr) std::abort();
    return t;
  }();
  return dir;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  if (text.find("include") != std::string_view::npos &&
      (text.find('/') != std::string_view::npos || text.find("..") != std::string_view::npos))
    return 0;
  const std::string path = private_dir() + "/printer.cfg";
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(text.data(), static_cast<std::streamsize>(text.size()));
    if (!out) std::abort();
  }
  auto profile = printtwin::load_klipper_printer_cfg(path);
  if (!profile) {
    if (profile.error().message.empty()) __builtin_trap();
    return 0;
  }
  // A profile that loads must be one the profile reader accepts back.
  const std::string json = printtwin::printer_profile_to_json(*profile);
  if (auto again = printtwin::parse_printer_profile(json, "round-trip.json"); !again) {
    std::fprintf(stderr, "profile from printer.cfg not accepted back: %s\n%s\n",
                 again.error().message.c_str(), json.c_str());
    __builtin_trap();
  }
  return 0;
}
