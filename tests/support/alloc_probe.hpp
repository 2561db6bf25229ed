// Counting heap allocators for the "no allocation while stepping" tests. Include in exactly ONE
// translation unit of a test executable (it defines the global operator new/delete family and, on
// glibc, interposes malloc/calloc/realloc/memalign/aligned_alloc/posix_memalign, forwarding to
// glibc's __libc_* entry points). Counters are thread-local and armed only between arm() and
// disarm(); the first allocation while armed records a backtrace (execinfo), printed by
// print_first_allocation().
#pragma once

#include <execinfo.h>

#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <new>

namespace alloc_probe {

thread_local long g_new_calls = 0;     // operator new (all forms) while armed
thread_local long g_malloc_calls = 0;  // malloc family while armed (includes operator new's)
thread_local bool g_armed = false;
thread_local bool g_in_probe = false;  // no recursion through backtrace()
thread_local int g_nframes = 0;
thread_local void* g_frames[64];

inline void record() {
  if (!g_armed || g_in_probe) return;
  g_in_probe = true;
  ++g_malloc_calls;
  if (g_malloc_calls == 1) g_nframes = backtrace(g_frames, 64);
  g_in_probe = false;
}

void arm() {
  g_new_calls = g_malloc_calls = 0;
  g_nframes = 0;
  g_armed = true;
}

void disarm() { g_armed = false; }

// Prints the backtrace of the first allocation seen while armed (call after disarm()). Frames of
// statically linked code show as "exe(+0xoffset)": resolve them with addr2line -Cfe <exe> 0xoffset.
void print_first_allocation() {
  if (g_nframes == 0) return;
  std::fprintf(stderr, "first heap allocation while armed (of %ld malloc-family, %ld operator new):\n",
               g_malloc_calls, g_new_calls);
  char** sym = backtrace_symbols(g_frames, g_nframes);
  for (int i = 0; i < g_nframes; ++i) std::fprintf(stderr, "  #%d %s\n", i, sym ? sym[i] : "?");
  std::free(sym);
}

}  // namespace alloc_probe

#if defined(__GLIBC__)
// Interpose the C allocator (glibc's documented "replacing malloc" mechanism; the memory still
// comes from glibc, so glibc's free() stays valid and need not be replaced).
extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void* __libc_memalign(std::size_t, std::size_t);

void* malloc(std::size_t n) {
  alloc_probe::record();
  return __libc_malloc(n);
}
void* calloc(std::size_t n, std::size_t s) {
  alloc_probe::record();
  return __libc_calloc(n, s);
}
void* realloc(void* p, std::size_t n) {
  alloc_probe::record();
  return __libc_realloc(p, n);
}
void* memalign(std::size_t a, std::size_t n) {
  alloc_probe::record();
  return __libc_memalign(a, n);
}
void* aligned_alloc(std::size_t a, std::size_t n) {
  alloc_probe::record();
  return __libc_memalign(a, n);
}
int posix_memalign(void** p, std::size_t a, std::size_t n) {
  alloc_probe::record();
  *p = __libc_memalign(a, n);
  return *p ? 0 : 12;  // ENOMEM
}
}
#define ALLOC_PROBE_MALLOC 1
#else
#define ALLOC_PROBE_MALLOC 0
#endif

// Counting global operator new/delete (all replaceable forms).
namespace {
void* counted_new(std::size_t n) {
  if (alloc_probe::g_armed && !alloc_probe::g_in_probe) ++alloc_probe::g_new_calls;
  if (!ALLOC_PROBE_MALLOC) alloc_probe::record();  // otherwise malloc records it
  void* p = std::malloc(n ? n : 1);
  if (!p) throw std::bad_alloc();
  return p;
}
void* counted_new_aligned(std::size_t n, std::align_val_t a) {
  if (alloc_probe::g_armed && !alloc_probe::g_in_probe) ++alloc_probe::g_new_calls;
  if (!ALLOC_PROBE_MALLOC) alloc_probe::record();
  const std::size_t al = static_cast<std::size_t>(a);
  void* p = std::aligned_alloc(al, ((n ? n : 1) + al - 1) / al * al);
  if (!p) throw std::bad_alloc();
  return p;
}
}  // namespace

void* operator new(std::size_t n) { return counted_new(n); }
void* operator new[](std::size_t n) { return counted_new(n); }
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  try {
    return counted_new(n);
  } catch (...) {
    return nullptr;
  }
}
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept {
  try {
    return counted_new(n);
  } catch (...) {
    return nullptr;
  }
}
void* operator new(std::size_t n, std::align_val_t a) { return counted_new_aligned(n, a); }
void* operator new[](std::size_t n, std::align_val_t a) { return counted_new_aligned(n, a); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
