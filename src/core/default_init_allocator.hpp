#pragma once
// Private (src/ only).
// An allocator whose value-initialisation is default-initialisation, so that
// std::vector<T, DefaultInitAllocator<T>>::resize(n) leaves trivially constructible elements
// (integers, bit words) unwritten: a large array's pages are then first touched by the code
// that fills it, which may run in parallel, instead of by one thread zero-filling it in
// resize (a first touch costs ~0.45 ms per MB on the machines this was measured on).
#include <memory>
#include <type_traits>
#include <utility>
#include <vector>

namespace printtwin {

template <class T>
struct DefaultInitAllocator : std::allocator<T> {
  using std::allocator<T>::allocator;
  template <class U>
  struct rebind {
    using other = DefaultInitAllocator<U>;
  };
  DefaultInitAllocator() = default;
  template <class U>
  DefaultInitAllocator(const DefaultInitAllocator<U>&) noexcept {}  // NOLINT(google-explicit-constructor)
  template <class U>
  void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) {
    ::new (static_cast<void*>(p)) U;
  }
  template <class U, class... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
};

}  // namespace printtwin
