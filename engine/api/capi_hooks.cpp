// Host hooks: the allocator (sinew_set_allocator) and the log callback (sinew_set_log_callback).
#include <cstdlib>
#include <mutex>

#include "engine/api/capi_alloc.hpp"
#include "engine/api/capi_internal.hpp"

namespace sinew::capi {

namespace {

std::mutex g_hooks_mutex;  // guards both settings; they change rarely and are read under it
HostHooks g_hooks;
sinew_log_fn g_log_fn = nullptr;
void* g_log_user = nullptr;

}  // namespace

void* HostHooks::allocate(std::size_t bytes, std::size_t alignment) const {
    if (bytes == 0) bytes = 1;
    void* p = nullptr;
    if (alloc) {
        p = alloc(bytes, alignment, user);
    } else if (alignment <= alignof(std::max_align_t)) {
        p = std::malloc(bytes);
    } else {
        p = std::aligned_alloc(alignment, (bytes + alignment - 1) / alignment * alignment);
    }
    if (!p) throw std::bad_alloc();
    return p;
}

void HostHooks::deallocate(void* p, std::size_t bytes) const noexcept {
    if (!p) return;
    if (bytes == 0) bytes = 1;
    if (alloc)
        free(p, bytes, user);
    else
        std::free(p);
}

HostHooks current_hooks() {
    std::lock_guard<std::mutex> lock(g_hooks_mutex);
    return g_hooks;
}

void log_message(sinew_log_level level, const std::string& message) {
    sinew_log_fn fn;
    void* user;
    {
        std::lock_guard<std::mutex> lock(g_hooks_mutex);
        fn = g_log_fn;
        user = g_log_user;
    }
    // Called outside the lock: the callback may call back into the library (even set another callback).
    if (fn) fn(level, message.c_str(), user);
}

}  // namespace sinew::capi

using namespace sinew::capi;

extern "C" {

sinew_status sinew_set_log_callback(sinew_log_fn fn, void* user) {
    {
        std::lock_guard<std::mutex> lock(g_hooks_mutex);
        g_log_fn = fn;
        g_log_user = fn ? user : nullptr;
    }
    clear_error();
    return SINEW_OK;
}

sinew_status sinew_set_allocator(const sinew_allocator* allocator) {
    return guarded("sinew_set_allocator", [&] {
        HostHooks h;
        if (allocator) {
            if (!allocator->alloc)
                return fail(SINEW_ERROR_NULL_ARGUMENT, "sinew_set_allocator: allocator->alloc is NULL");
            if (!allocator->free)
                return fail(SINEW_ERROR_NULL_ARGUMENT, "sinew_set_allocator: allocator->free is NULL");
            h.alloc = allocator->alloc;
            h.free = allocator->free;
            h.user = allocator->user;
        }
        std::lock_guard<std::mutex> lock(g_hooks_mutex);
        g_hooks = h;
        return SINEW_OK;
    });
}

}  // extern "C"
