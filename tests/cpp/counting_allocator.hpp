// SPDX-License-Identifier: BSD-3-Clause
// Replaces the global operator new and delete, and malloc and its kin (Eigen's aligned_allocator, which holds PCL's
// clouds, calls malloc, not operator new), with versions that count allocations while asked to: include it in
// exactly one file of an executable of its own (tests/cpp/realtime_test.cpp, bench/realtime.cpp). Under
// AddressSanitizer, which must see every malloc itself, only operator new is counted (kCountsMalloc is false).
#pragma once

#include <atomic>
#include <cerrno>
#include <cstddef>
#include <cstdlib>
#include <new>

namespace {

std::atomic<bool> counting{false};
std::atomic<long> allocations{0};
// Breakpoints here (gdb: `break on_counted_allocation`, then `bt`) show where a counted allocation comes from, and
// in which frame (on_frame's argument).
[[gnu::noinline, maybe_unused]] void on_frame(int k) { asm volatile("" : : "r"(k)); }
[[gnu::noinline]] void on_counted_allocation() { allocations.fetch_add(1, std::memory_order_relaxed); }

#if defined(__SANITIZE_ADDRESS__)
constexpr bool kCountsMalloc = false;
void* raw_malloc(std::size_t size) { return std::malloc(size); }
void* raw_memalign(std::size_t alignment, std::size_t size) {
    void* p = nullptr;
    return posix_memalign(&p, alignment, size) == 0 ? p : nullptr;
}
void raw_free(void* p) { std::free(p); }
#else
}  // namespace
// glibc's allocator under its own names: the replacements below count, then call these (glibc documents replacing
// malloc, calloc, realloc and free together; its memalign family stays its own and frees through free).
extern "C" void* __libc_malloc(std::size_t);
extern "C" void* __libc_calloc(std::size_t, std::size_t);
extern "C" void* __libc_realloc(void*, std::size_t);
extern "C" void* __libc_memalign(std::size_t, std::size_t);
extern "C" void __libc_free(void*);
namespace {
constexpr bool kCountsMalloc = true;
void* raw_malloc(std::size_t size) { return __libc_malloc(size); }
void* raw_memalign(std::size_t alignment, std::size_t size) { return __libc_memalign(alignment, size); }
void raw_free(void* p) { __libc_free(p); }
#endif

void count() {
    if (counting.load(std::memory_order_relaxed)) on_counted_allocation();
}

void* allocate(std::size_t size, std::size_t alignment = 0) {
    count();
    if (size == 0) size = 1;
    return alignment > alignof(std::max_align_t) ? raw_memalign(alignment, size) : raw_malloc(size);
}

void* allocate_or_throw(std::size_t size, std::size_t alignment = 0) {
    void* p = allocate(size, alignment);
    if (!p) throw std::bad_alloc();
    return p;
}

}  // namespace

void* operator new(std::size_t size) { return allocate_or_throw(size); }
void* operator new[](std::size_t size) { return allocate_or_throw(size); }
void* operator new(std::size_t size, const std::nothrow_t&) noexcept { return allocate(size); }
void* operator new[](std::size_t size, const std::nothrow_t&) noexcept { return allocate(size); }
void* operator new(std::size_t size, std::align_val_t a) { return allocate_or_throw(size, std::size_t(a)); }
void* operator new[](std::size_t size, std::align_val_t a) { return allocate_or_throw(size, std::size_t(a)); }
void* operator new(std::size_t size, std::align_val_t a, const std::nothrow_t&) noexcept {
    return allocate(size, std::size_t(a));
}
void* operator new[](std::size_t size, std::align_val_t a, const std::nothrow_t&) noexcept {
    return allocate(size, std::size_t(a));
}
void operator delete(void* p) noexcept { raw_free(p); }
void operator delete[](void* p) noexcept { raw_free(p); }
void operator delete(void* p, std::size_t) noexcept { raw_free(p); }
void operator delete[](void* p, std::size_t) noexcept { raw_free(p); }
void operator delete(void* p, std::align_val_t) noexcept { raw_free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { raw_free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { raw_free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { raw_free(p); }

#if !defined(__SANITIZE_ADDRESS__)
extern "C" {
void* malloc(std::size_t size) {
    count();
    return __libc_malloc(size);
}
void* calloc(std::size_t n, std::size_t size) {
    count();
    return __libc_calloc(n, size);
}
void* realloc(void* p, std::size_t size) {
    count();
    return __libc_realloc(p, size);
}
void free(void* p) { __libc_free(p); }
int posix_memalign(void** out, std::size_t alignment, std::size_t size) {
    count();
    void* p = __libc_memalign(alignment, size);
    if (!p) return ENOMEM;
    *out = p;
    return 0;
}
void* aligned_alloc(std::size_t alignment, std::size_t size) {
    count();
    return __libc_memalign(alignment, size);
}
}
#endif

// Allocations made by `step` (operator new of any form, and malloc and its kin where kCountsMalloc; any thread).
template <class F>
long allocations_in(F&& step) {
    allocations = 0;
    counting = true;
    step();
    counting = false;
    return allocations.load();
}

