// LeakCheckPause: while one lives, LeakSanitizer ignores the allocations of this thread (OCCT's
// one-time registries look like leaks at exit); an empty object in builds without AddressSanitizer.
#pragma once

#if defined(__SANITIZE_ADDRESS__)
#define ALIGN3D_LEAK_CHECKED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define ALIGN3D_LEAK_CHECKED 1
#endif
#endif
#ifdef ALIGN3D_LEAK_CHECKED
#include <sanitizer/lsan_interface.h>
#endif

namespace align3d::detail {

#ifdef ALIGN3D_LEAK_CHECKED
using LeakCheckPause = __lsan::ScopedDisabler;
#else
struct LeakCheckPause {};
#endif

}  // namespace align3d::detail
