// libFuzzer target: arbitrary bytes through the binary G-code reader (bgcode.hpp): file
// header, blocks, CRC32, deflate, heatshrink, MeatPack, metadata, and the seekable text
// stream. Besides crashes and sanitizer reports, it traps when the reader's answers
// disagree: the metadata reader and the stream must accept the same headers, an error must
// say something, and seeking must give back the bytes of a straight read. It also holds
// the fast paths to their references: libdeflate to zlib (PRINTTWIN_PLAIN=bgcode_libdeflate)
// on the whole file, and MeatPack's table-driven loop to its byte-at-a-time state machine
// (PRINTTWIN_PLAIN=bgcode_meatpack) on the raw bytes, also with packing switched on first;
// each pair must give the same text, or both an error.
// Seeds (fuzz/corpus_bgcode/) carry checksum type 0, so mutations reach the decoders
// instead of stopping at the CRC.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include "gcode/meatpack.hpp"
#include "printtwin/bgcode.hpp"

namespace {

/// MeatPack's fast loop and its reference give the same text, or both an error.
void meatpack_paths_agree(std::string_view bytes) {
  printtwin::detail::Bytes fast_buf, slow_buf;
  std::size_t fast_size = 0, slow_size = 0;
  std::string fast_why, slow_why;
  const bool fast = printtwin::detail::meatpack_decode(bytes, fast_buf, fast_size, fast_why, true);
  const bool slow = printtwin::detail::meatpack_decode(bytes, slow_buf, slow_size, slow_why, false);
  if (fast != slow || fast_why != slow_why) __builtin_trap();
  if (fast &&
      std::string_view(fast_buf.data(), fast_size) != std::string_view(slow_buf.data(), slow_size))
    __builtin_trap();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  auto meta = printtwin::read_bgcode_metadata(bytes, "fuzz.bgcode");
  auto text = printtwin::decode_bgcode(bytes, "fuzz.bgcode");
  // MeatPack on the raw bytes, and with packing switched on first (plain and "no spaces"),
  // so that the table-driven loop sees the bytes as packed data.
  meatpack_paths_agree(bytes);
  for (std::string_view prefix :
       {std::string_view("\xFF\xFF\xFB"), std::string_view("\xFF\xFF\xF7\xFF\xFF\xFB")})
    meatpack_paths_agree(std::string(prefix) + std::string(bytes));
  // zlib, the plain twin of libdeflate, accepts and decodes the same files.
  setenv("PRINTTWIN_PLAIN", "bgcode_libdeflate", 1);
  auto plain = printtwin::decode_bgcode(bytes, "fuzz.bgcode");
  unsetenv("PRINTTWIN_PLAIN");
  if (plain.ok() != text.ok() || (plain.ok() && *plain != *text)) __builtin_trap();
  if (!meta.ok() && meta.error().message.empty()) __builtin_trap();
  if (!text.ok()) {
    if (text.error().message.empty() || text.error().file != "fuzz.bgcode") __builtin_trap();
    return 0;
  }
  if (!meta.ok()) __builtin_trap();  // the stream read these same blocks first

  // Seeks: to the end, into the middle, back to the start.
  auto stream = printtwin::BgcodeGcodeStream::from_memory(bytes, "fuzz.bgcode");
  if (!stream.ok()) __builtin_trap();
  auto& in = **stream;
  in.seekg(0, std::ios::end);
  if (static_cast<std::size_t>(in.tellg()) != text->size()) __builtin_trap();
  for (std::size_t at : {text->size() / 2, std::size_t{0}, text->size() - text->size() / 3}) {
    in.clear();
    in.seekg(static_cast<std::streamoff>(at));
    char buf[64];
    in.read(buf, sizeof buf);
    const auto got = static_cast<std::size_t>(in.gcount());
    if (std::string_view(buf, got) != std::string_view(*text).substr(at, sizeof buf))
      __builtin_trap();
  }
  if (in.error()) __builtin_trap();
  return 0;
}
