#pragma once
// Private to src/: atomic writes of files produced piece by piece (write_file_atomic in
// printtwin/io.hpp takes the whole content at once).
#include <filesystem>
#include <functional>

#include "printtwin/result.hpp"

namespace printtwin::detail {

/// Writes `path` atomically like write_file_atomic (temporary file beside it, then rename),
/// the content written by `fill` into the temporary file: a POSIX descriptor open for reading
/// and writing at offset 0 (pread, pwrite and ftruncate may be used). `fill` returns false
/// when a write fails.
[[nodiscard]] Status write_file_atomic_with(const std::filesystem::path& path,
                                            const std::function<bool(int fd)>& fill);

}  // namespace printtwin::detail
