#pragma once
// Heatshrink decoder (LZSS with a bit stream), as PrusaSlicer's binary G-code uses it.
//
// The stream is read most significant bit first. Tag bit 1: a literal byte follows (8
// bits). Tag bit 0: a back-reference follows, `window_bits` bits of (offset - 1) then
// `lookahead_bits` bits of (count - 1); it copies `count` bytes starting `offset` bytes back
// in the output, the copy may overlap what it writes. The window starts as zero bytes, so an
// offset past the start of the output reads zeros. The encoder pads the last byte with
// zero bits, fewer than a whole literal or back-reference, which the decoder ignores.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "core/plain_path.hpp"
#include "printtwin/default_init_allocator.hpp"

namespace printtwin::detail {

/// A byte buffer whose resize() does not zero what it adds (decoders overwrite it all).
using Bytes = std::vector<char, DefaultInitAllocator<char>>;

/// b.resize(n); the plain twin (PRINTTWIN_PLAIN=default_init) zero-fills what it adds, as a
/// std::vector<char> would.
inline void resize_bytes(Bytes& b, std::size_t n) {
  static const bool plain = plain_path("default_init");
  const std::size_t old = b.size();
  b.resize(n);
  if (plain && n > old) std::fill(b.begin() + static_cast<std::ptrdiff_t>(old), b.end(), '\0');
}

/// Decodes `in` into `out` (resized to `expected_size`). False, with `why` set, when the
/// stream does not produce exactly `expected_size` bytes. window_bits <= 15,
/// lookahead_bits <= 8.
[[nodiscard]] bool heatshrink_decode(std::string_view in, int window_bits, int lookahead_bits,
                                     std::size_t expected_size, Bytes& out, std::string& why);

/// Most bytes one input byte can expand to (a back-reference of 2^lookahead bytes in
/// 1 + window + lookahead bits): bounds the output before anything is allocated.
[[nodiscard]] constexpr std::size_t heatshrink_max_expansion(int window_bits, int lookahead_bits) {
  return (std::size_t{8} << lookahead_bits) / static_cast<std::size_t>(1 + window_bits + lookahead_bits) + 1;
}

}  // namespace printtwin::detail
