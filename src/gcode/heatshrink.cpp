// Heatshrink decoder: see heatshrink.hpp for the bit stream.
#include "gcode/heatshrink.hpp"

namespace printtwin::detail {

namespace {

/// MSB-first bit reader over a byte string.
class BitReader {
 public:
  explicit BitReader(std::string_view in) : in_(in) {}
  /// True when `n` (<= 24) more bits are available; loads them.
  bool need(int n) {
    while (bits_ < n) {
      if (pos_ == in_.size()) return false;
      acc_ = (acc_ << 8) | static_cast<std::uint8_t>(in_[pos_++]);
      bits_ += 8;
    }
    return true;
  }
  /// The next `n` bits (after need(n) returned true).
  std::uint32_t take(int n) {
    bits_ -= n;
    return static_cast<std::uint32_t>(acc_ >> bits_) & ((1u << n) - 1u);
  }

 private:
  std::string_view in_;
  std::size_t pos_ = 0;
  std::uint64_t acc_ = 0;
  int bits_ = 0;
};

}  // namespace

bool heatshrink_decode(std::string_view in, int window_bits, int lookahead_bits, std::size_t expected_size,
                       std::string& out, std::string& why) {
  out.resize(expected_size);
  char* const dst = out.data();
  std::size_t n = 0;
  BitReader bits(in);
  for (;;) {
    if (!bits.need(1)) break;
    if (bits.take(1) != 0) {
      if (!bits.need(8)) break;
      const auto c = static_cast<char>(bits.take(8));
      if (n == expected_size) {
        why = "heatshrink data decodes to more than the " + std::to_string(expected_size) +
              " bytes the block header states";
        return false;
      }
      dst[n++] = c;
      continue;
    }
    if (!bits.need(window_bits)) break;
    const std::size_t offset = bits.take(window_bits) + 1;
    if (!bits.need(lookahead_bits)) break;
    const std::size_t count = bits.take(lookahead_bits) + 1;
    if (count > expected_size - n) {
      why = "heatshrink data decodes to more than the " + std::to_string(expected_size) +
            " bytes the block header states";
      return false;
    }
    for (std::size_t i = 0; i < count; ++i, ++n) dst[n] = n >= offset ? dst[n - offset] : '\0';
  }
  if (n != expected_size) {
    why = "heatshrink data decodes to " + std::to_string(n) + " bytes, the block header states " +
          std::to_string(expected_size);
    return false;
  }
  return true;
}

}  // namespace printtwin::detail
