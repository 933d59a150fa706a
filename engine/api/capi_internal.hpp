// Internals shared by the C API's translation units: the world registry, handle checks, the per-thread
// last error, and the guard that turns C++ exceptions into status codes so none crosses the C boundary.
#pragma once

#include <cstdint>
#include <cstring>
#include <memory>
#include <string>

#include "engine/api/capi_alloc.hpp"
#include "engine/api/capi_events.hpp"
#include "engine/api/sinew.h"
#include "engine/world/world.hpp"

namespace sinew::capi {

/// Fails a call: records the message for sinew_last_error(), sends it to the log callback at
/// SINEW_LOG_ERROR, and returns the status.
sinew_status fail(sinew_status status, std::string message);
/// fail(SINEW_ERROR_INVALID_ARGUMENT, "FN: WHAT").
sinew_status invalid(const char* fn, const std::string& what);
/// fail(SINEW_ERROR_NULL_ARGUMENT, "FN: NAME is NULL").
sinew_status null_arg(const char* fn, const char* name);
void clear_error();
/// Sends a message to the host's log callback, if one is set (capi_hooks.cpp).
void log_message(sinew_log_level level, const std::string& message);

/// What a world handle refers to: the World and the C API's per-world state. Allocated, with its event
/// buffers, through the host hooks current at the world's creation (kept in `hooks`).
struct WorldEntry {
    WorldEntry(std::unique_ptr<World> w, const HostHooks& h) : hooks(h), world(std::move(w)), events(*world, h) {}
    HostHooks hooks;
    std::unique_ptr<World> world;
    WorldEvents events;  ///< after `world`: destroyed first, it unregisters its pipeline hooks
};

/// The live world for a handle, or nullptr after recording SINEW_ERROR_STALE_ID naming `fn`.
World* find_world(sinew_world_id id, const char* fn);
WorldEntry* find_entry(sinew_world_id id, const char* fn);
/// SINEW_ERROR_IN_STEP (recorded, naming fn) if the world is stepping, else SINEW_OK.
sinew_status check_not_stepping(const World* w, const char* fn);
/// The body id inside its world, or a null id after recording the error.
BodyId find_body(sinew_body_id id, const char* fn, World** world);
/// Body handles carry their world as (generation << 16) | index.
std::uint32_t pack_world(sinew_world_id id);
/// Logs a warning naming soft body `id` if it was created past its method's documented stability limit
/// at the step it takes (soft/soft_stability.hpp).
void warn_if_unstable(const char* fn, sinew_world_id world, const World& w, SoftBodyId id);
sinew_world_id world_of(sinew_body_id id);

/// Registers a world (its entry is allocated through the current host hooks). Throws on failure, and the
/// world is then destroyed.
sinew_world_id register_world(std::unique_ptr<World> world);
void unregister_world(sinew_world_id id);

inline Vec3 to_vec(const sinew_vec3& v) { return Vec3(Real(v.x), Real(v.y), Real(v.z)); }
inline sinew_vec3 to_c(const Vec3& v) { return {float(v.x()), float(v.y()), float(v.z())}; }
inline Quat to_quat(const sinew_quat& q) { return Quat(Real(q.w), Real(q.x), Real(q.y), Real(q.z)); }
inline CollisionFilter to_filter(const sinew_filter& f) { return {f.category_bits, f.mask_bits, f.group_index}; }
inline sinew_filter to_c(const CollisionFilter& f) { return {f.category, f.mask, f.group}; }
inline sinew_transform to_c(const Transform& t) {
    return {to_c(t.p), {float(t.q.x()), float(t.q.y()), float(t.q.z()), float(t.q.w())}};
}
bool finite(const sinew_vec3& v);
/// A quaternion that normalises: finite and not (nearly) zero.
inline bool unit_quat_ok(const sinew_quat& q) {
    const float n2 = q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w;
    return std::isfinite(n2) && n2 > 1e-12f;
}
/// The shape a sinew_shape_def describes (engine/api/capi_shape.cpp); ShapeError names the bad field,
/// starting with `where` ("def->shape").
Shape make_shape(const sinew_shape_def& d, const char* where);

/// The integer a C caller stored in an enum field. Reading an out-of-range value through the C++ enum
/// type would be undefined behaviour (UBSan flags it), so the bytes are read as an int.
template <class E>
int enum_value(const E& e) {
    static_assert(sizeof(E) == sizeof(int), "C enums are int-sized");
    int v;
    std::memcpy(&v, &e, sizeof v);
    return v;
}

/// Runs f() (returning sinew_status) and maps every exception to a status and message naming `fn`.
template <class F>
sinew_status guarded(const char* fn, F&& f) noexcept {
    try {
        clear_error();
        return f();
    } catch (const std::bad_alloc&) {
        return fail(SINEW_ERROR_INTERNAL, std::string(fn) + ": out of memory");
    } catch (const std::invalid_argument& e) {  // RigidError, ShapeError: bad user data
        return fail(SINEW_ERROR_INVALID_ARGUMENT, std::string(fn) + ": " + e.what());
    } catch (const std::exception& e) {
        return fail(SINEW_ERROR_INTERNAL, std::string(fn) + ": " + e.what());
    } catch (...) {
        return fail(SINEW_ERROR_INTERNAL, std::string(fn) + ": unknown error");
    }
}

}  // namespace sinew::capi
