// Whole-file reads and atomic writes; locale-independent number formatting.
#include "printtwin/io.hpp"

#if defined(__GLIBC__)
#include <malloc.h>
#endif
#include <algorithm>
#include <array>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <optional>
#include <random>
#include <sstream>
#include <system_error>

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <cpuid.h>
#include <immintrin.h>
#endif

#include "core/plain_path.hpp"

namespace printtwin {

namespace fs = std::filesystem;

namespace {

/// Why `path` cannot be read, in the user's terms ("file not found", "symbolic link loop",
/// "permission denied", ...), or nothing when it is a readable-looking regular file.
std::optional<Error> input_problem(const fs::path& path) {
  std::error_code ec;
  const auto status = fs::status(path, ec);
  if (ec && ec != std::errc::no_such_file_or_directory) {
    if (ec == std::errc::too_many_symbolic_link_levels)
      return bad_input("symbolic link loop (too many levels of symbolic links), expected a file",
                       path.string());
    if (ec == std::errc::permission_denied)
      return bad_input("permission denied (a folder on the path cannot be searched)", path.string());
    if (ec == std::errc::not_a_directory)
      return bad_input("file not found (a part of the path is a file, not a folder)", path.string());
    return bad_input("cannot access: " + ec.message(), path.string());
  }
  if (!fs::exists(status)) {
    std::error_code lec;
    if (fs::is_symlink(fs::symlink_status(path, lec)))
      return bad_input("dangling symbolic link: its target does not exist", path.string());
    return bad_input("file not found", path.string());
  }
  if (fs::is_directory(status)) return bad_input("is a directory, expected a file", path.string());
  return std::nullopt;
}

}  // namespace

Result<std::uint64_t> input_file_size(const fs::path& path) {
  if (auto problem = input_problem(path)) return *problem;
  std::error_code ec;
  const auto size = fs::file_size(path, ec);
  if (ec) return bad_input("cannot read its size (not a regular file?): " + ec.message(), path.string());
  return static_cast<std::uint64_t>(size);
}

Result<std::string> read_file_head(const fs::path& path, std::size_t max_bytes) {
  if (auto problem = input_problem(path)) return *problem;
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (f == nullptr) return bad_input(std::string("cannot open: ") + std::strerror(errno), path.string());
  std::string data(max_bytes, '\0');
  const std::size_t got = data.empty() ? 0 : std::fread(data.data(), 1, data.size(), f);
  const bool failed = std::ferror(f) != 0;
  std::fclose(f);
  if (failed) return bad_input("read error", path.string());
  data.resize(got);
  return data;
}

Result<std::string> read_file(const fs::path& path) {
  if (auto problem = input_problem(path)) return *problem;
  // C stdio with one fread into the final buffer: no stream buffer copy in between.
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (f == nullptr) return bad_input(std::string("cannot open: ") + std::strerror(errno), path.string());
  std::string data;
  bool ok = std::fseek(f, 0, SEEK_END) == 0;
  const long size = ok ? std::ftell(f) : -1;
  if (size < 0 || std::fseek(f, 0, SEEK_SET) != 0) {
    std::fclose(f);
    return bad_input("cannot read (not a regular file?)", path.string());
  }
  std::setvbuf(f, nullptr, _IONBF, 0);
  data.resize(static_cast<std::size_t>(size));
  const std::size_t got = data.empty() ? 0 : std::fread(data.data(), 1, data.size(), f);
  ok = got == data.size() || std::feof(f) != 0;
  if (!ok || std::ferror(f) != 0) {
    std::fclose(f);
    return bad_input("read error", path.string());
  }
  std::fclose(f);
  data.resize(got);
  return data;
}

Status write_file_atomic(const fs::path& path, std::string_view content) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) return bad_input("is a folder, expected a file to write", path.string());
  if (path.has_parent_path()) fs::create_directories(path.parent_path(), ec);
  // A unique temporary name beside the target, so that rename() is atomic.
  std::random_device rd;
  const fs::path tmp = path.string() + ".tmp" + std::to_string(rd() % 1000000);
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) {
      return Error{ErrorCode::bad_input, std::string("cannot write: ") + std::strerror(errno),
                   path.string(), {}};
    }
    out.write(content.data(), static_cast<std::streamsize>(content.size()));
    out.flush();
    if (!out) {
      out.close();
      fs::remove(tmp, ec);
      return Error{ErrorCode::bad_input, "write failed (disk full?)", path.string(), {}};
    }
  }
  fs::rename(tmp, path, ec);
  if (ec) {
    // The rename's reason, read before the clean-up reuses an error code.
    const std::string why = ec == std::errc::is_a_directory ? "it is a folder, expected a file" : ec.message();
    std::error_code ignored;
    fs::remove(tmp, ignored);
    return Error{ErrorCode::bad_input, "cannot rename the temporary file into place: " + why,
                 path.string(), {}};
  }
  return Ok{};
}

std::string format_number(double v) {
  if (!std::isfinite(v)) return std::isnan(v) ? "nan" : (v > 0 ? "inf" : "-inf");
  std::array<char, 64> buf{};
  auto [ptr, err] = std::to_chars(buf.data(), buf.data() + buf.size(), v);
  if (err != std::errc{}) return "0";
  return std::string(buf.data(), ptr);
}

std::string format_fixed(double v, int decimals) {
  if (!std::isfinite(v)) return format_number(v);
  std::array<char, 128> buf{};
  auto [ptr, err] = std::to_chars(buf.data(), buf.data() + buf.size(), v,
                                  std::chars_format::fixed, decimals);
  if (err != std::errc{}) return "0";
  std::string s(buf.data(), ptr);
  // "-0.000" -> "0.000"
  if (s[0] == '-' && s.find_first_not_of("-0.") == std::string::npos) s.erase(0, 1);
  return s;
}

std::string format_duration_compact(double seconds) {
  const long total = std::isfinite(seconds) ? std::lround(std::max(seconds, 0.0)) : 0;
  const long h = total / 3600, m = (total % 3600) / 60, s = total % 60;
  std::string out;
  if (h > 0) out += std::to_string(h) + "h ";
  if (h > 0 || m > 0) out += std::to_string(m) + "m ";
  out += std::to_string(s) + "s";
  return out;
}

std::string format_duration(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0) return "—";
  const long total = std::lround(seconds);
  const long h = total / 3600, m = (total % 3600) / 60, s = total % 60;
  auto two = [](long v) { return (v < 10 ? "0" : "") + std::to_string(v); };
  if (h > 0) return std::to_string(h) + " h " + two(m) + " min";
  if (m > 0) return std::to_string(m) + " min " + two(s) + " s";
  return std::to_string(s) + " s";
}

// SHA-256 (FIPS 180-4), dependency-free: used for input provenance (a 37 MB STL is hashed on
// every verify, so speed matters). The blocks are hashed straight from the input (no copy);
// only the padded tail goes through a 128-byte buffer. On x86-64 CPUs with the SHA
// extensions (cpuid leaf 7, EBX bit 29) the compression runs on them (~1.5 GB/s);
// elsewhere a portable scalar version (~300 MB/s). Both give the same digest.
namespace {
constexpr std::array<std::uint32_t, 64> kK = {
    0x428a2f98, 0x71374491, 0xb5c0fbcf, 0xe9b5dba5, 0x3956c25b, 0x59f111f1, 0x923f82a4,
    0xab1c5ed5, 0xd807aa98, 0x12835b01, 0x243185be, 0x550c7dc3, 0x72be5d74, 0x80deb1fe,
    0x9bdc06a7, 0xc19bf174, 0xe49b69c1, 0xefbe4786, 0x0fc19dc6, 0x240ca1cc, 0x2de92c6f,
    0x4a7484aa, 0x5cb0a9dc, 0x76f988da, 0x983e5152, 0xa831c66d, 0xb00327c8, 0xbf597fc7,
    0xc6e00bf3, 0xd5a79147, 0x06ca6351, 0x14292967, 0x27b70a85, 0x2e1b2138, 0x4d2c6dfc,
    0x53380d13, 0x650a7354, 0x766a0abb, 0x81c2c92e, 0x92722c85, 0xa2bfe8a1, 0xa81a664b,
    0xc24b8b70, 0xc76c51a3, 0xd192e819, 0xd6990624, 0xf40e3585, 0x106aa070, 0x19a4c116,
    0x1e376c08, 0x2748774c, 0x34b0bcb5, 0x391c0cb3, 0x4ed8aa4a, 0x5b9cca4f, 0x682e6ff3,
    0x748f82ee, 0x78a5636f, 0x84c87814, 0x8cc70208, 0x90befffa, 0xa4506ceb, 0xbef9a3f7,
    0xc67178f2};

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
      const auto t1 = hh + (rotr(e, 6) ^ rotr(e, 11) ^ rotr(e, 25)) + ((e & f) ^ (~e & g)) + kK[i] + w[i];
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
__attribute__((target("sha,sse4.1,ssse3"))) void sha256_blocks_shani(std::array<std::uint32_t, 8>& h,
                                                                      const unsigned char* data,
                                                                      std::size_t blocks) {
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
        cur = _mm_shuffle_epi8(_mm_loadu_si128(reinterpret_cast<const __m128i*>(data + 16 * g)), byte_swap);
      } else {
        const __m128i& prev1 = w[(g + 3) & 3];  // W[t-4 .. t-1]
        const __m128i& prev2 = w[(g + 2) & 3];  // W[t-8 .. t-5]
        const __m128i& prev3 = w[(g + 1) & 3];  // W[t-12 .. t-9]
        __m128i x = _mm_sha256msg1_epu32(cur, prev3);  // W[t-16..] + sigma0(W[t-15..])
        x = _mm_add_epi32(x, _mm_alignr_epi8(prev1, prev2, 4));  // + W[t-7 .. t-4]
        cur = _mm_sha256msg2_epu32(x, prev1);                   // + sigma1(W[t-2 ..])
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
  for (int i = 0; i < 8; ++i) tail[tail_len - 1 - i] = static_cast<unsigned char>(bit_len >> (8 * i));
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

void tune_allocator_for_jobs() {
#if defined(__GLIBC__)
  if (detail::plain_path("tune_allocator")) return;  // the plain twin: glibc's defaults
  // A job allocates and frees arrays of tens of MB in turn (file text, mesh import, the
  // outer surface's bit columns, face arrays). Fresh pages cost ~1.5 us each here (the kernel
  // zeroes and maps them, ~0.4 ms per MB), so freed memory is kept for reuse: no block goes
  // to its own mapping (it would be unmapped on free), and the heap is not trimmed below
  // 512 MiB. Measured (verify of the benchmark part): the 32 MiB mmap threshold with the trim
  // threshold took sys 1.3 -> 0.85 s; no mmap at all then 243k -> 204k page faults, sys
  // 0.53 -> 0.45 s, same peak. (Thread arenas still map a block too big for one of their
  // 64 MiB heaps.)
  // One arena for every thread: a TBB worker that allocates an array (the branches of a
  // parallel_invoke run on either thread) then reuses what the main thread freed instead of
  // growing a heap of its own. The jobs allocate per chunk of work, not per element, so the
  // shared lock is not contended. Measured (verify of the benchmark part, 2 cores, alternating
  // with and without): 186k -> 174k page faults, peak 673 -> 650 MB, system time 0.46 -> 0.40 s.
  mallopt(M_ARENA_MAX, 1);
  mallopt(M_MMAP_THRESHOLD, 32 << 20);
  mallopt(M_MMAP_MAX, 0);
  mallopt(M_TRIM_THRESHOLD, 512 << 20);
#endif
}

}  // namespace printtwin
