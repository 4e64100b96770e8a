#pragma once
// The voxel grid's tag nibbles (a 4-bit palette entry per voxel, 32 bytes per z-slice of a
// block: row y at bytes 4 y .. 4 y + 3, voxel x in nibble x): the write kernel, exposed for
// the tests.
#include <cstdint>

namespace printtwin::detail {

/// Sets nibble e at the voxels of `mask` (bit y * 8 + x) in a z-slice's 32 bytes `row`, a
/// row at a time through a table.
void store_nibbles(std::uint8_t* row, std::uint64_t mask, unsigned e);

}  // namespace printtwin::detail
