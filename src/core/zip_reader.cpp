// Zip reading as the format's application note (PKWARE APPNOTE 6.3) describes it: the end
// of central directory record locates the central directory; each central entry gives the
// compression method, sizes, CRC-32 and the offset of the entry's local header, whose own
// name and extra fields are skipped to reach the data. Every offset is checked against the
// archive's size before it is read.
#include "core/zip_reader.hpp"

#include <zlib.h>

#include <cstdint>

namespace printtwin::detail {

namespace {

constexpr std::uint32_t kLocalHeader = 0x04034b50;
constexpr std::uint32_t kCentralHeader = 0x02014b50;
constexpr std::uint32_t kEndOfCentral = 0x06054b50;
constexpr std::uint32_t kZip64EndOfCentral = 0x06064b50;
constexpr std::uint32_t kZip64Locator = 0x07064b50;
constexpr std::size_t kEndOfCentralSize = 22;
constexpr std::size_t kMaxComment = 0xffff;
// An entry larger than this is neither a settings file nor a plate's G-code: refuse it
// rather than allocate it.
constexpr std::uint64_t kMaxEntryBytes = std::uint64_t{1} << 30;

std::uint64_t le(std::string_view b, std::size_t at, int bytes) {
  std::uint64_t v = 0;
  for (int i = bytes - 1; i >= 0; --i)
    v = (v << 8) | static_cast<unsigned char>(b[at + static_cast<std::size_t>(i)]);
  return v;
}

struct CentralDirectory {
  std::uint64_t offset = 0;
  std::uint64_t size = 0;
  std::uint64_t entries = 0;
};

struct Entry {
  std::uint16_t flags = 0;
  std::uint16_t method = 0;
  std::uint32_t crc = 0;
  std::uint64_t compressed = 0;
  std::uint64_t uncompressed = 0;
  std::uint64_t local_offset = 0;
};

Error damaged(const std::string& source, const std::string& what) {
  return bad_input("not a readable zip archive: " + what, source);
}

Result<CentralDirectory> find_central_directory(std::string_view a, const std::string& source) {
  if (a.size() < kEndOfCentralSize) return damaged(source, "too short for an end record");
  const std::size_t lowest =
      a.size() > kEndOfCentralSize + kMaxComment ? a.size() - kEndOfCentralSize - kMaxComment : 0;
  for (std::size_t at = a.size() - kEndOfCentralSize + 1; at-- > lowest;) {
    if (le(a, at, 4) != kEndOfCentral) continue;
    if (at + kEndOfCentralSize + le(a, at + 20, 2) != a.size()) continue;  // comment length
    CentralDirectory cd{le(a, at + 16, 4), le(a, at + 12, 4), le(a, at + 10, 2)};
    const bool zip64 = cd.offset == 0xffffffff || cd.size == 0xffffffff || cd.entries == 0xffff;
    if (zip64) {
      if (at < 20 || le(a, at - 20, 4) != kZip64Locator)
        return damaged(source, "ZIP64 sizes without a ZIP64 locator");
      const std::uint64_t rec = le(a, at - 20 + 8, 8);
      if (rec > a.size() || a.size() - rec < 56 || le(a, rec, 4) != kZip64EndOfCentral)
        return damaged(source, "the ZIP64 end record is out of the file");
      cd = {le(a, rec + 48, 8), le(a, rec + 40, 8), le(a, rec + 32, 8)};
    }
    if (cd.offset > a.size() || cd.size > a.size() - cd.offset)
      return damaged(source, "the central directory lies outside the file");
    return cd;
  }
  return damaged(source, "no end of central directory record");
}

// The ZIP64 extended information extra field replaces the 32-bit fields that are 0xffffffff,
// in the order uncompressed, compressed, local offset.
void apply_zip64_extra(std::string_view extra, Entry& e) {
  for (std::size_t at = 0; at + 4 <= extra.size();) {
    const std::uint64_t id = le(extra, at, 2);
    const std::size_t len = le(extra, at + 2, 2);
    if (at + 4 + len > extra.size()) return;
    if (id == 0x0001) {
      std::size_t p = at + 4;
      auto take = [&](std::uint64_t& field) {
        if (field != 0xffffffff || p + 8 > at + 4 + len) return;
        field = le(extra, p, 8);
        p += 8;
      };
      take(e.uncompressed);
      take(e.compressed);
      take(e.local_offset);
      return;
    }
    at += 4 + len;
  }
}

Result<std::string> inflate_raw(std::string_view data, std::uint64_t size,
                                const std::string& source, std::string_view name) {
  std::string out(static_cast<std::size_t>(size), '\0');
  z_stream zs{};
  if (inflateInit2(&zs, -MAX_WBITS) != Z_OK) return internal_error("zlib: inflateInit2 failed");
  zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data.data()));
  zs.avail_in = static_cast<uInt>(data.size());
  zs.next_out = reinterpret_cast<Bytef*>(out.data());
  zs.avail_out = static_cast<uInt>(out.size());
  const int rc = inflate(&zs, Z_FINISH);
  const std::uint64_t produced = zs.total_out;
  inflateEnd(&zs);
  if (rc != Z_STREAM_END || produced != size)
    return damaged(source, "entry " + std::string(name) + " does not inflate to its stated " +
                               std::to_string(size) + " bytes");
  return out;
}

}  // namespace

bool looks_like_zip(std::string_view bytes) {
  return bytes.size() >= 4 && (le(bytes, 0, 4) == kLocalHeader || le(bytes, 0, 4) == kEndOfCentral);
}

namespace {

/// Walks the central directory: visit(name, at) for each entry (at = its record's offset)
/// until visit returns true. Returns whether it did.
template <class Visit>
Result<bool> walk_directory(std::string_view a, const std::string& source, Visit visit) {
  auto cd = find_central_directory(a, source);
  if (!cd) return cd.error();
  std::size_t at = static_cast<std::size_t>(cd->offset);
  const std::size_t end = static_cast<std::size_t>(cd->offset + cd->size);
  for (std::uint64_t i = 0; i < cd->entries; ++i) {
    if (end - at < 46 || le(a, at, 4) != kCentralHeader)
      return damaged(source, "central directory entry " + std::to_string(i + 1) + " is cut short");
    const std::size_t name_len = le(a, at + 28, 2);
    const std::size_t extra_len = le(a, at + 30, 2);
    const std::size_t comment_len = le(a, at + 32, 2);
    if (end - at - 46 < name_len + extra_len + comment_len)
      return damaged(source, "central directory entry " + std::to_string(i + 1) + " is cut short");
    if (visit(a.substr(at + 46, name_len), at)) return true;
    at += 46 + name_len + extra_len + comment_len;
  }
  return false;
}

}  // namespace

Result<std::vector<std::string>> zip_entry_names(std::string_view a, const std::string& source) {
  std::vector<std::string> names;
  auto walked = walk_directory(a, source, [&](std::string_view name, std::size_t /*at*/) {
    names.emplace_back(name);
    return false;
  });
  if (!walked) return walked.error();
  return names;
}

Result<std::optional<std::string>> zip_entry(std::string_view a, std::string_view name,
                                             const std::string& source) {
  std::size_t at = 0;
  auto found = walk_directory(a, source, [&](std::string_view entry_name, std::size_t record) {
    at = record;
    return entry_name == name;
  });
  if (!found) return found.error();
  if (!*found) return std::optional<std::string>{};
  const std::size_t name_len = le(a, at + 28, 2);
  const std::size_t extra_len = le(a, at + 30, 2);
  Entry e;
  e.flags = static_cast<std::uint16_t>(le(a, at + 8, 2));
  e.method = static_cast<std::uint16_t>(le(a, at + 10, 2));
  e.crc = static_cast<std::uint32_t>(le(a, at + 16, 4));
  e.compressed = le(a, at + 20, 4);
  e.uncompressed = le(a, at + 24, 4);
  e.local_offset = le(a, at + 42, 4);
  apply_zip64_extra(a.substr(at + 46 + name_len, extra_len), e);
  const std::string what = "entry " + std::string(name);
  if ((e.flags & 1U) != 0) return damaged(source, what + " is encrypted");
  if (e.uncompressed > kMaxEntryBytes)
    return damaged(source, what + " states " + std::to_string(e.uncompressed) + " bytes");
  const std::uint64_t lh = e.local_offset;
  if (lh > a.size() || a.size() - lh < 30 || le(a, lh, 4) != kLocalHeader)
    return damaged(source, what + ": its local header is missing");
  const std::uint64_t data_at = lh + 30 + le(a, lh + 26, 2) + le(a, lh + 28, 2);
  if (data_at > a.size() || e.compressed > a.size() - data_at)
    return damaged(source, what + ": its data runs past the end of the file");
  const std::string_view data =
      a.substr(static_cast<std::size_t>(data_at), static_cast<std::size_t>(e.compressed));
  std::string out;
  if (e.method == 0) {
    if (e.compressed != e.uncompressed)
      return damaged(source, what + " is stored with two different sizes");
    out.assign(data);
  } else if (e.method == 8) {
    auto inflated = inflate_raw(data, e.uncompressed, source, name);
    if (!inflated) return inflated.error();
    out = std::move(*inflated);
  } else {
    return damaged(source, what + " uses compression method " + std::to_string(e.method) +
                               " (only stored and deflate are read)");
  }
  const auto crc = static_cast<std::uint32_t>(
      crc32(0L, reinterpret_cast<const Bytef*>(out.data()), static_cast<uInt>(out.size())));
  if (crc != e.crc) return damaged(source, what + " fails its CRC-32 check");
  return std::optional<std::string>(std::move(out));
}

}  // namespace printtwin::detail
