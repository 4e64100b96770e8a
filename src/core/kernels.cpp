// The core's kernels: SHA-256 of the input files (report provenance), the plain rounds and
// the x86-64 SHA extensions, behind one dispatch point (sha256_hex). Both give the same
// digest; bench/RESULTS.md measures the pair (PRINTTWIN_PLAIN=sha_ni).
#include <array>
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <cpuid.h>
#include <immintrin.h>
#endif

#include "core/plain_path.hpp"
#include "printtwin/io.hpp"

namespace printtwin {

// SHA-256 (FIPS 180-4), dependency-free: used for input provenance (a 37 MB STL is hashed on
// every verify, so speed matters). The blocks are hashed straight from the input (no copy);
// only the padded tail goes through a 128-byte buffer. On x86-64 CPUs with the SHA
// extensions (cpuid leaf 7, EBX bit 29) the compression runs on them (~1.5 GB/s);
// elsewhere a portable scalar version (~300 MB/s). Both give the same digest.
namespace {
constexpr std::array<std::uint32_t, 64> kK = {
    0x428a2f98, 0x71374491, 0xb5c0fbcf, 0xe9b5dba5, 0x3956c25b, 0x59f111f1, 0x923f82a4, 0xab1c5ed5,
    0xd807aa98, 0x12835b01, 0x243185be, 0x550c7dc3, 0x72be5d74, 0x80deb1fe, 0x9bdc06a7, 0xc19bf174,
    0xe49b69c1, 0xefbe4786, 0x0fc19dc6, 0x240ca1cc, 0x2de92c6f, 0x4a7484aa, 0x5cb0a9dc, 0x76f988da,
    0x983e5152, 0xa831c66d, 0xb00327c8, 0xbf597fc7, 0xc6e00bf3, 0xd5a79147, 0x06ca6351, 0x14292967,
    0x27b70a85, 0x2e1b2138, 0x4d2c6dfc, 0x53380d13, 0x650a7354, 0x766a0abb, 0x81c2c92e, 0x92722c85,
    0xa2bfe8a1, 0xa81a664b, 0xc24b8b70, 0xc76c51a3, 0xd192e819, 0xd6990624, 0xf40e3585, 0x106aa070,
    0x19a4c116, 0x1e376c08, 0x2748774c, 0x34b0bcb5, 0x391c0cb3, 0x4ed8aa4a, 0x5b9cca4f, 0x682e6ff3,
    0x748f82ee, 0x78a5636f, 0x84c87814, 0x8cc70208, 0x90befffa, 0xa4506ceb, 0xbef9a3f7, 0xc67178f2};

constexpr std::uint32_t rotr(std::uint32_t x, int n) { return (x >> n) | (x << (32 - n)); }

std::uint32_t load_be32(const unsigned char* p) {
  return (std::uint32_t(p[0]) << 24) | (std::uint32_t(p[1]) << 16) | (std::uint32_t(p[2]) << 8) |
         std::uint32_t(p[3]);
}

/// Portable compression of `blocks` 64-byte blocks.
void sha256_blocks_scalar(std::array<std::uint32_t, 8>& h, const unsigned char* data,
                          std::size_t blocks) {
  std::array<std::uint32_t, 64> w{};
  for (; blocks > 0; --blocks, data += 64) {
    for (int i = 0; i < 16; ++i) w[i] = load_be32(data + 4 * i);
    for (int i = 16; i < 64; ++i) {
      const auto s0 = rotr(w[i - 15], 7) ^ rotr(w[i - 15], 18) ^ (w[i - 15] >> 3);
      const auto s1 = rotr(w[i - 2], 17) ^ rotr(w[i - 2], 19) ^ (w[i - 2] >> 10);
      w[i] = w[i - 16] + s0 + w[i - 7] + s1;
    }
    std::uint32_t a = h[0], b = h[1], c = h[2], d = h[3], e = h[4], f = h[5], g = h[6], hh = h[7];
    for (int i = 0; i < 64; ++i) {
      const auto t1 =
          hh + (rotr(e, 6) ^ rotr(e, 11) ^ rotr(e, 25)) + ((e & f) ^ (~e & g)) + kK[i] + w[i];
      const auto t2 = (rotr(a, 2) ^ rotr(a, 13) ^ rotr(a, 22)) + ((a & b) ^ (a & c) ^ (b & c));
      hh = g;
      g = f;
      f = e;
      e = d + t1;
      d = c;
      c = b;
      b = a;
      a = t1 + t2;
    }
    h[0] += a, h[1] += b, h[2] += c, h[3] += d, h[4] += e, h[5] += f, h[6] += g, h[7] += hh;
  }
}

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define PRINTTWIN_SHA_NI 1

bool cpu_has_sha_extensions() {
  unsigned eax = 0, ebx = 0, ecx = 0, edx = 0;
  if (__get_cpuid(1, &eax, &ebx, &ecx, &edx) == 0) return false;
  const bool ssse3 = (ecx & (1U << 9)) != 0, sse41 = (ecx & (1U << 19)) != 0;
  if (__get_cpuid_count(7, 0, &eax, &ebx, &ecx, &edx) == 0) return false;
  return ssse3 && sse41 && (ebx & (1U << 29)) != 0;
}

/// The same compression with the SHA extensions: the state is kept as ABEF/CDGH lane pairs
/// (the layout sha256rnds2 works on); each group of four rounds extends the message schedule
/// with sha256msg1/msg2 in a ring of four registers.
__attribute__((target("sha,sse4.1,ssse3"))) void sha256_blocks_shani(
    std::array<std::uint32_t, 8>& h, const unsigned char* data, std::size_t blocks) {
  const __m128i byte_swap = _mm_set_epi64x(0x0c0d0e0f08090a0bLL, 0x0405060700010203LL);
  __m128i dcba = _mm_loadu_si128(reinterpret_cast<const __m128i*>(h.data()));
  __m128i hgfe = _mm_loadu_si128(reinterpret_cast<const __m128i*>(h.data() + 4));
  const __m128i cdab = _mm_shuffle_epi32(dcba, 0xB1);
  const __m128i efgh = _mm_shuffle_epi32(hgfe, 0x1B);
  __m128i abef = _mm_alignr_epi8(cdab, efgh, 8);
  __m128i cdgh = _mm_blend_epi16(efgh, cdab, 0xF0);
  for (; blocks > 0; --blocks, data += 64) {
    const __m128i abef_in = abef, cdgh_in = cdgh;
    __m128i w[4];
#pragma GCC unroll 16
    for (int g = 0; g < 16; ++g) {
      __m128i& cur = w[g & 3];
      if (g < 4) {
        cur = _mm_shuffle_epi8(_mm_loadu_si128(reinterpret_cast<const __m128i*>(data + 16 * g)),
                               byte_swap);
      } else {
        const __m128i& prev1 = w[(g + 3) & 3];                   // W[t-4 .. t-1]
        const __m128i& prev2 = w[(g + 2) & 3];                   // W[t-8 .. t-5]
        const __m128i& prev3 = w[(g + 1) & 3];                   // W[t-12 .. t-9]
        __m128i x = _mm_sha256msg1_epu32(cur, prev3);            // W[t-16..] + sigma0(W[t-15..])
        x = _mm_add_epi32(x, _mm_alignr_epi8(prev1, prev2, 4));  // + W[t-7 .. t-4]
        cur = _mm_sha256msg2_epu32(x, prev1);                    // + sigma1(W[t-2 ..])
      }
      __m128i k = _mm_loadu_si128(reinterpret_cast<const __m128i*>(kK.data() + 4 * g));
      __m128i m = _mm_add_epi32(cur, k);
      cdgh = _mm_sha256rnds2_epu32(cdgh, abef, m);
      m = _mm_shuffle_epi32(m, 0x0E);
      abef = _mm_sha256rnds2_epu32(abef, cdgh, m);
    }
    abef = _mm_add_epi32(abef, abef_in);
    cdgh = _mm_add_epi32(cdgh, cdgh_in);
  }
  const __m128i feba = _mm_shuffle_epi32(abef, 0x1B);
  const __m128i dchg = _mm_shuffle_epi32(cdgh, 0xB1);
  dcba = _mm_blend_epi16(feba, dchg, 0xF0);
  hgfe = _mm_alignr_epi8(dchg, feba, 8);
  _mm_storeu_si128(reinterpret_cast<__m128i*>(h.data()), dcba);
  _mm_storeu_si128(reinterpret_cast<__m128i*>(h.data() + 4), hgfe);
}
#endif

void sha256_blocks(std::array<std::uint32_t, 8>& h, const unsigned char* data, std::size_t blocks,
                   bool use_extensions) {
#ifdef PRINTTWIN_SHA_NI
  if (use_extensions) return sha256_blocks_shani(h, data, blocks);
#endif
  (void)use_extensions;
  sha256_blocks_scalar(h, data, blocks);
}

std::string sha256_hex_impl(std::string_view bytes, bool use_extensions) {
  std::array<std::uint32_t, 8> h = {0x6a09e667, 0xbb67ae85, 0x3c6ef372, 0xa54ff53a,
                                    0x510e527f, 0x9b05688c, 0x1f83d9ab, 0x5be0cd19};
  const auto* data = reinterpret_cast<const unsigned char*>(bytes.data());
  const std::size_t whole = bytes.size() / 64;
  sha256_blocks(h, data, whole, use_extensions);
  // Tail: the remaining bytes, 0x80, zeros, the bit length big endian (one or two blocks).
  std::array<unsigned char, 128> tail{};
  const std::size_t rest = bytes.size() - whole * 64;
  if (rest > 0) std::memcpy(tail.data(), data + whole * 64, rest);
  tail[rest] = 0x80;
  const std::size_t tail_len = rest < 56 ? 64 : 128;
  const std::uint64_t bit_len = static_cast<std::uint64_t>(bytes.size()) * 8;
  for (int i = 0; i < 8; ++i)
    tail[tail_len - 1 - i] = static_cast<unsigned char>(bit_len >> (8 * i));
  sha256_blocks(h, tail.data(), tail_len / 64, use_extensions);
  static constexpr char kHex[] = "0123456789abcdef";
  std::string out;
  out.reserve(64);
  for (auto v : h)
    for (int i = 28; i >= 0; i -= 4) out.push_back(kHex[(v >> i) & 0xf]);
  return out;
}
}  // namespace

std::string sha256_hex(std::string_view bytes) {
#ifdef PRINTTWIN_SHA_NI
  return sha256_hex_impl(bytes, cpu_has_sha_extensions() && !detail::plain_path("sha_ni"));
#else
  return sha256_hex_impl(bytes, false);
#endif
}

std::string sha256_hex_portable(std::string_view bytes) { return sha256_hex_impl(bytes, false); }

}  // namespace printtwin
