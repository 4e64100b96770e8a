// Heatshrink decoder: see heatshrink.hpp for the bit stream.
#include "gcode/heatshrink.hpp"

#include <cstring>

namespace printtwin::detail {

bool heatshrink_decode(std::string_view in, int window_bits, int lookahead_bits,
                       std::size_t expected_size, Bytes& out, std::string& why) {
  // 16 bytes of slack past the end let a back-reference copy a whole 16-byte word.
  constexpr std::size_t kSlack = 16;
  out.resize(expected_size + kSlack);
  char* const dst = out.data();
  std::size_t n = 0;
  // MSB-first bit buffer: `bits` valid bits in the low end of `acc`, refilled a byte at a
  // time to at least one whole token (1 + window + lookahead <= 24 bits) when the input has it.
  const auto* src = reinterpret_cast<const unsigned char*>(in.data());
  const std::size_t src_size = in.size();
  std::size_t pos = 0;
  std::uint64_t acc = 0;
  int bits = 0;
  const int backref_bits = 1 + window_bits + lookahead_bits;
  const std::uint32_t window_mask = (1u << window_bits) - 1u,
                      count_mask = (1u << lookahead_bits) - 1u;
  auto too_long = [&] {
    why = "heatshrink data decodes to more than the " + std::to_string(expected_size) +
          " bytes the block header states";
    return false;
  };
  for (;;) {
    if (bits < backref_bits) {
      while (bits <= 56 && pos < src_size) {
        acc = (acc << 8) | src[pos++];
        bits += 8;
      }
      if (bits == 0) break;
    }
    if ((acc >> (bits - 1)) & 1u) {  // literal
      if (bits < 9) break;           // padding
      bits -= 9;
      if (n == expected_size) return too_long();
      dst[n++] = static_cast<char>((acc >> bits) & 0xFFu);
      continue;
    }
    if (bits < backref_bits) break;  // padding
    bits -= backref_bits;
    const auto token = static_cast<std::uint32_t>(acc >> bits);
    const std::size_t offset = ((token >> lookahead_bits) & window_mask) + 1;
    const std::size_t count = (token & count_mask) + 1;
    if (count > expected_size - n) return too_long();
    if (offset >= kSlack && count <= kSlack && offset <= n) {  // no overlap: one fixed-size copy
      std::memcpy(dst + n, dst + n - offset, kSlack);
      n += count;
    } else if (offset <= n) {  // the copy starts inside the output
      const char* from = dst + n - offset;
      for (std::size_t i = 0; i < count; ++i) dst[n + i] = from[i];  // may overlap: byte by byte
      n += count;
    } else {  // reaches back before the start: the zeroed window
      for (std::size_t i = 0; i < count; ++i, ++n) dst[n] = n >= offset ? dst[n - offset] : '\0';
    }
  }
  out.resize(expected_size);
  if (n != expected_size) {
    why = "heatshrink data decodes to " + std::to_string(n) + " bytes, the block header states " +
          std::to_string(expected_size);
    return false;
  }
  return true;
}

}  // namespace printtwin::detail
