#pragma once
// ZeroedArray<T>: a fixed-size array of trivially copyable T that starts as all zeros without
// writing them. Large arrays are one anonymous mapping whose pages the kernel supplies zeroed
// on first touch, so the parts never written cost neither a memset nor a page fault (a
// height map or block directory spans the whole printed extent, skirt and purge line
// included, while the beads cover a fraction of it); small ones come from calloc.
#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <new>
#include <type_traits>
#include <utility>

#include "core/plain_path.hpp"

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace printtwin {

template <class T>
class ZeroedArray {
  static_assert(std::is_trivially_copyable_v<T>);

 public:
  ZeroedArray() = default;
  explicit ZeroedArray(std::size_t n) : size_(n) {
    if (n == 0) return;
    const std::size_t bytes = n * sizeof(T);
#if defined(__linux__)
    if (bytes >= kMapBytes) {
      void* p = mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
      if (p == MAP_FAILED) throw std::bad_alloc();
      data_ = static_cast<T*>(p);
      mapped_ = true;
      if (detail::plain_path("claim_pages")) return;  // claim() does nothing
      claimed_ = static_cast<std::uint8_t*>(std::calloc((bytes + kPage - 1) / kPage, 1));
      if (claimed_ == nullptr) {
        munmap(p, bytes);
        throw std::bad_alloc();
      }
      return;
    }
#endif
    data_ = static_cast<T*>(std::calloc(n, sizeof(T)));
    if (data_ == nullptr) throw std::bad_alloc();
  }
  ZeroedArray(const ZeroedArray& o) : ZeroedArray(o.size_) {
    if (size_ != 0) std::memcpy(data_, o.data_, size_ * sizeof(T));
  }
  ZeroedArray(ZeroedArray&& o) noexcept { swap(o); }
  ZeroedArray& operator=(ZeroedArray o) noexcept {
    swap(o);
    return *this;
  }
  ~ZeroedArray() { release(); }

  void swap(ZeroedArray& o) noexcept {
    std::swap(data_, o.data_);
    std::swap(size_, o.size_);
    std::swap(mapped_, o.mapped_);
    std::swap(claimed_, o.claimed_);
  }
  [[nodiscard]] T* data() { return data_; }
  [[nodiscard]] const T* data() const { return data_; }
  [[nodiscard]] std::size_t size() const { return size_; }
  [[nodiscard]] bool empty() const { return size_ == 0; }
  T& operator[](std::size_t i) { return data_[i]; }
  const T& operator[](std::size_t i) const { return data_[i]; }

  /// Call before the first read of element i when the element (or its page) will be written
  /// afterwards. A page read before it is ever written maps the kernel's shared zero page,
  /// and the write then copies it: a second fault, and a flush of the TLB of every CPU that
  /// runs one of the process's threads (an interrupt each, costly in a VM). Claiming writes
  /// the page first (a locked OR of zero: it never changes a value, so threads may claim the
  /// same page at once), making it private and resident in one fault. Once per page.
  /// PRINTTWIN_PLAIN=claim_pages turns claiming off (core/plain_path.hpp).
  void claim(std::size_t i) {
    if (claimed_ == nullptr) return;
    const std::size_t page = i * sizeof(T) / kPage;
    std::atomic_ref<std::uint8_t> flag(claimed_[page]);
    if (flag.load(std::memory_order_relaxed) != 0) return;
    flag.store(1, std::memory_order_relaxed);
    std::atomic_ref<std::uint8_t>(reinterpret_cast<std::uint8_t*>(data_)[page * kPage])
        .fetch_or(0, std::memory_order_relaxed);
  }

  /// claim() for every page of elements [first, last].
  void claim_range(std::size_t first, std::size_t last) {
    if (claimed_ == nullptr || first > last) return;
    last = std::min(last, size_ - 1);
    const std::size_t per_page = kPage / sizeof(T);
    for (std::size_t i = first - first % per_page; i <= last; i += per_page) claim(i);
  }

 private:
  static constexpr std::size_t kMapBytes = std::size_t{1} << 20;
  static constexpr std::uintptr_t kPage = 4096;
  void release() noexcept {
    if (data_ == nullptr) return;
#if defined(__linux__)
    if (mapped_) {
      munmap(data_, size_ * sizeof(T));
      std::free(claimed_);
      claimed_ = nullptr;
      data_ = nullptr;
      return;
    }
#endif
    std::free(data_);
    data_ = nullptr;
  }
  T* data_ = nullptr;
  std::size_t size_ = 0;
  bool mapped_ = false;
  std::uint8_t* claimed_ = nullptr;  ///< per page of a mapping: claimed for writing
};

}  // namespace printtwin
