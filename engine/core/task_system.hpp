// Threads come from the host: a game engine owns its workers and lends them to physics (Box2D v3's
// enqueueTask/finishTask callbacks, Jolt's JobSystem). Sinew asks for them through TaskSystem and
// never creates a thread behind the host's back; ThreadPool (engine/core/thread_pool.hpp) is the small
// default a world uses when the host brings none.
//
// Work is split by ParallelRegion, in Box2D v3's solver-stage shape: the calling thread runs the step
// and publishes stages (a loop over items cut into blocks); up to worker_count - 1 helper tasks join in
// and claim blocks of the current stage with one atomic each. Helpers spin between the stages of one
// region, so a region of a hundred short stages (the soft step's colours times sub-steps) costs one
// enqueue per helper, not one per stage. The work never waits for a helper to start: the calling thread
// can run every block itself, so a host that runs tasks late, one at a time, or inline inside enqueue is
// correct, only slower. The region's end does wait for each helper task (finish), so a host's finish
// must run a task no worker has started.
//
// Determinism: a stage's result must not depend on which worker runs which block. The stages written
// for it make each item write only its own outputs (a colour's contact batches share no moving body;
// a pair's manifolds go to the pair's own slot), and reductions run afterwards in item order.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <mutex>
#include <thread>
#include <type_traits>

namespace sinew {

/// Runs items [begin, end) of a task on the worker with index `worker` (0 <= worker < worker_count).
using TaskFn = void (*)(int begin, int end, int worker, void* task_context);

/// The host's job system. `enqueue` runs `task` over items [0, item_count), in ranges of at least
/// `min_range` items, on its workers, and returns a handle for `finish`; it may instead run the task on
/// the calling thread before returning and return null (then `finish` is not called), but must not wait
/// for it on another thread. `finish` returns once the task has run, running it itself if no worker has
/// started it. Sinew enqueues only tasks of one item (one per helper of a region) and runs its own share
/// on the calling thread. Workers must use the calling thread's floating-point mode (rounding,
/// flush-to-zero), or results depend on which worker ran what.
struct TaskSystem {
    /// Threads that may work on one step at the same time, the calling thread included (1 = serial).
    int worker_count = 1;
    void* (*enqueue)(TaskFn task, int item_count, int min_range, void* task_context, void* user_context) = nullptr;
    void (*finish)(void* user_task, void* user_context) = nullptr;
    void* user_context = nullptr;

    bool parallel() const { return worker_count > 1 && enqueue != nullptr && finish != nullptr; }
};

/// The most workers a region uses (a bound for per-worker scratch arrays).
constexpr int kMaxWorkers = 64;

/// A parallel region: see the file comment. One run() at a time per region object; a run() inside a
/// run() of the same region on its calling thread joins the outer one (its helpers, its worker count),
/// so a stage's owner can open a region around code whose parts open their own.
class ParallelRegion {
public:
    ParallelRegion() = default;
    ParallelRegion(const ParallelRegion&) = delete;
    ParallelRegion& operator=(const ParallelRegion&) = delete;

    /// Runs body() on the calling thread with helpers from `tasks` (null or serial: no helpers) that
    /// join the stages body() publishes through for_each().
    template <class Body>
    void run(const TaskSystem* tasks, Body&& body) {
        if (running_) {
            body();
            return;
        }
        open(tasks);
        running_ = true;
        struct Closer {
            ParallelRegion* r;
            ~Closer() {
                r->running_ = false;
                r->close();
            }
        } closer{this};
        body();
    }

    /// Workers of the region in progress (1 outside run() or without helpers): scratch arrays indexed by
    /// a stage's `worker` need this many entries.
    int workers() const { return workers_; }

    /// A stage: fn(begin, end, worker) over items [0, count) in blocks (about count / (8 workers), at
    /// least min_block items unless the count is not a multiple), on this thread and the helpers; returns
    /// when every block is done. Outside run() or with one worker it is fn(0, count, 0). Only the thread
    /// that called run() publishes stages (no stage inside a stage). If a block throws, the stage's other
    /// blocks still finish (without running fn once an exception is held) and the first exception is
    /// rethrown here.
    template <class Fn>
    void for_each(int count, int min_block, Fn&& fn) {
        if (count <= 0) return;
        if (workers_ <= 1 || count <= min_block) {
            fn(0, count, 0);
            return;
        }
        using F = std::remove_reference_t<Fn>;
        publish(count, min_block, [](void* ctx, int b, int e, int w) { (*static_cast<F*>(ctx))(b, e, w); },
                const_cast<void*>(static_cast<const void*>(&fn)));
    }

private:
    using Thunk = void (*)(void* ctx, int begin, int end, int worker);
    // A stage's blocks are cut into one contiguous range per worker. Each worker starts on its own range
    // and then helps with the others' (Box2D v3 does the same): the same worker tends to get the same
    // contact batches, and so the same bodies, stage after stage, and they stay in its core's cache.
    // A range's claim word: [stage sequence : 32][blocks : 16][next block : 16]. Packing the stage and the
    // block count with the cursor lets a helper that slept through a stage change never claim a block of
    // the wrong stage, nor read the descriptor of a stage it did not claim in. The calling thread does not
    // write the ranges when it publishes: whoever claims first in a range for a stage sets it up (the
    // stage word gives the sequence and block count, so every worker cuts the same ranges), and a
    // worker's own range stays in its own cache from stage to stage.
    struct alignas(64) Range {
        std::atomic<std::uint64_t> claim{0};
    };
    void open(const TaskSystem* tasks);
    void close();
    void publish(int count, int min_block, Thunk thunk, void* ctx);
    /// Claims and runs blocks of stage `seq` (of `blocks` blocks), its own range first, until none is
    /// left or the stage moved on; returns how many it ran.
    int work_on(std::uint32_t seq, int blocks, int worker);
    /// Claims and runs blocks of range r while it has some in stage `seq`; returns how many it ran.
    int drain(int r, std::uint32_t seq, int blocks, int worker);
    /// Claims the next block of range r in stage `seq`, setting the range up if this is the stage's first
    /// claim in it; returns the block's index in the stage, or -1.
    int claim(int r, std::uint32_t seq, int blocks);
    static void helper_entry(int begin, int end, int worker, void* ctx);

    struct Helper {
        ParallelRegion* region;
        int worker;
        void* handle;
    };

    /// Runs block [begin, end) of the current stage, holding the first exception any block throws.
    void run_block(int begin, int end, int worker) noexcept;

    Range ranges_[kMaxWorkers];
    // Blocks the helpers finished in the current stage, each helper adding its count once it finds no
    // block left: kept off the line the spinning helpers read.
    alignas(64) std::atomic<int> done_{0};
    // The stage descriptor, on one cache line: a helper that sees a new stage word gets the rest with it.
    // The word is [sequence : 32][blocks : 32]; the other fields are written before it is stored and read
    // by a helper only once it holds a block of that stage.
    alignas(64) std::atomic<std::uint64_t> stage_{0};
    Thunk thunk_ = nullptr;
    void* ctx_ = nullptr;
    int count_ = 0;
    int block_ = 1;
    std::uint32_t seq_ = 0;  // the sequence of the stage published last
    int workers_ = 1;
    alignas(64) std::atomic<bool> exit_{false};
    std::atomic<bool> failed_{false};  // a block of the current stage threw (error_ holds it)
    std::mutex error_mutex_;
    std::exception_ptr error_;
    bool running_ = false;  // inside run(), on the thread that called it
    const TaskSystem* tasks_ = nullptr;
    std::thread::id owner_;
    Helper helpers_[kMaxWorkers];
};

/// fn(begin, end) over [0, count) in blocks of at least min_block on `region`'s workers, or once on this
/// thread when `region` is null: for a loop that a caller puts on the workers only past a size threshold.
template <class Fn>
void for_ranges(ParallelRegion* region, std::size_t count, int min_block, Fn&& fn) {
    if (region)
        region->for_each(int(count), min_block, [&](int begin, int end, int) { fn(std::size_t(begin), std::size_t(end)); });
    else
        fn(std::size_t(0), count);
}

}  // namespace sinew
