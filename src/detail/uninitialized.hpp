// A std::vector whose resize leaves new elements of trivial type uninitialised (default-
// initialised, not value-initialised). For the large arrays a parallel loop fills right after
// sizing them: zeroing them first ran on one thread and touched every fresh page there (a page
// fault costs ~1.7 µs on the 2-core machine of bench/README.md: 10 ms for a 24 MB array); left to
// the loop, the pages are touched by the threads that fill them.
#pragma once

#include <memory>
#include <new>
#include <type_traits>
#include <utility>
#include <vector>

namespace align3d::detail {

template <class T>
struct DefaultInitAllocator : std::allocator<T> {
  using value_type = T;
  template <class U>
  struct rebind {
    using other = DefaultInitAllocator<U>;
  };
  DefaultInitAllocator() = default;
  template <class U>
  DefaultInitAllocator(const DefaultInitAllocator<U>&) noexcept {}  // NOLINT: implicit
  template <class U>
  void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) {
    ::new (static_cast<void*>(p)) U;
  }
  template <class U, class... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
};

template <class T>
using UninitializedVector = std::vector<T, DefaultInitAllocator<T>>;

}  // namespace align3d::detail
