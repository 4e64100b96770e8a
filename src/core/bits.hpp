#pragma once
// Bit counting without a library call (std::popcount calls libgcc's __popcountdi2 on
// baseline x86-64, without -mpopcnt, which the voxel loops cannot afford; the x86-64-v2
// build (CMakeLists.txt) turns this into the POPCNT instruction), and the CPU
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

#if defined(__x86_64__) && defined(__GNUC__)
/// The CPU feature `name` (a literal for __builtin_cpu_supports), asked once per call site.
#define PRINTTWIN_CPU_SUPPORTS(name)                           \
  [] {                                                         \
    static const bool has = __builtin_cpu_supports(name) != 0; \
    return has;                                                \
  }()
#else
#define PRINTTWIN_CPU_SUPPORTS(name) false
#endif

/// True when the CPU runs AVX2 (x86-64 with GCC or Clang; false elsewhere). Kernels that
/// use it have a portable twin giving the same bits.
inline bool cpu_has_avx2() { return PRINTTWIN_CPU_SUPPORTS("avx2"); }

/// True when the CPU runs AVX-512F (x86-64 with GCC or Clang; false elsewhere).
inline bool cpu_has_avx512f() { return PRINTTWIN_CPU_SUPPORTS("avx512f"); }

}  // namespace printtwin
