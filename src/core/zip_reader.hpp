#pragma once
// Reading one named entry out of a zip archive (3MF projects are zip archives). Only what
// printtwin needs: the central directory, stored and deflated entries, ZIP64 sizes and
// offsets, CRC-32 checked. Errors name the archive and what in it is wrong.
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "printtwin/result.hpp"

namespace printtwin::detail {

/// True when the bytes start like a zip archive ("PK\3\4", or an empty archive "PK\5\6").
[[nodiscard]] bool looks_like_zip(std::string_view bytes);

/// The uncompressed bytes of the entry called `name` in the zip archive held in `archive`
/// (`source` names the file in errors); nullopt when the archive has no such entry.
/// A damaged archive, an encrypted entry or an unknown compression method is an error.
[[nodiscard]] Result<std::optional<std::string>> zip_entry(std::string_view archive,
                                                           std::string_view name,
                                                           const std::string& source);

/// The names of the archive's entries, in the order of its central directory.
[[nodiscard]] Result<std::vector<std::string>> zip_entry_names(std::string_view archive,
                                                               const std::string& source);

}  // namespace printtwin::detail
