#pragma once
// Heatshrink decoder (LZSS with a bit stream), as PrusaSlicer's binary G-code uses it.
//
// The stream is read most significant bit first. Tag bit 1: a literal byte follows (8
// bits). Tag bit 0: a back-reference follows, `window_bits` bits of (offset - 1) then
// `lookahead_bits` bits of (count - 1); it copies `count` bytes starting `offset` bytes back
// in the output, the copy may overlap what it writes. The window starts as zero bytes, so an
// offset past the start of the output reads zeros. The encoder pads the last byte with
// zero bits, fewer than a whole literal or back-reference, which the decoder ignores.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace printtwin::detail {

/// A byte buffer of the decoders.
using Bytes = std::vector<char>;

/// Decodes `in` into `out` (resized to `expected_size`). False, with `why` set, when the
/// stream does not produce exactly `expected_size` bytes. window_bits <= 15,
/// lookahead_bits <= 8.
[[nodiscard]] bool heatshrink_decode(std::string_view in, int window_bits, int lookahead_bits,
                                     std::size_t expected_size, Bytes& out, std::string& why);

/// Most bytes one input byte can expand to (a back-reference of 2^lookahead bytes in
/// 1 + window + lookahead bits): bounds the output before anything is allocated.
[[nodiscard]] constexpr std::size_t heatshrink_max_expansion(int window_bits, int lookahead_bits) {
  return (std::size_t{8} << lookahead_bits) /
             static_cast<std::size_t>(1 + window_bits + lookahead_bits) +
         1;
}

}  // namespace printtwin::detail
