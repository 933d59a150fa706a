// The host's allocation hooks (sinew_set_allocator) as a C++ allocator, for the C API's per-world memory.
// Each world copies the hooks current at its creation, so changing them later never frees a block with
// a different allocator than the one that made it.
#pragma once

#include <cstddef>
#include <new>
#include <vector>

#include "engine/api/sinew.h"

namespace sinew::capi {

/// The hooks a world was created with (alloc == nullptr: malloc/free).
struct HostHooks {
    void* (*alloc)(std::size_t size, std::size_t alignment, void* user) = nullptr;
    void (*free)(void* ptr, std::size_t size, void* user) = nullptr;
    void* user = nullptr;

    /// Throws std::bad_alloc if the hook (or malloc) returns NULL.
    void* allocate(std::size_t bytes, std::size_t alignment) const;
    void deallocate(void* p, std::size_t bytes) const noexcept;
    bool operator==(const HostHooks& o) const { return alloc == o.alloc && free == o.free && user == o.user; }
};

/// The hooks set by the last sinew_set_allocator() (copied under a lock).
HostHooks current_hooks();

/// A std allocator over a world's hooks (stateful: containers keep a copy).
template <class T>
struct HostAllocator {
    using value_type = T;
    HostHooks hooks;

    explicit HostAllocator(const HostHooks& h) : hooks(h) {}
    template <class U>
    HostAllocator(const HostAllocator<U>& o) : hooks(o.hooks) {}  // NOLINT: rebinding is implicit
    T* allocate(std::size_t n) { return static_cast<T*>(hooks.allocate(n * sizeof(T), alignof(T))); }
    void deallocate(T* p, std::size_t n) noexcept { hooks.deallocate(p, n * sizeof(T)); }
    template <class U>
    bool operator==(const HostAllocator<U>& o) const { return hooks == o.hooks; }
    template <class U>
    bool operator!=(const HostAllocator<U>& o) const { return !(hooks == o.hooks); }
};

template <class T>
using HostVector = std::vector<T, HostAllocator<T>>;

}  // namespace sinew::capi
