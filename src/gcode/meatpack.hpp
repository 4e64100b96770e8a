#pragma once
// MeatPack decoder for the G-code blocks of PrusaSlicer's binary G-code.
//
// MeatPack packs the 15 most frequent G-code characters into 4-bit codes, two per byte,
// first character in the low nibble: '0'-'9' = 0-9, '.' = 10, ' ' = 11 ('E' once "no
// spaces" is on), '\n' = 12, 'G' = 13, 'X' = 14. Code 15 means "not packed": that
// character follows as a whole byte (when both nibbles are 15, both follow, first one
// first). A '\n' in the low nibble ends the pair (the high nibble is padding).
// 0xFF 0xFF <command> switches modes: 0xFB packing on, 0xFA packing off (plain bytes
// follow, e.g. comment lines), 0xF9 reset (packing off), 0xF8 query (no effect), 0xF7/0xF6
// "no spaces" on/off. A single 0xFF is an ordinary byte.
//
// The encoder removes the spaces of G lines; the decoder writes the text as PrusaSlicer's
// own reader does: a space before each parameter letter (X Y Z E F I J R G P W H C A) of a
// line starting with 'G' when none is there, and no empty lines. Each block is a fresh
// MeatPack stream.
#include <string>
#include <string_view>

#include "gcode/heatshrink.hpp"  // Bytes

namespace printtwin::detail {

/// Decodes one MeatPack-encoded block into the first `size` bytes of `buf`, which is grown
/// as needed and never shrunk, so a buffer reused block after block is neither cleared nor
/// reallocated. False, with `why` set (naming the byte offset in the block's data), on an
/// unknown command byte or a block that ends inside a command or before a pending
/// full-width character. `fast` = false runs every byte through the byte-at-a-time state
/// machine alone: the reference the tests and the fuzz target hold the fast paths to.
[[nodiscard]] bool meatpack_decode(std::string_view in, Bytes& buf, std::size_t& size,
                                   std::string& why, bool fast = true);

}  // namespace printtwin::detail
