// The registry of worlds behind sinew_world_id handles, and the per-thread last error.
#include <array>
#include <cmath>
#include <mutex>
#include <new>

#include "engine/api/capi_internal.hpp"
#include "engine/core/format.hpp"

namespace sinew::capi {

namespace {

// A fixed table, so looking a world up never races with another thread creating one (slots never
// move). Index 0 is unused so a zeroed handle is never valid.
constexpr std::size_t kMaxWorlds = 256;
struct WorldSlot {
    WorldEntry* entry = nullptr;  ///< allocated through entry->hooks
    std::uint32_t generation = 0;
};
std::array<WorldSlot, kMaxWorlds> g_worlds;
std::mutex g_registry_mutex;  // guards creation and destruction only
thread_local std::string g_last_error;

std::string describe(sinew_world_id id) {
    return "world {index " + std::to_string(id.index) + ", generation " + std::to_string(id.generation) + "}";
}

}  // namespace

sinew_status fail(sinew_status status, std::string message) {
    g_last_error = std::move(message);
    log_message(SINEW_LOG_ERROR, g_last_error);
    return status;
}

sinew_status invalid(const char* fn, const std::string& what) {
    return fail(SINEW_ERROR_INVALID_ARGUMENT, std::string(fn) + ": " + what);
}

sinew_status null_arg(const char* fn, const char* name) {
    return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": " + name + " is NULL");
}

void clear_error() { g_last_error.clear(); }

bool finite(const sinew_vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

WorldEntry* find_entry(sinew_world_id id, const char* fn) {
    if (id.generation == 0) {
        fail(SINEW_ERROR_STALE_ID, std::string(fn) + ": world is the null handle");
        return nullptr;
    }
    if (id.index == 0 || id.index >= kMaxWorlds || !g_worlds[id.index].entry ||
        g_worlds[id.index].generation != id.generation) {
        fail(SINEW_ERROR_STALE_ID, std::string(fn) + ": " + describe(id) + " is destroyed or was never created");
        return nullptr;
    }
    return g_worlds[id.index].entry;
}

World* find_world(sinew_world_id id, const char* fn) {
    WorldEntry* e = find_entry(id, fn);
    return e ? e->world.get() : nullptr;
}

sinew_status check_not_stepping(const World* w, const char* fn) {
    if (w->in_step()) return fail(SINEW_ERROR_IN_STEP, std::string(fn) + ": the world is stepping");
    return SINEW_OK;
}

sinew_world_id world_of(sinew_body_id id) { return {id.world & 0xFFFFu, id.world >> 16}; }

std::uint32_t pack_world(sinew_world_id id) { return (id.generation << 16) | (id.index & 0xFFFFu); }

BodyId find_body(sinew_body_id id, const char* fn, World** world) {
    World* w = find_world(world_of(id), fn);
    if (!w) return {};
    BodyId b{id.index, id.generation};
    if (!w->rigid().valid(b)) {
        fail(SINEW_ERROR_STALE_ID, std::string(fn) + ": body {index " + std::to_string(id.index) + ", generation " +
                                       std::to_string(id.generation) + "} is null, destroyed or not in world " +
                                       std::to_string(id.world));
        return {};
    }
    *world = w;
    return b;
}

namespace {

void delete_entry(WorldEntry* e) {
    const HostHooks hooks = e->hooks;
    e->~WorldEntry();
    hooks.deallocate(e, sizeof(WorldEntry));
}

}  // namespace

sinew_world_id register_world(std::unique_ptr<World> world) {
    // The entry is made outside the registry lock: the host's allocator may call back into the library.
    const HostHooks hooks = current_hooks();
    void* memory = hooks.allocate(sizeof(WorldEntry), alignof(WorldEntry));
    WorldEntry* entry;
    try {
        entry = new (memory) WorldEntry(std::move(world), hooks);
    } catch (...) {
        hooks.deallocate(memory, sizeof(WorldEntry));
        throw;
    }
    std::lock_guard<std::mutex> lock(g_registry_mutex);
    for (std::uint32_t i = 1; i < kMaxWorlds; ++i) {
        WorldSlot& s = g_worlds[i];
        if (s.entry) continue;
        s.entry = entry;
        // Generations stay within 16 bits: body handles pack the world's index and generation.
        s.generation = (s.generation % 0xFFFFu) + 1;
        const sinew_world_id id{i, s.generation};
        entry->events.set_world_tag(pack_world(id));
        return id;
    }
    delete_entry(entry);
    throw std::runtime_error("too many worlds (at most " + std::to_string(kMaxWorlds - 1) + " at once)");
}

void unregister_world(sinew_world_id id) {
    WorldEntry* entry;
    {
        std::lock_guard<std::mutex> lock(g_registry_mutex);
        entry = g_worlds[id.index].entry;
        g_worlds[id.index].entry = nullptr;
    }
    if (entry) delete_entry(entry);  // outside the lock, as its allocation was
}

}  // namespace sinew::capi

extern "C" const char* sinew_last_error(void) { return sinew::capi::g_last_error.c_str(); }
