#pragma once
// Bit counting without a library call (std::popcount calls libgcc's __popcountdi2 on
// baseline x86-64, without -mpopcnt, which the voxel loops cannot afford), and the CPU
// feature tests of the AVX2 and AVX-512 kernels.
#include <cstdint>

namespace printtwin {

/// Bits set in x (SWAR).
inline int popcount64(std::uint64_t x) {
  x = x - ((x >> 1) & 0x5555555555555555ull);
  x = (x & 0x3333333333333333ull) + ((x >> 2) & 0x3333333333333333ull);
  x = (x + (x >> 4)) & 0x0F0F0F0F0F0F0F0Full;
  return static_cast<int>((x * 0x0101010101010101ull) >> 56);
}

/// True when the CPU runs AVX2 (x86-64 with GCC or Clang; false elsewhere). Kernels that
/// use it have a portable twin giving the same bits.
inline bool cpu_has_avx2() {
#if defined(__x86_64__) && defined(__GNUC__)
  static const bool has = __builtin_cpu_supports("avx2") != 0;
  return has;
#else
  return false;
#endif
}

/// True when the CPU runs AVX-512F (x86-64 with GCC or Clang; false elsewhere).
inline bool cpu_has_avx512f() {
#if defined(__x86_64__) && defined(__GNUC__)
  static const bool has = __builtin_cpu_supports("avx512f") != 0;
  return has;
#else
  return false;
#endif
}

}  // namespace printtwin
