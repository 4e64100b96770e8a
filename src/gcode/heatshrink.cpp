// Heatshrink decoder: see heatshrink.hpp for the bit stream.
#include "gcode/heatshrink.hpp"

#include <cstring>

namespace printtwin::detail {

namespace {

/// The 64 bits of `src` from bit `at` on, most significant first; bits past the end read
/// as zero. At least 57 of them come from the input when it has that many.
std::uint64_t peek64(const unsigned char* src, std::size_t size, std::uint64_t at) {
  const auto byte = static_cast<std::size_t>(at >> 3);
  std::uint64_t w = 0;
  if (byte + 8 <= size) {
    std::memcpy(&w, src + byte, 8);
    w = __builtin_bswap64(w);
  } else {
    for (std::size_t k = 0; byte + k < size; ++k)
      w |= static_cast<std::uint64_t>(src[byte + k]) << (56 - 8 * k);
  }
  return w << (at & 7u);
}

/// The decoder; kWindow and kLookahead, when not 0, fix the bit widths at compile time
/// (constant shifts and masks for the two widths binary G-code uses).
template <int kWindow, int kLookahead>
bool decode(std::string_view in, int window_arg, int lookahead_arg, std::size_t expected_size,
            Bytes& out, std::string& why) {
  const int window_bits = kWindow != 0 ? kWindow : window_arg;
  const int lookahead_bits = kLookahead != 0 ? kLookahead : lookahead_arg;
  // 16 bytes of slack past the end let a back-reference copy a whole 16-byte word.
  constexpr std::size_t kSlack = 16;
  out.resize(expected_size + kSlack);
  char* const dst = out.data();
  std::size_t n = 0;
  // Each token is read from a 64-bit big-endian load at its bit position: a literal is
  // 1 + 8 bits, a back-reference 1 + window + lookahead <= 24 bits.
  const auto* src = reinterpret_cast<const unsigned char*>(in.data());
  const std::size_t src_size = in.size();
  const std::uint64_t total_bits = 8 * static_cast<std::uint64_t>(src_size);
  std::uint64_t bit = 0;
  const int backref_bits = 1 + window_bits + lookahead_bits;
  const std::uint32_t window_mask = (1u << window_bits) - 1u,
                      count_mask = (1u << lookahead_bits) - 1u;
  auto too_long = [&] {
    why = "heatshrink data decodes to more than the " + std::to_string(expected_size) +
          " bytes the block header states";
    return false;
  };
  while (bit < total_bits) {
    const std::uint64_t left = total_bits - bit;
    const std::uint64_t w = peek64(src, src_size, bit);
    if ((w >> 63) != 0) {   // literal
      if (left < 9) break;  // padding
      if (n == expected_size) return too_long();
      dst[n++] = static_cast<char>((w >> 55) & 0xFFu);
      bit += 9;
      continue;
    }
    if (left < static_cast<std::uint64_t>(backref_bits)) break;  // padding
    bit += static_cast<std::uint64_t>(backref_bits);
    const auto token = static_cast<std::uint32_t>(w >> (64 - backref_bits));
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

}  // namespace

bool heatshrink_decode(std::string_view in, int window_bits, int lookahead_bits,
                       std::size_t expected_size, Bytes& out, std::string& why) {
  if (window_bits == 11 && lookahead_bits == 4)
    return decode<11, 4>(in, window_bits, lookahead_bits, expected_size, out, why);
  if (window_bits == 12 && lookahead_bits == 4)
    return decode<12, 4>(in, window_bits, lookahead_bits, expected_size, out, why);
  return decode<0, 0>(in, window_bits, lookahead_bits, expected_size, out, why);
}

}  // namespace printtwin::detail
