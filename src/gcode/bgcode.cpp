// PrusaSlicer's binary G-code v1: block reader, metadata and the G-code text stream.
// Format and limits: include/printtwin/bgcode.hpp.
#include "printtwin/bgcode.hpp"

#include <libdeflate.h>
#include <zlib.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <fstream>
#include <streambuf>

#include "core/plain_path.hpp"
#include "gcode/heatshrink.hpp"
#include "gcode/meatpack.hpp"

namespace printtwin {

namespace {

constexpr std::string_view kMagic = "GCDE";
constexpr std::size_t kFileHeaderBytes = 10;
constexpr std::uint16_t kLastBlockType = 5;
constexpr std::uint16_t kLastCompression = 3;

std::uint16_t le16(const unsigned char* p) {
  return static_cast<std::uint16_t>(p[0] | (p[1] << 8));
}
std::uint32_t le32(const unsigned char* p) {
  return static_cast<std::uint32_t>(p[0]) | (static_cast<std::uint32_t>(p[1]) << 8) |
         (static_cast<std::uint32_t>(p[2]) << 16) | (static_cast<std::uint32_t>(p[3]) << 24);
}

std::string hex32(std::uint32_t v) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string s = "0x";
  for (int shift = 28; shift >= 0; shift -= 4) s.push_back(kDigits[(v >> shift) & 15u]);
  return s;
}

/// The bytes as text, non-printable ones as \xNN (for "it starts with ..." messages).
std::string printable(std::string_view bytes) {
  static constexpr char kDigits[] = "0123456789ABCDEF";
  std::string s;
  for (char c : bytes) {
    const auto u = static_cast<unsigned char>(c);
    if (u >= 0x20 && u < 0x7F && c != '\\' && c != '"') {
      s.push_back(c);
    } else {
      s += "\\x";
      s.push_back(kDigits[u >> 4]);
      s.push_back(kDigits[u & 15u]);
    }
  }
  return s;
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t' || s.front() == '\r'))
    s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r'))
    s.remove_suffix(1);
  return s;
}

/// libdeflate inflates and computes CRC32 (carry-less multiply) 2-3x faster than zlib: it
/// cuts the fixed cost of opening a file, whose deflated slicer settings are most of it.
/// zlib is its plain twin (PRINTTWIN_PLAIN=bgcode_libdeflate, core/plain_path.hpp) and the
/// fuzz target's cross-check: both must accept and reject the same blocks.
bool use_libdeflate() { return !detail::plain_path("bgcode_libdeflate"); }

std::uint32_t crc32_of(bool fast, std::uint32_t crc, const void* data, std::size_t n) {
  if (fast) return libdeflate_crc32(crc, data, n);
  const auto* p = static_cast<const Bytef*>(data);
  while (n > 0) {  // zlib takes uInt lengths
    const auto chunk = static_cast<uInt>(std::min<std::size_t>(n, 1u << 30));
    crc = static_cast<std::uint32_t>(::crc32(crc, p, chunk));
    p += chunk;
    n -= chunk;
  }
  return crc;
}

/// One libdeflate decompressor per thread (it holds ~30 KB of tables; not thread-safe).
libdeflate_decompressor* thread_decompressor() {
  struct Holder {
    libdeflate_decompressor* d = libdeflate_alloc_decompressor();
    Holder() = default;
    Holder(const Holder&) = delete;
    Holder& operator=(const Holder&) = delete;
    ~Holder() { libdeflate_free_decompressor(d); }
  };
  thread_local Holder holder;
  return holder.d;
}

/// Inflates the zlib stream `in` into `out`, which has room for exactly `expected` bytes.
/// Empty on success, else what is wrong (the same words from either library).
std::string inflate_block(bool fast, std::string_view in, char* out, std::size_t expected) {
  const auto too_long = [expected] {
    return "deflate data decodes to more than the " + std::to_string(expected) +
           " bytes the block header states";
  };
  std::size_t produced = 0, consumed = 0;
  unsigned char dummy = 0;
  void* const dst = expected > 0 ? static_cast<void*>(out) : &dummy;
  if (fast) {
    libdeflate_decompressor* d = thread_decompressor();
    if (d == nullptr) return "deflate data cannot be decoded (out of memory)";
    switch (libdeflate_zlib_decompress_ex(d, in.data(), in.size(), dst, expected, &consumed,
                                          &produced)) {
      case LIBDEFLATE_SUCCESS:
        break;
      case LIBDEFLATE_INSUFFICIENT_SPACE:
        return too_long();
      default:
        return "deflate data is corrupt (invalid or incomplete data)";
    }
  } else {
    uLongf out_len = static_cast<uLongf>(expected);
    uLong in_len = static_cast<uLong>(in.size());
    const int rc = ::uncompress2(static_cast<Bytef*>(dst), &out_len,
                                 reinterpret_cast<const Bytef*>(in.data()), &in_len);
    if (rc == Z_BUF_ERROR) return too_long();
    if (rc != Z_OK)
      return rc == Z_MEM_ERROR ? "deflate data cannot be decoded (out of memory)"
                               : "deflate data is corrupt (invalid or incomplete data)";
    produced = out_len;
    consumed = in_len;
  }
  if (produced != expected)
    return "deflate data decodes to " + std::to_string(produced) +
           " bytes, the block header states " + std::to_string(expected);
  if (consumed != in.size())
    return std::to_string(in.size() - consumed) + " bytes follow the end of the deflate stream";
  return {};
}

/// Reads blocks one after the other from a seekable byte stream of known size, or from
/// bytes in memory (then the stored data is a view of them, never copied).
class BlockReader {
 public:
  BlockReader(std::istream& in, std::uint64_t size, std::string name)
      : in_(&in), size_(size), name_(std::move(name)) {}
  BlockReader(std::string_view memory, std::string name)
      : memory_(memory), size_(memory.size()), name_(std::move(name)) {}

  const std::string& name() const { return name_; }

  Status read_file_header(BgcodeMetadata& meta) {
    std::array<unsigned char, kFileHeaderBytes> h{};
    const auto got = read_at(0, h.data(), h.size());
    const std::string_view head(reinterpret_cast<const char*>(h.data()),
                                std::min<std::size_t>(got, 4));
    if (got < 4 || head != kMagic)
      return bad_input("not a binary G-code file: it starts with \"" + printable(head) +
                           "\" where \"GCDE\" was expected",
                       name_);
    if (got < h.size())
      return bad_input("binary G-code file header cut short: " + std::to_string(kFileHeaderBytes) +
                           " bytes expected, the file has " + std::to_string(got),
                       name_);
    meta.version = le32(h.data() + 4);
    if (meta.version != 1)
      return bad_input("binary G-code version " + std::to_string(meta.version) +
                           " is not supported (printtwin reads version 1)",
                       name_);
    const std::uint16_t checksum = le16(h.data() + 8);
    if (checksum > 1)
      return bad_input("unknown checksum type " + std::to_string(checksum) +
                           " in the binary G-code file header (expected 0 = none or 1 = CRC32)",
                       name_);
    meta.crc32 = checksum == 1;
    crc_ = meta.crc32;
    offset_ = kFileHeaderBytes;
    index_ = 0;
    return Ok{};
  }

  /// Moves to the block header at `offset`, which is block number `index` (1-based). When
  /// that is the block just read, the next next() gives it again without reading it (or
  /// checking its CRC) a second time.
  void seek(std::uint64_t offset, int index) {
    again_ = loaded_ && offset == info_.offset && index == info_.index;
    offset_ = offset;
    index_ = index - 1;
  }
  std::uint64_t offset() const { return offset_; }

  /// Reads the next block's header, parameters and stored data and checks its CRC.
  /// False at the end of the file.
  Result<bool> next() {
    if (again_) {
      again_ = false;
      offset_ = loaded_end_;
      index_ = info_.index;
      return true;
    }
    loaded_ = false;
    if (offset_ >= size_) return false;
    info_ = {};
    info_.index = ++index_;
    info_.offset = offset_;
    std::array<unsigned char, 12> h{};
    const std::uint64_t left = size_ - offset_;
    if (left < 8)
      return error("truncated inside the block header (" + std::to_string(left) + " of 8 bytes)",
                   false);
    if (read_at(offset_, h.data(), 8) != 8) return io_error();
    const std::uint16_t type = le16(h.data());
    const std::uint16_t compression = le16(h.data() + 2);
    const std::uint32_t uncompressed = le32(h.data() + 4);
    if (type > kLastBlockType)
      return error("unknown block type " + std::to_string(type) +
                       " (expected 0-5: file metadata, G-code, slicer metadata, printer metadata, "
                       "print metadata, "
                       "thumbnail)",
                   false);
    info_.type = static_cast<BgcodeBlockType>(type);
    if (compression > kLastCompression)
      return error(
          "unknown compression " + std::to_string(compression) +
              " (expected 0 = none, 1 = deflate, 2 = heatshrink 11/4, 3 = heatshrink 12/4)",
          true);
    info_.compression = static_cast<BgcodeCompression>(compression);
    const std::size_t header_bytes = compression == 0 ? 8 : 12;
    if (left < header_bytes)
      return error("truncated inside the block header (" + std::to_string(left) + " of " +
                       std::to_string(header_bytes) + " bytes)",
                   true);
    if (header_bytes == 12 && read_at(offset_ + 8, h.data() + 8, 4) != 4) return io_error();
    info_.data_bytes = uncompressed;
    info_.stored_bytes = compression == 0 ? uncompressed : le32(h.data() + 8);
    params_bytes_ = info_.type == BgcodeBlockType::thumbnail ? 6 : 2;
    const std::uint64_t crc_bytes = crc_ ? 4 : 0;
    const std::uint64_t need = header_bytes + params_bytes_ + info_.stored_bytes + crc_bytes;
    if (need > left)
      return error("truncated: the block needs " + std::to_string(need) + " bytes (header " +
                       std::to_string(header_bytes) + ", parameters " +
                       std::to_string(params_bytes_) + ", data " +
                       std::to_string(info_.stored_bytes) + ", checksum " +
                       std::to_string(crc_bytes) + "), the file ends " + std::to_string(left) +
                       " bytes after the block's start",
                   true);
    if (info_.data_bytes > kMaxBgcodeBlockBytes || info_.stored_bytes > kMaxBgcodeBlockBytes)
      return error("the block states " +
                       std::to_string(std::max(info_.data_bytes, info_.stored_bytes)) +
                       " bytes of data, more than the " + std::to_string(kMaxBgcodeBlockBytes) +
                       " printtwin accepts in one block",
                   true);
    if (read_at(offset_ + header_bytes, params_.data(), params_bytes_) != params_bytes_)
      return io_error();
    const std::uint64_t data_at = offset_ + header_bytes + params_bytes_;
    if (in_ == nullptr) {
      stored_view_ = memory_.substr(static_cast<std::size_t>(data_at), info_.stored_bytes);
    } else {
      stored_.resize(info_.stored_bytes);
      if (read_at(data_at, stored_.data(), stored_.size()) != stored_.size()) return io_error();
      stored_view_ = std::string_view(stored_.data(), stored_.size());
    }
    if (crc_) {
      std::array<unsigned char, 4> c{};
      if (read_at(offset_ + header_bytes + params_bytes_ + info_.stored_bytes, c.data(), 4) != 4)
        return io_error();
      std::uint32_t crc = crc32_of(fast_, 0, h.data(), header_bytes);
      crc = crc32_of(fast_, crc, params_.data(), params_bytes_);
      crc = crc32_of(fast_, crc, stored_view_.data(), stored_view_.size());
      if (crc != le32(c.data()))
        return error("CRC32 mismatch (stored " + hex32(le32(c.data())) + ", computed " +
                         hex32(crc) + "): the block is corrupt",
                     true);
    }
    offset_ += need;
    loaded_ = true;
    loaded_end_ = offset_;
    return true;
  }

  const BgcodeBlockInfo& info() const { return info_; }
  /// The first 16-bit parameter (encoding, or image format for thumbnails).
  std::uint16_t param(int i) const { return le16(params_.data() + 2 * i); }

  /// The block's data, decompressed into `scratch` (or the stored bytes when not compressed).
  Result<std::string_view> data(detail::Bytes& scratch) {
    const std::size_t expected = info_.data_bytes;
    std::string why;
    switch (info_.compression) {
      case BgcodeCompression::none:
        return stored_view_;
      case BgcodeCompression::deflate: {
        // Deflate expands at most about 1032:1: reject impossible sizes before allocating.
        if (expected / 1032 > stored_view_.size() + 1)
          return error("deflate data cannot expand to the " + std::to_string(expected) +
                           " bytes the block header states",
                       true)
              .error();
        scratch.resize(expected);
        if (auto wrong = inflate_block(fast_, stored_view_, scratch.data(), expected);
            !wrong.empty())
          return error(wrong, true).error();
        return std::string_view(scratch.data(), scratch.size());
      }
      case BgcodeCompression::heatshrink_11_4:
      case BgcodeCompression::heatshrink_12_4: {
        const int window = info_.compression == BgcodeCompression::heatshrink_11_4 ? 11 : 12;
        if (expected / detail::heatshrink_max_expansion(window, 4) > stored_view_.size() + 1)
          return error("heatshrink data cannot expand to the " + std::to_string(expected) +
                           " bytes the block header states",
                       true)
              .error();
        if (!detail::heatshrink_decode(stored_view_, window, 4, expected, scratch, why))
          return error(why, true).error();
        return std::string_view(scratch.data(), scratch.size());
      }
    }
    return error("unknown compression", true).error();
  }

  /// "block 3 (thumbnail, deflate) at byte 996: <what>" as a bad-input error.
  Result<bool> error(const std::string& what, bool type_known) const {
    std::string where = "block " + std::to_string(info_.index);
    if (type_known) {
      where += " (" + std::string(bgcode_block_type_name(info_.type));
      if (info_.compression != BgcodeCompression::none)
        where += ", " + std::string(bgcode_compression_name(info_.compression));
      where += ")";
    }
    return bad_input(where + " at byte " + std::to_string(info_.offset) + ": " + what, name_);
  }

 private:
  std::size_t read_at(std::uint64_t offset, void* dst, std::size_t n) {
    if (n == 0 || offset >= size_) return 0;
    if (in_ == nullptr) {
      n = std::min<std::size_t>(n, static_cast<std::size_t>(size_ - offset));
      std::memcpy(dst, memory_.data() + offset, n);
      return n;
    }
    in_->clear();
    in_->seekg(static_cast<std::streamoff>(offset));
    in_->read(static_cast<char*>(dst), static_cast<std::streamsize>(n));
    return static_cast<std::size_t>(in_->gcount());
  }
  Result<bool> io_error() const {
    return error("read error (the file changed or cannot be read)", false);
  }

  std::istream* in_ = nullptr;  ///< the file, or null when reading `memory_`
  std::string_view memory_;
  std::uint64_t size_;
  std::string name_;
  bool fast_ = use_libdeflate();  ///< libdeflate, else zlib (the plain twin)
  bool crc_ = true;
  bool loaded_ = false;  ///< info_, params_ and the stored data are those of a whole block
  bool again_ = false;   ///< next() gives the loaded block again
  std::uint64_t loaded_end_ = 0;
  std::uint64_t offset_ = 0;
  int index_ = 0;
  BgcodeBlockInfo info_;
  std::array<unsigned char, 6> params_{};
  std::size_t params_bytes_ = 2;
  detail::Bytes stored_;          ///< the stored data read from the file
  std::string_view stored_view_;  ///< the stored data of the current block
};

/// Calls `pair(key, value)` for each `key=value` line of metadata `text` (key and value
/// trimmed of spaces; empty lines skipped). An error names the first line without '='.
template <class Pair>
Status for_each_ini_pair(std::string_view text, const BlockReader& reader, Pair&& pair) {
  std::size_t line_no = 0;
  while (!text.empty()) {
    const auto nl = text.find('\n');
    const std::string_view line = trim(text.substr(0, nl));
    text = nl == std::string_view::npos ? std::string_view() : text.substr(nl + 1);
    ++line_no;
    if (line.empty()) continue;
    const auto eq = line.find('=');
    if (eq == std::string_view::npos)
      return reader
          .error("line " + std::to_string(line_no) +
                     " has no '=' (metadata is key=value lines): \"" +
                     printable(line.substr(0, 60)) + "\"",
                 true)
          .error();
    pair(trim(line.substr(0, eq)), trim(line.substr(eq + 1)));
  }
  return Ok{};
}

Status parse_ini(std::string_view text, BgcodeKeyValues& out, const BlockReader& reader) {
  out.reserve(out.size() + static_cast<std::size_t>(std::count(text.begin(), text.end(), '\n')) +
              1);
  return for_each_ini_pair(text, reader, [&](std::string_view key, std::string_view value) {
    out.emplace_back(std::string(key), std::string(value));
  });
}

/// Appends `; key = value` lines, the way a text G-code file states settings.
void append_comment_line(std::string& out, std::string_view key, std::string_view value) {
  out.append("; ", 2).append(key).append(" = ", 3).append(value).push_back('\n');
}

/// What read_metadata() does with the slicer metadata block. The G-code stream wants it
/// as the text file's config block, not as pairs: when `slicer_config` is given, each
/// setting goes there as a `; key = value` line, the block's INI text to `slicer_ini`, and
/// meta.slicer stays empty - the ~300 settings are never copied into strings of their own
/// (the stream's metadata() parses `slicer_ini` when asked). Else they go to meta.slicer.
struct MetadataSinks {
  std::string* slicer_config = nullptr;
  std::string* slicer_ini = nullptr;
};

/// Reads a metadata or thumbnail block (the reader stands on it) into `meta`.
Status store_metadata_block(BlockReader& reader, BgcodeMetadata& meta, detail::Bytes& scratch,
                            const MetadataSinks& sinks) {
  const BgcodeBlockInfo& info = reader.info();
  if (info.type == BgcodeBlockType::thumbnail) {
    const std::uint16_t format = reader.param(0);
    if (format > 2)
      return reader
          .error("unknown thumbnail image format " + std::to_string(format) +
                     " (expected 0 = PNG, 1 = JPG, 2 = QOI)",
                 true)
          .error();
    auto data = reader.data(scratch);
    if (!data) return data.error();
    BgcodeThumbnail t;
    t.format = static_cast<BgcodeImageFormat>(format);
    t.width = reader.param(1);
    t.height = reader.param(2);
    t.bytes = std::string(*data);
    meta.thumbnails.push_back(std::move(t));
  } else {
    if (const std::uint16_t encoding = reader.param(0); encoding != 0)
      return reader
          .error("unknown metadata encoding " + std::to_string(encoding) + " (expected 0 = INI)",
                 true)
          .error();
    auto data = reader.data(scratch);
    if (!data) return data.error();
    if (info.type == BgcodeBlockType::slicer_metadata && sinks.slicer_config != nullptr) {
      std::string& config = *sinks.slicer_config;
      config.reserve(config.size() + data->size() + data->size() / 8 + 64);
      auto st = for_each_ini_pair(*data, reader, [&](std::string_view key, std::string_view value) {
        append_comment_line(config, key, value);
      });
      if (!st) return st;
      sinks.slicer_ini->append(*data);
      meta.blocks.push_back(info);
      return Ok{};
    }
    BgcodeKeyValues* target = info.type == BgcodeBlockType::file_metadata      ? &meta.file
                              : info.type == BgcodeBlockType::printer_metadata ? &meta.printer
                              : info.type == BgcodeBlockType::print_metadata   ? &meta.print
                                                                               : &meta.slicer;
    if (auto st = parse_ini(*data, *target, reader); !st) return st;
  }
  meta.blocks.push_back(info);
  return Ok{};
}

/// Reads the file header and the blocks before the first G-code block; leaves the reader
/// on that G-code block (read, CRC checked, not decoded).
Result<BgcodeMetadata> read_metadata(BlockReader& reader, const MetadataSinks& sinks = {}) {
  BgcodeMetadata meta;
  if (auto st = reader.read_file_header(meta); !st) return st.error();
  detail::Bytes scratch;
  for (;;) {
    auto more = reader.next();
    if (!more) return more.error();
    if (!*more)
      return bad_input("the binary G-code has no G-code block: the file ends after block " +
                           std::to_string(meta.blocks.size()) + " (byte " +
                           std::to_string(reader.offset()) + ")",
                       reader.name());
    if (reader.info().type == BgcodeBlockType::gcode) {
      meta.first_gcode_block_offset = reader.info().offset;
      return meta;
    }
    if (auto st = store_metadata_block(reader, meta, scratch, sinks); !st) return st.error();
  }
}

std::uint64_t stream_size(std::istream& in) {
  in.seekg(0, std::ios::end);
  const auto end = in.tellg();
  in.clear();
  in.seekg(0);
  return end < 0 ? 0 : static_cast<std::uint64_t>(end);
}

void append_pairs(std::string& out, const BgcodeKeyValues& pairs) {
  std::size_t bytes = out.size();
  for (const auto& [key, value] : pairs) bytes += key.size() + value.size() + 6;
  out.reserve(bytes);
  for (const auto& [key, value] : pairs) append_comment_line(out, key, value);
}

}  // namespace

std::string_view bgcode_block_type_name(BgcodeBlockType type) {
  switch (type) {
    case BgcodeBlockType::file_metadata:
      return "file metadata";
    case BgcodeBlockType::gcode:
      return "G-code";
    case BgcodeBlockType::slicer_metadata:
      return "slicer metadata";
    case BgcodeBlockType::printer_metadata:
      return "printer metadata";
    case BgcodeBlockType::print_metadata:
      return "print metadata";
    case BgcodeBlockType::thumbnail:
      return "thumbnail";
  }
  return "unknown";
}

std::string_view bgcode_compression_name(BgcodeCompression compression) {
  switch (compression) {
    case BgcodeCompression::none:
      return "none";
    case BgcodeCompression::deflate:
      return "deflate";
    case BgcodeCompression::heatshrink_11_4:
      return "heatshrink 11/4";
    case BgcodeCompression::heatshrink_12_4:
      return "heatshrink 12/4";
  }
  return "unknown";
}

std::string_view bgcode_image_format_name(BgcodeImageFormat format) {
  switch (format) {
    case BgcodeImageFormat::png:
      return "PNG";
    case BgcodeImageFormat::jpg:
      return "JPG";
    case BgcodeImageFormat::qoi:
      return "QOI";
  }
  return "unknown";
}

std::optional<std::string_view> bgcode_find(const BgcodeKeyValues& pairs, std::string_view key) {
  for (const auto& [k, v] : pairs)
    if (k == key) return std::string_view(v);
  return std::nullopt;
}

bool looks_like_bgcode(std::string_view head) { return head.substr(0, kMagic.size()) == kMagic; }

bool is_bgcode_input(std::string_view head, const std::filesystem::path& name) {
  if (looks_like_bgcode(head)) return true;
  std::string ext = name.extension().string();
  for (char& c : ext) c = static_cast<char>(c >= 'A' && c <= 'Z' ? c - 'A' + 'a' : c);
  return ext == ".bgcode";
}

bool is_bgcode_file(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return false;
  std::ifstream in(path, std::ios::binary);
  std::array<char, 4> head{};
  in.read(head.data(), head.size());
  return is_bgcode_input(std::string_view(head.data(), static_cast<std::size_t>(in.gcount())),
                         path);
}

Result<BgcodeMetadata> read_bgcode_metadata(std::string_view bytes, const std::string& name) {
  BlockReader reader(bytes, name);
  return read_metadata(reader);
}

Result<BgcodeMetadata> read_bgcode_metadata(const std::filesystem::path& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    return bad_input("is a directory, expected a binary G-code file", path.string());
  std::ifstream in(path, std::ios::binary);
  if (!in) return bad_input("cannot open binary G-code file", path.string());
  BlockReader reader(in, stream_size(in), path.string());
  return read_metadata(reader);
}

// ---------------------------------------------------------------------------------------
// The G-code text stream: the header comments, each G-code block decoded in turn, then the
// slicer's settings. The get area holds one of these chunks at a time.

class BgcodeStreamBuf final : public std::streambuf {
 public:
  /// Over a file (owned).
  BgcodeStreamBuf(std::unique_ptr<std::istream> file, std::uint64_t size, const std::string& name)
      : file_(std::move(file)), reader_(*file_, size, name) {}
  /// Over bytes in memory (not owned).
  BgcodeStreamBuf(std::string_view bytes, const std::string& name) : reader_(bytes, name) {}

  Status open() {
    constexpr std::string_view kBegin = "; prusaslicer_config = begin\n";
    trailer_ = kBegin;
    auto meta = read_metadata(reader_, MetadataSinks{&trailer_, &slicer_ini_});
    if (!meta) return meta.error();
    meta_ = std::move(*meta);
    if (auto producer = bgcode_find(meta_.file, "Producer")) {
      header_ = "; generated by " + std::string(*producer);
      if (auto on = bgcode_find(meta_.file, "Produced on")) header_ += " on " + std::string(*on);
      header_ += '\n';
    }
    append_pairs(header_, meta_.printer);
    append_pairs(header_, meta_.print);
    if (trailer_.size() > kBegin.size())
      trailer_ += "; prusaslicer_config = end\n";
    else
      trailer_.clear();
    first_gcode_index_ = reader_.info().index;
    rewind();
    return Ok{};
  }

  const BgcodeMetadata& metadata() const {
    if (!slicer_ini_.empty() && meta_.slicer.empty())  // checked on opening: cannot fail
      (void)parse_ini(slicer_ini_, meta_.slicer, reader_);
    return meta_;
  }
  const std::optional<Error>& error() const { return error_; }
  std::size_t gcode_blocks_read() const { return gcode_blocks_read_; }

 protected:
  int_type underflow() override {
    while (gptr() == egptr()) {
      if (!next_chunk()) return traits_type::eof();
    }
    return traits_type::to_int_type(*gptr());
  }

  pos_type seekoff(off_type off, std::ios_base::seekdir dir,
                   std::ios_base::openmode which) override {
    if (error_ || (which & std::ios_base::in) == 0) return fail();
    off_type base = 0;
    if (dir == std::ios_base::cur) {
      base = static_cast<off_type>(chunk_start_) + (gptr() - eback());
    } else if (dir == std::ios_base::end) {
      while (next_chunk()) {}
      if (error_) return fail();
      base = static_cast<off_type>(chunk_start_);
    }
    if (dir == std::ios_base::cur && off == 0) return pos_type(base);
    return seekpos(pos_type(base + off), which);
  }

  pos_type seekpos(pos_type pos, std::ios_base::openmode which) override {
    const off_type target = off_type(pos);
    if (error_ || target < 0 || (which & std::ios_base::in) == 0) return fail();
    const auto t = static_cast<std::uint64_t>(target);
    if (t < chunk_start_) rewind();
    for (;;) {
      const auto size = static_cast<std::uint64_t>(egptr() - eback());
      if (t < chunk_start_ + size) {
        setg(eback(), eback() + (t - chunk_start_), egptr());
        return pos;
      }
      if (!next_chunk()) {
        if (!error_ && t == chunk_start_) return pos;
        return fail();
      }
    }
  }

 private:
  enum class Phase { header, gcode, trailer, done };

  static pos_type fail() { return pos_type(off_type(-1)); }

  void rewind() {
    reader_.seek(meta_.first_gcode_block_offset, first_gcode_index_);
    phase_ = Phase::header;
    chunk_start_ = 0;
    last_char_ = '\n';
    setg(nullptr, nullptr, nullptr);
  }

  void show(char* p, std::size_t n) {
    setg(p, p, p + n);
    if (n > 0) last_char_ = p[n - 1];
  }
  void show(std::string& chunk) { show(chunk.data(), chunk.size()); }

  /// Moves to the next chunk of text (possibly empty). False at the end or on an error.
  bool next_chunk() {
    chunk_start_ += static_cast<std::uint64_t>(egptr() - eback());
    setg(nullptr, nullptr, nullptr);
    switch (phase_) {
      case Phase::header:
        phase_ = Phase::gcode;
        show(header_);
        return true;
      case Phase::gcode: {
        auto more = reader_.next();
        if (!more) return stop(more.error());
        if (!*more) {
          phase_ = Phase::trailer;
          chunk_.clear();
          if (!trailer_.empty()) {
            if (last_char_ != '\n') chunk_ += '\n';
            chunk_ += trailer_;
          }
          show(chunk_);
          return true;
        }
        if (reader_.info().type != BgcodeBlockType::gcode)
          return stop(
              reader_
                  .error("a " + std::string(bgcode_block_type_name(reader_.info().type)) +
                             " block after the G-code blocks (the format puts every metadata block "
                             "before the G-code)",
                         true)
                  .error());
        const std::uint16_t encoding = reader_.param(0);
        if (encoding > 2)
          return stop(
              reader_
                  .error("unknown G-code encoding " + std::to_string(encoding) +
                             " (expected 0 = none, 1 = MeatPack, 2 = MeatPack with comments)",
                         true)
                  .error());
        auto data = reader_.data(decompressed_);
        if (!data) return stop(data.error());
        ++gcode_blocks_read_;
        if (encoding == 0) {
          // The get area shows the data where it is (never written: no put area, and a
          // putback of another character fails instead of writing).
          show(const_cast<char*>(data->data()), data->size());
        } else {
          std::size_t size = 0;
          std::string why;
          if (!detail::meatpack_decode(*data, unpacked_, size, why, fast_meatpack_))
            return stop(reader_.error(why, true).error());
          show(unpacked_.data(), size);
        }
        return true;
      }
      case Phase::trailer:
        phase_ = Phase::done;
        return false;
      case Phase::done:
        return false;
    }
    return false;
  }

  bool stop(Error e) {
    error_ = std::move(e);
    phase_ = Phase::done;
    setg(nullptr, nullptr, nullptr);
    return false;
  }

  std::unique_ptr<std::istream> file_;
  BlockReader reader_;
  mutable BgcodeMetadata meta_;  ///< meta_.slicer filled from slicer_ini_ on first metadata()
  std::string slicer_ini_;
  std::string header_, trailer_, chunk_;
  detail::Bytes decompressed_, unpacked_;
  int first_gcode_index_ = 1;
  Phase phase_ = Phase::header;
  std::uint64_t chunk_start_ = 0;  ///< stream position of eback()
  char last_char_ = '\n';
  std::size_t gcode_blocks_read_ = 0;
  std::optional<Error> error_;
  /// MeatPack's table-driven loop, else its byte-at-a-time state machine alone (the plain
  /// twin: PRINTTWIN_PLAIN=bgcode_meatpack, core/plain_path.hpp).
  bool fast_meatpack_ = !detail::plain_path("bgcode_meatpack");
};

BgcodeGcodeStream::BgcodeGcodeStream(std::unique_ptr<BgcodeStreamBuf> buf)
    : std::istream(buf.get()), buf_(std::move(buf)) {}

BgcodeGcodeStream::~BgcodeGcodeStream() = default;

const BgcodeMetadata& BgcodeGcodeStream::metadata() const { return buf_->metadata(); }
const std::optional<Error>& BgcodeGcodeStream::error() const { return buf_->error(); }
std::size_t BgcodeGcodeStream::gcode_blocks_read() const { return buf_->gcode_blocks_read(); }

Result<std::unique_ptr<BgcodeGcodeStream>> BgcodeGcodeStream::open(
    const std::filesystem::path& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    return bad_input("is a directory, expected a G-code file", path.string());
  auto file = std::make_unique<std::ifstream>(path, std::ios::binary);
  if (!*file) return bad_input("cannot open G-code file", path.string());
  const std::uint64_t size = stream_size(*file);
  auto buf = std::make_unique<BgcodeStreamBuf>(std::move(file), size, path.string());
  if (auto st = buf->open(); !st) return st.error();
  return std::unique_ptr<BgcodeGcodeStream>(new BgcodeGcodeStream(std::move(buf)));
}

Result<std::unique_ptr<BgcodeGcodeStream>> BgcodeGcodeStream::from_memory(std::string_view bytes,
                                                                          const std::string& name) {
  auto buf = std::make_unique<BgcodeStreamBuf>(bytes, name);
  if (auto st = buf->open(); !st) return st.error();
  return std::unique_ptr<BgcodeGcodeStream>(new BgcodeGcodeStream(std::move(buf)));
}

Result<std::string> decode_bgcode(std::string_view bytes, const std::string& name) {
  auto stream = BgcodeGcodeStream::from_memory(bytes, name);
  if (!stream) return stream.error();
  std::string text;
  std::array<char, 64 * 1024> chunk{};
  while ((*stream)->read(chunk.data(), chunk.size()) || (*stream)->gcount() > 0)
    text.append(chunk.data(), static_cast<std::size_t>((*stream)->gcount()));
  if ((*stream)->error()) return *(*stream)->error();
  return text;
}

}  // namespace printtwin
