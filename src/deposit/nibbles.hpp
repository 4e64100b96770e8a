#pragma once
// The voxel grid's tag nibbles (a 4-bit palette entry per voxel, 32 bytes per z-slice of a
// block: row y at bytes 4 y .. 4 y + 3, voxel x in nibble x): the write kernels, exposed for
// the tests, which check that both give the same bytes.
#include <cstdint>

namespace printtwin::detail {

/// Sets nibble e at the voxels of `mask` (bit y * 8 + x) in a z-slice's 32 bytes `row`.
void store_nibbles(std::uint8_t* row, std::uint64_t mask, unsigned e);
/// The same, a row at a time through a table (any CPU).
void store_nibbles_portable(std::uint8_t* row, std::uint64_t mask, unsigned e);
/// The same with BMI2's PDEP, two rows at a time; false (nothing written) without BMI2.
bool store_nibbles_bmi2(std::uint8_t* row, std::uint64_t mask, unsigned e);

}  // namespace printtwin::detail
