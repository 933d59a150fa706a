// C API: worlds and stepping.
#include <cmath>

#include "engine/api/capi_internal.hpp"
#include "rigid/joint_set.hpp"
#include "engine/core/format.hpp"

using namespace sinew;
using namespace sinew::capi;

namespace {

// One error line per body whose state turned non-finite in the steps just taken (World::faults), naming
// the body's handle, the first step, the quantity and the method's limit; the last line is also the
// call's last error. A body that blew up in several of the steps is named once, with the count.
sinew_status report_faults(const char* fn, const sinew_world_id& world, const std::vector<StepFault>& faults) {
    std::vector<std::string> lines;
    std::vector<bool> counted(faults.size(), false);
    for (std::size_t i = 0; i < faults.size(); ++i) {
        if (counted[i]) continue;
        const StepFault& f = faults[i];
        int repeats = 0;
        for (std::size_t j = i + 1; j < faults.size(); ++j)
            if (!counted[j] && faults[j].system == f.system && faults[j].index == f.index &&
                faults[j].generation == f.generation) {
                counted[j] = true;
                ++repeats;
            }
        StepFault first = f;
        if (repeats > 0) first.what += " (and again in " + std::to_string(repeats) + " later steps of this call)";
        std::string line = std::string(fn) + ": step " + std::to_string(f.step) + ": " + f.system_name() +
                           " body {world " + std::to_string(pack_world(world)) + ", index " + std::to_string(f.index) +
                           ", generation " + std::to_string(f.generation) + "}: " + first.outcome();
        lines.push_back(std::move(line));
    }
    for (std::size_t i = 0; i + 1 < lines.size(); ++i) log_message(SINEW_LOG_ERROR, lines[i]);
    return fail(SINEW_ERROR_NON_FINITE, lines.back());
}

/// A C caller's threads as a TaskSystem (empty callbacks: the world's own pool), or the failure naming
/// function `fn` and the fields, each written after `field` ("def->" or "").
sinew_status task_system_of(const char* fn, const std::string& field, int worker_count, sinew_enqueue_task_fn* enqueue,
                            sinew_finish_task_fn* finish, void* context, TaskSystem& out) {
    const std::string where = std::string(fn) + ": ";
    if ((enqueue == nullptr) != (finish == nullptr))
        return fail(SINEW_ERROR_INVALID_ARGUMENT,
                    where + field + "enqueue_task and " + field + "finish_task must be set together");
    if (worker_count < 1 || worker_count > kMaxWorkers)
        return fail(SINEW_ERROR_INVALID_ARGUMENT, where + field + "worker_count = " + std::to_string(worker_count) +
                                                      " must be in [1, " + std::to_string(kMaxWorkers) + "]");
    out = TaskSystem{};
    if (enqueue) {
        // sinew_task_fn and TaskFn have the same signature (begin, end, worker, context); only the
        // language linkage of the C caller's function types differs.
        out.worker_count = worker_count;
        out.enqueue = reinterpret_cast<void* (*)(TaskFn, int, int, void*, void*)>(enqueue);
        out.finish = finish;
        out.user_context = context;
    }
    return SINEW_OK;
}

}  // namespace

extern "C" {

sinew_world_def sinew_world_def_default(void) {
    const WorldSettings ws;
    sinew_world_def d;
    d.gravity = to_c(ws.rigid.gravity);
    d.time_step = float(ws.time_step);
    d.max_steps_per_frame = ws.max_steps_per_frame;
    d.solver = SINEW_SOLVER_SOFT_STEP;
    d.velocity_iterations = ws.rigid.velocity_iterations;
    d.enable_sleep = ws.rigid.sleeping ? 1 : 0;
    d.worker_count = ws.workers;
    d.enqueue_task = nullptr;
    d.finish_task = nullptr;
    d.user_task_context = nullptr;
    return d;
}

sinew_status sinew_world_create(const sinew_world_def* def, sinew_world_id* out) {
    return guarded("sinew_world_create", [&] {
        const char* fn = "sinew_world_create";
        if (!def) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": def is NULL");
        if (!out) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": out is NULL");
        if (!finite(def->gravity))
            return fail(SINEW_ERROR_INVALID_ARGUMENT, std::string(fn) + ": def->gravity must be finite");
        if (!(def->time_step > 0 && def->time_step <= 1))
            return fail(SINEW_ERROR_INVALID_ARGUMENT,
                        std::string(fn) + ": def->time_step = " + to_text(def->time_step) + " must be in (0, 1] s");
        const int solver = enum_value(def->solver);
        if (solver < SINEW_SOLVER_SOFT_STEP || solver > SINEW_SOLVER_NEWTON)
            return fail(SINEW_ERROR_INVALID_ARGUMENT,
                        std::string(fn) + ": def->solver = " + std::to_string(solver) + " is not a sinew_solver");
        if (def->enable_sleep != 0 && def->enable_sleep != 1)
            return fail(SINEW_ERROR_INVALID_ARGUMENT, std::string(fn) + ": def->enable_sleep must be 0 or 1");
        WorldSettings ws;
        if (sinew_status s = task_system_of(fn, "def->", def->worker_count, def->enqueue_task,
                                            def->finish_task, def->user_task_context, ws.tasks))
            return s;
        ws.workers = def->worker_count;
        ws.time_step = Real(def->time_step);
        ws.max_steps_per_frame = def->max_steps_per_frame;
        ws.rigid.gravity = to_vec(def->gravity);
        ws.rigid.velocity_iterations = def->velocity_iterations;
        ws.rigid.sleeping = def->enable_sleep == 1;
        switch (solver) {
            case SINEW_SOLVER_SOFT_STEP: ws.rigid.solver = RigidSolverKind::SoftStep; break;
            case SINEW_SOLVER_SPLIT_IMPULSE: ws.rigid.solver = RigidSolverKind::SplitImpulse; break;
            case SINEW_SOLVER_BAUMGARTE: ws.rigid.solver = RigidSolverKind::Baumgarte; break;
            default: ws.rigid.solver = RigidSolverKind::Newton; break;
        }
        auto world = std::make_unique<World>(ws);  // validates the rest (throws invalid_argument)
        *out = register_world(std::move(world));
        return SINEW_OK;
    });
}

sinew_status sinew_world_destroy(sinew_world_id id) {
    return guarded("sinew_world_destroy", [&] {
        World* w = find_world(id, "sinew_world_destroy");
        if (!w) return SINEW_ERROR_STALE_ID;
        if (sinew_status s = check_not_stepping(w, "sinew_world_destroy")) return s;
        unregister_world(id);
        return SINEW_OK;
    });
}

sinew_status sinew_world_set_workers(sinew_world_id id, int worker_count, sinew_enqueue_task_fn* enqueue_task,
                                     sinew_finish_task_fn* finish_task, void* user_task_context) {
    return guarded("sinew_world_set_workers", [&] {
        const char* fn = "sinew_world_set_workers";
        World* w = find_world(id, fn);
        if (!w) return SINEW_ERROR_STALE_ID;
        if (sinew_status s = check_not_stepping(w, fn)) return s;
        TaskSystem tasks;
        if (sinew_status s = task_system_of(fn, "", worker_count, enqueue_task, finish_task,
                                            user_task_context, tasks))
            return s;
        w->set_threads(worker_count, tasks);
        return SINEW_OK;
    });
}

sinew_status sinew_world_step(sinew_world_id id, float frame_dt, int* steps_taken, float* alpha) {
    return guarded("sinew_world_step", [&] {
        WorldEntry* e = find_entry(id, "sinew_world_step");
        if (!e) return SINEW_ERROR_STALE_ID;
        World* w = e->world.get();
        if (sinew_status s = check_not_stepping(w, "sinew_world_step")) return s;
        if (!std::isfinite(frame_dt) || frame_dt < 0)
            return fail(SINEW_ERROR_INVALID_ARGUMENT,
                        "sinew_world_step: frame_dt = " + to_text(frame_dt) + " must be finite and >= 0");
        const double h = double(w->settings().time_step);
        const double pending = double(w->interpolation_alpha()) * h + double(frame_dt);
        e->events.clear();
        const int n = w->advance(Real(frame_dt));
        e->events.gather_sensors(w->sensor_events());
        const std::vector<StepFault> faults = w->faults();  // a log callback below may step the world again
        // The accumulator cap drops what it could not simulate: tell the host (a frame hitch or a world
        // too slow for its time step).
        const double left = pending - n * h;
        if (n == w->settings().max_steps_per_frame && left >= h)
            log_message(SINEW_LOG_WARNING,
                        "sinew_world_step: frame_dt = " + to_text(frame_dt) + " s needed more than max_steps_per_frame = " +
                            std::to_string(n) + " steps; " + to_text(left - double(w->interpolation_alpha()) * h) +
                            " s of simulated time were dropped");
        if (steps_taken) *steps_taken = n;
        if (alpha) *alpha = float(w->interpolation_alpha());
        if (!faults.empty()) return report_faults("sinew_world_step", id, faults);
        return SINEW_OK;
    });
}

sinew_status sinew_world_step_fixed(sinew_world_id id) {
    return guarded("sinew_world_step_fixed", [&] {
        WorldEntry* e = find_entry(id, "sinew_world_step_fixed");
        if (!e) return SINEW_ERROR_STALE_ID;
        if (sinew_status s = check_not_stepping(e->world.get(), "sinew_world_step_fixed")) return s;
        e->events.clear();
        e->world->step();
        e->events.gather_sensors(e->world->sensor_events());
        if (!e->world->faults().empty()) return report_faults("sinew_world_step_fixed", id, e->world->faults());
        return SINEW_OK;
    });
}

sinew_status sinew_world_get_events(sinew_world_id id, sinew_events* out) {
    return guarded("sinew_world_get_events", [&] {
        if (!out) return fail(SINEW_ERROR_NULL_ARGUMENT, "sinew_world_get_events: out is NULL");
        WorldEntry* e = find_entry(id, "sinew_world_get_events");
        if (!e) return SINEW_ERROR_STALE_ID;
        *out = e->events.view();
        return SINEW_OK;
    });
}

sinew_status sinew_world_body_count(sinew_world_id id, int* out) {
    return guarded("sinew_world_body_count", [&] {
        if (!out) return fail(SINEW_ERROR_NULL_ARGUMENT, "sinew_world_body_count: out is NULL");
        World* w = find_world(id, "sinew_world_body_count");
        if (!w) return SINEW_ERROR_STALE_ID;
        *out = int(w->rigid().body_count());
        return SINEW_OK;
    });
}

sinew_status sinew_world_get_counters(sinew_world_id id, sinew_world_counters* out) {
    const char* fn = "sinew_world_get_counters";
    return guarded(fn, [&] {
        if (!out) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": out is NULL");
        World* w = find_world(id, fn);
        if (!w) return SINEW_ERROR_STALE_ID;
        const RigidSystem& r = w->rigid();
        sinew_world_counters c{};
        c.body_count = int(r.body_count());
        c.awake_body_count = int(r.awake_count());
        c.soft_body_count = int(w->soft().body_count() - w->coupling().fem_embedding().count());  // not embed-fem's proxies
        c.joint_count = int(r.joints().count());
        for (const ContactManifold& m : r.contacts()) {
            if (m.manifold.count == 0) continue;
            ++c.contact_count;
            c.contact_point_count += m.manifold.count;
        }
        c.step_count = w->step_count();
        const Pipeline& p = w->pipeline();
        c.step_ms = float(p.last_step_ms());
        for (int stage = 0; stage < 4; ++stage)
            for (int sys = 0; sys < p.system_count(); ++sys) c.stage_ms[stage] += float(p.timer(sys, Stage(stage)).last_ms);
        *out = c;
        return SINEW_OK;
    });
}

sinew_status sinew_world_get_transforms(sinew_world_id id, sinew_body_id* ids, sinew_transform* transforms,
                                        int capacity, int* count) {
    return guarded("sinew_world_get_transforms", [&] {
        if (!count) return fail(SINEW_ERROR_NULL_ARGUMENT, "sinew_world_get_transforms: count is NULL");
        if (capacity < 0)
            return fail(SINEW_ERROR_INVALID_ARGUMENT,
                        "sinew_world_get_transforms: capacity = " + std::to_string(capacity) + " must be >= 0");
        World* w = find_world(id, "sinew_world_get_transforms");
        if (!w) return SINEW_ERROR_STALE_ID;
        const RigidSystem& r = w->rigid();
        int n = 0;
        // Slot order, no allocation: walk the slots directly.
        for (std::uint32_t s = 0; s < r.slot_count() && n < capacity; ++s) {
            if (!r.slot_alive(s)) continue;
            BodyId b = r.id_of_slot(s);
            if (ids) ids[n] = {pack_world(id), b.index, b.generation};
            if (transforms) transforms[n] = to_c(r.transform(b));
            ++n;
        }
        *count = n;
        return SINEW_OK;
    });
}

}  // extern "C"
