#pragma once
// Internals of the deposit-surface distance search, for the tests.
#include <cstdint>
#include <span>
#include <vector>

#include "printtwin/deviation.hpp"

namespace printtwin::detail {

/// distances_to_deposit with the face tests of the portable kernel (`portable`) or of the
/// one the CPU dispatches to (AVX2 when present). Both give the same bits.
void distances_to_deposit_with(const DepositSurface& surface, std::span<const Vec3> points,
                               std::vector<double>& signed_mm, std::vector<std::uint32_t>* nearest_face,
                               bool portable);

/// True when distances_to_deposit runs the AVX2 face tests on this CPU.
bool deposit_distance_uses_avx2();

}  // namespace printtwin::detail
