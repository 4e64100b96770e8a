// The command line's global operator new: large blocks ask the kernel for transparent huge
// pages.
//
// A run touches a few gigabytes of freshly allocated memory (the deposit's blocks and their
// tags, the surface's faces and points, the distance arrays). In 4 KiB pages each first touch
// is a page fault; on the 2-core machines of bench/RESULTS.md that was about a sixth of verify's
// CPU. Blocks of at least kAdviseBytes come from malloc as usual, and the whole 2 MiB pages
// inside them are marked MADV_HUGEPAGE, so the kernel (transparent_hugepage = madvise or
// always) backs them with 2 MiB pages: one fault instead of 512. Small blocks, the library's
// own ZeroedArray mappings (left sparse on purpose) and other programs linking libprinttwin are
// not affected. Where the kernel has no transparent huge pages, madvise fails and nothing
// changes.
//
// A special path (core/plain_path.hpp): PRINTTWIN_PLAIN=huge_pages allocates without the advice.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <new>

#if defined(__linux__)
#include <sys/mman.h>
#endif

#include "core/plain_path.hpp"

namespace {

constexpr std::size_t kHugePage = std::size_t{2} << 20;
/// Blocks this large always hold at least one whole aligned 2 MiB page.
constexpr std::size_t kAdviseBytes = std::size_t{4} << 20;

void advise_huge_pages([[maybe_unused]] void* p, [[maybe_unused]] std::size_t n) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  static const bool plain = printtwin::detail::plain_path("huge_pages");
  if (plain) return;
  const auto begin = reinterpret_cast<std::uintptr_t>(p);
  const std::uintptr_t lo = (begin + kHugePage - 1) & ~(kHugePage - 1);
  const std::uintptr_t hi = (begin + n) & ~(kHugePage - 1);
  // NOLINTNEXTLINE(performance-no-int-to-ptr): the page range of a block we own
  if (hi > lo) madvise(reinterpret_cast<void*>(lo), hi - lo, MADV_HUGEPAGE);
#endif
}

void* allocate(std::size_t n) noexcept {
  if (n == 0) n = 1;
  for (;;) {
    // NOLINTNEXTLINE(cppcoreguidelines-no-malloc): operator new is malloc's wrapper
    if (void* p = std::malloc(n)) {
      if (n >= kAdviseBytes) advise_huge_pages(p, n);
      return p;
    }
    std::new_handler handler = std::get_new_handler();
    if (handler == nullptr) return nullptr;
    handler();
  }
}

void* allocate_or_throw(std::size_t n) {
  if (void* p = allocate(n)) return p;
  throw std::bad_alloc();
}

}  // namespace

// The replaceable global allocation functions (the aligned ones keep the library's default).
void* operator new(std::size_t n) { return allocate_or_throw(n); }
void* operator new[](std::size_t n) { return allocate_or_throw(n); }
void* operator new(std::size_t n, const std::nothrow_t& /*tag*/) noexcept { return allocate(n); }
void* operator new[](std::size_t n, const std::nothrow_t& /*tag*/) noexcept { return allocate(n); }
// NOLINTBEGIN(cppcoreguidelines-no-malloc): the matching deallocation of operator new above
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t /*n*/) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t /*n*/) noexcept { std::free(p); }
void operator delete(void* p, const std::nothrow_t& /*tag*/) noexcept { std::free(p); }
void operator delete[](void* p, const std::nothrow_t& /*tag*/) noexcept { std::free(p); }
// NOLINTEND(cppcoreguidelines-no-malloc)
