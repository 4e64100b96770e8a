// The G-code inside a sliced 3MF (include/printtwin/gcode_3mf.hpp).
#include "printtwin/gcode_3mf.hpp"

#include <algorithm>
#include <vector>

#include "core/zip_reader.hpp"
#include "printtwin/io.hpp"

namespace printtwin {

namespace {

/// The plate number of an entry named Metadata/plate_<n>.gcode, or 0.
int plate_of(std::string_view name) {
  constexpr std::string_view kPrefix = "Metadata/plate_";
  constexpr std::string_view kSuffix = ".gcode";
  if (name.size() <= kPrefix.size() + kSuffix.size() || name.substr(0, kPrefix.size()) != kPrefix ||
      name.substr(name.size() - kSuffix.size()) != kSuffix)
    return 0;
  const std::string_view digits =
      name.substr(kPrefix.size(), name.size() - kPrefix.size() - kSuffix.size());
  if (digits.empty() || digits.size() > 4 ||
      !std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; }))
    return 0;
  return std::stoi(std::string(digits));
}

}  // namespace

bool looks_like_gcode_3mf(std::string_view head) { return detail::looks_like_zip(head); }

bool is_gcode_3mf_file(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return false;
  const auto head = read_file_head(path, 4);
  return head.ok() && looks_like_gcode_3mf(*head);
}

Result<std::string> gcode_of_3mf(std::string_view archive, const std::string& source) {
  auto names = detail::zip_entry_names(archive, source);
  if (!names) return names.error();
  std::vector<std::pair<int, std::string>> plates;
  for (const auto& n : *names)
    if (const int p = plate_of(n); p > 0) plates.emplace_back(p, n);
  std::sort(plates.begin(), plates.end());
  if (plates.empty())
    return bad_input(
        "a 3MF archive with no sliced G-code in it (no Metadata/plate_<n>.gcode): a project, "
        "not a print; slice it and export the plate (\"Export plate sliced file\"), or pass the "
        "G-code",
        source);
  if (plates.size() > 1) {
    std::string list;
    for (const auto& [p, n] : plates) list += (list.empty() ? "" : ", ") + std::to_string(p);
    return bad_input("the 3MF holds the G-code of " + std::to_string(plates.size()) + " plates (" +
                         list + "); printtwin reads one print: take one out, e.g. " +
                         "unzip -p FILE " + plates.front().second + " > plate_" +
                         std::to_string(plates.front().first) + ".gcode",
                     source);
  }
  auto text = detail::zip_entry(archive, plates.front().second, source);
  if (!text) return text.error();
  return std::move(**text);
}

Result<std::string> read_gcode_3mf(const std::filesystem::path& path) {
  auto bytes = read_file(path);
  if (!bytes) return bytes.error();
  return gcode_of_3mf(*bytes, path.string());
}

}  // namespace printtwin
