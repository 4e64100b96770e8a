// Whole-file reads and atomic writes; locale-independent number formatting.
#include "printtwin/io.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <optional>
#include <random>
#include <sstream>
#include <system_error>

#include "core/atomic_write.hpp"

namespace printtwin {

namespace fs = std::filesystem;

namespace {

/// Why `path` cannot be read, in the user's terms ("file not found", "symbolic link loop",
/// "permission denied", ...), or nothing when it is a readable-looking regular file.
std::optional<Error> input_problem(const fs::path& path) {
  std::error_code ec;
  const auto status = fs::status(path, ec);
  if (ec && ec != std::errc::no_such_file_or_directory) {
    if (ec == std::errc::too_many_symbolic_link_levels)
      return bad_input("symbolic link loop (too many levels of symbolic links), expected a file",
                       path.string());
    if (ec == std::errc::permission_denied)
      return bad_input("permission denied (a folder on the path cannot be searched)",
                       path.string());
    if (ec == std::errc::not_a_directory)
      return bad_input("file not found (a part of the path is a file, not a folder)",
                       path.string());
    return bad_input("cannot access: " + ec.message(), path.string());
  }
  if (!fs::exists(status)) {
    std::error_code lec;
    if (fs::is_symlink(fs::symlink_status(path, lec)))
      return bad_input("dangling symbolic link: its target does not exist", path.string());
    return bad_input("file not found", path.string());
  }
  if (fs::is_directory(status)) return bad_input("is a directory, expected a file", path.string());
  return std::nullopt;
}

}  // namespace

Result<std::uint64_t> input_file_size(const fs::path& path) {
  if (auto problem = input_problem(path)) return *problem;
  std::error_code ec;
  const auto size = fs::file_size(path, ec);
  if (ec)
    return bad_input("cannot read its size (not a regular file?): " + ec.message(), path.string());
  return static_cast<std::uint64_t>(size);
}

Result<std::string> read_file_head(const fs::path& path, std::size_t max_bytes) {
  if (auto problem = input_problem(path)) return *problem;
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (f == nullptr)
    return bad_input(std::string("cannot open: ") + std::strerror(errno), path.string());
  std::string data(max_bytes, '\0');
  const std::size_t got = data.empty() ? 0 : std::fread(data.data(), 1, data.size(), f);
  const bool failed = std::ferror(f) != 0;
  std::fclose(f);
  if (failed) return bad_input("read error", path.string());
  data.resize(got);
  return data;
}

Result<std::string> read_file(const fs::path& path) {
  if (auto problem = input_problem(path)) return *problem;
  // C stdio with one fread into the final buffer: no stream buffer copy in between.
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (f == nullptr)
    return bad_input(std::string("cannot open: ") + std::strerror(errno), path.string());
  std::string data;
  bool ok = std::fseek(f, 0, SEEK_END) == 0;
  const long size = ok ? std::ftell(f) : -1;
  if (size < 0 || std::fseek(f, 0, SEEK_SET) != 0) {
    std::fclose(f);
    return bad_input("cannot read (not a regular file?)", path.string());
  }
  std::setvbuf(f, nullptr, _IONBF, 0);
  data.resize(static_cast<std::size_t>(size));
  const std::size_t got = data.empty() ? 0 : std::fread(data.data(), 1, data.size(), f);
  ok = got == data.size() || std::feof(f) != 0;
  if (!ok || std::ferror(f) != 0) {
    std::fclose(f);
    return bad_input("read error", path.string());
  }
  std::fclose(f);
  data.resize(got);
  return data;
}

Status write_file_atomic(const fs::path& path, std::string_view content) {
  return detail::write_file_atomic_with(path, [content](int fd) {
    for (std::size_t done = 0; done < content.size();) {
      const ssize_t n = ::write(fd, content.data() + done, content.size() - done);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) return false;
      done += static_cast<std::size_t>(n);
    }
    return true;
  });
}

Status detail::write_file_atomic_with(const fs::path& path,
                                      const std::function<bool(int fd)>& fill) {
  std::error_code ec;
  if (fs::is_directory(path, ec))
    return bad_input("is a folder, expected a file to write", path.string());
  if (path.has_parent_path()) fs::create_directories(path.parent_path(), ec);
  // A unique temporary name beside the target, so that rename() is atomic.
  std::random_device rd;
  const fs::path tmp = path.string() + ".tmp" + std::to_string(rd() % 1000000);
  const int fd = ::open(tmp.c_str(), O_RDWR | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
  if (fd < 0) {
    return Error{ErrorCode::bad_input,
                 std::string("cannot write: ") + std::strerror(errno),
                 path.string(),
                 {}};
  }
  const bool filled = fill(fd);
  if (::close(fd) != 0 || !filled) {
    fs::remove(tmp, ec);
    return Error{ErrorCode::bad_input, "write failed (disk full?)", path.string(), {}};
  }
  fs::rename(tmp, path, ec);
  if (ec) {
    // The rename's reason, read before the clean-up reuses an error code.
    const std::string why =
        ec == std::errc::is_a_directory ? "it is a folder, expected a file" : ec.message();
    std::error_code ignored;
    fs::remove(tmp, ignored);
    return Error{ErrorCode::bad_input,
                 "cannot rename the temporary file into place: " + why,
                 path.string(),
                 {}};
  }
  return Ok{};
}

std::string format_number(double v) {
  if (!std::isfinite(v)) return std::isnan(v) ? "nan" : (v > 0 ? "inf" : "-inf");
  std::array<char, 64> buf{};
  auto [ptr, err] = std::to_chars(buf.data(), buf.data() + buf.size(), v);
  if (err != std::errc{}) return "0";
  return std::string(buf.data(), ptr);
}

std::string format_fixed(double v, int decimals) {
  if (!std::isfinite(v)) return format_number(v);
  std::array<char, 128> buf{};
  auto [ptr, err] =
      std::to_chars(buf.data(), buf.data() + buf.size(), v, std::chars_format::fixed, decimals);
  if (err != std::errc{}) return "0";
  std::string s(buf.data(), ptr);
  // "-0.000" -> "0.000"
  if (s[0] == '-' && s.find_first_not_of("-0.") == std::string::npos) s.erase(0, 1);
  return s;
}

std::string format_duration_compact(double seconds) {
  const long total = std::isfinite(seconds) ? std::lround(std::max(seconds, 0.0)) : 0;
  const long h = total / 3600, m = (total % 3600) / 60, s = total % 60;
  std::string out;
  if (h > 0) out += std::to_string(h) + "h ";
  if (h > 0 || m > 0) out += std::to_string(m) + "m ";
  out += std::to_string(s) + "s";
  return out;
}

std::string format_duration(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0) return "—";
  const long total = std::lround(seconds);
  const long h = total / 3600, m = (total % 3600) / 60, s = total % 60;
  auto two = [](long v) { return (v < 10 ? "0" : "") + std::to_string(v); };
  if (h > 0) return std::to_string(h) + " h " + two(m) + " min";
  if (m > 0) return std::to_string(m) + " min " + two(s) + " s";
  return std::to_string(s) + " s";
}

}  // namespace printtwin
