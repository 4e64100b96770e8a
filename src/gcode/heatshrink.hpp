#pragma once
// Heatshrink decoder (LZSS with a bit stream), as PrusaSlicer's binary G-code uses it.
//
// The stream is read most significant bit first. Tag bit 1: a literal byte follows (8
// bits). Tag bit 0: a back-reference follows, `window_bits` bits of (offset - 1) then
// `lookahead_bits` bits of (count - 1); it copies `count` bytes starting `offset` bytes back
// in the output, the copy may overlap what it writes. The window starts as zero bytes, so an
// offset past the start of the output reads zeros. The encoder pads the last byte with
// zero bits, fewer than a whole literal or back-reference, which the decoder ignores.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string>
#include <string_view>

namespace printtwin::detail {

/// A byte buffer of the decoders: resize() never clears what it adds (the decoders write
/// every byte they hand out) and never gives memory back, so a buffer reused block after
/// block costs neither a clear nor an allocation per block.
class Bytes {
 public:
  [[nodiscard]] char* data() { return data_.get(); }
  [[nodiscard]] const char* data() const { return data_.get(); }
  [[nodiscard]] std::size_t size() const { return size_; }
  [[nodiscard]] bool empty() const { return size_ == 0; }
  char& operator[](std::size_t i) { return data_[i]; }
  /// Sets the size; bytes past the old size are left unset.
  void resize(std::size_t n) {
    if (n > capacity_) {
      const std::size_t cap = std::max(n, capacity_ + capacity_ / 2);
      auto bigger = std::make_unique_for_overwrite<char[]>(cap);
      if (size_ > 0) std::memcpy(bigger.get(), data_.get(), size_);
      data_ = std::move(bigger);
      capacity_ = cap;
    }
    size_ = n;
  }

 private:
  std::unique_ptr<char[]> data_;
  std::size_t size_ = 0, capacity_ = 0;
};

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
