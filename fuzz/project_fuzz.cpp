// libFuzzer target: the per-object settings of a PrusaSlicer 3MF project
// (Metadata/Slic3r_PE_model.config and the height-range file) through
// detail::project_object_settings. The input's first NUL splits it into the two files.
// Besides crashes and sanitizer reports, it traps when an error says nothing or names
// another file, or when a key read back is empty.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "slice/project_settings.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  const std::size_t split = bytes.find('\0');
  const std::string_view model = bytes.substr(0, split);
  const std::string_view ranges =
      split == std::string_view::npos ? std::string_view{} : bytes.substr(split + 1);
  auto settings = printtwin::detail::project_object_settings(model, ranges, "fuzz.3mf");
  if (!settings) {
    if (settings.error().message.empty() || settings.error().file != "fuzz.3mf") __builtin_trap();
    return 0;
  }
  for (const auto& [key, value] : *settings)
    if (key.empty()) __builtin_trap();
  return 0;
}
