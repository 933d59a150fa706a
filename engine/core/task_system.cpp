// ParallelRegion: stages published by the calling thread, blocks claimed by helpers (task_system.hpp).
#include "engine/core/task_system.hpp"

#include <algorithm>
#include <cassert>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

namespace sinew {

namespace {

// A range's claim word: [stage sequence : 32][blocks : 16][next block : 16] (task_system.hpp).
constexpr std::uint64_t kField = 0xFFFF;
constexpr int kMaxBlocks = 8 * kMaxWorkers;  // a stage's blocks (publish), so a range's fit 16 bits
static_assert(kMaxBlocks <= int(kField), "a range's block count fits its field");

std::uint32_t seq_of(std::uint64_t c) { return std::uint32_t(c >> 32); }
int blocks_of(std::uint64_t c) { return int((c >> 16) & kField); }
int next_of(std::uint64_t c) { return int(c & kField); }
std::uint64_t claim_word(std::uint32_t seq, int blocks, int next) {
    return (std::uint64_t(seq) << 32) | (std::uint64_t(blocks) << 16) | std::uint64_t(next);
}
std::uint64_t stage_word(std::uint32_t seq, int blocks) { return (std::uint64_t(seq) << 32) | std::uint32_t(blocks); }
/// Whether sequence a comes after b. Sequences wrap at 2^32; a helper is at most the stages of one
/// region behind (far fewer than 2^31).
bool later(std::uint32_t a, std::uint32_t b) { return std::int32_t(a - b) > 0; }
/// Range r's first block when `blocks` blocks are cut among `workers` ranges.
int range_start(int blocks, int r, int workers) { return int(std::int64_t(blocks) * r / workers); }

/// One wait in a spin loop: a pause instruction for a while, then giving the core away, so helpers
/// spinning on more workers than cores (or under a sanitizer) do not starve the thread they wait for.
struct Backoff {
    int spins = 0;
    void wait() {
        if (spins < 1000) {
            ++spins;
#if defined(__x86_64__) || defined(__i386__)
            _mm_pause();
#endif
        } else {
            std::this_thread::yield();
        }
    }
};

}  // namespace

void ParallelRegion::open(const TaskSystem* tasks) {
    tasks_ = tasks;
    workers_ = (tasks && tasks->parallel()) ? std::min(tasks->worker_count, kMaxWorkers) : 1;
    if (workers_ <= 1) return;
    owner_ = std::this_thread::get_id();
    exit_.store(false, std::memory_order_relaxed);
    // The current stage, exhausted: a helper that starts now waits for the first real one.
    for (int r = 0; r < workers_; ++r) ranges_[r].claim.store(claim_word(seq_, 0, 0), std::memory_order_relaxed);
    stage_.store(stage_word(seq_, 0), std::memory_order_release);
    for (int k = 1; k < workers_; ++k) helpers_[k] = Helper{this, k, nullptr};
    try {
        for (int k = 1; k < workers_; ++k)
            helpers_[k].handle = tasks->enqueue(&ParallelRegion::helper_entry, 1, 1, &helpers_[k], tasks->user_context);
    } catch (...) {
        close();  // the helpers enqueued so far leave; nothing else ran
        throw;
    }
}

void ParallelRegion::close() {
    if (workers_ <= 1) return;
    exit_.store(true, std::memory_order_release);
    for (int k = 1; k < workers_; ++k)
        if (helpers_[k].handle) tasks_->finish(helpers_[k].handle, tasks_->user_context);
    workers_ = 1;
}

void ParallelRegion::run_block(int begin, int end, int worker) noexcept {
    // Once a block has thrown, the stage's other blocks are only counted: the caller rethrows.
    if (failed_.load(std::memory_order_acquire)) return;
    try {
        thunk_(ctx_, begin, end, worker);
    } catch (...) {
        std::lock_guard<std::mutex> lock(error_mutex_);
        if (!error_) error_ = std::current_exception();
        failed_.store(true, std::memory_order_release);
    }
}

void ParallelRegion::helper_entry(int, int, int, void* ctx) {
    const Helper& h = *static_cast<const Helper*>(ctx);
    ParallelRegion& r = *h.region;
    // Run inline inside enqueue (or by finish on the calling thread): the calling thread does the work.
    if (std::this_thread::get_id() == r.owner_) return;
    std::uint64_t last = ~std::uint64_t(0);  // no stage: a helper arriving mid-stage joins it
    Backoff backoff;
    while (!r.exit_.load(std::memory_order_acquire)) {
        const std::uint64_t stage = r.stage_.load(std::memory_order_acquire);
        if (stage != last) {
            // The blocks this helper ran, counted once: one shared atomic per helper and stage, not per
            // block (the calling thread waits for the count).
            const int ran = r.work_on(seq_of(stage), int(stage & 0xFFFFFFFFu), h.worker);
            if (ran > 0) r.done_.fetch_add(ran, std::memory_order_release);
            last = stage;
            backoff = Backoff{};
        } else {
            backoff.wait();
        }
    }
}

int ParallelRegion::claim(int r, std::uint32_t seq, int blocks) {
    std::atomic<std::uint64_t>& word = ranges_[r].claim;
    std::uint64_t c = word.load(std::memory_order_acquire);
    for (;;) {
        std::uint64_t next;
        if (seq_of(c) == seq) {
            if (next_of(c) >= blocks_of(c)) return -1;
            next = c + 1;
        } else if (later(seq_of(c), seq)) {
            return -1;  // this worker slept through the stage: it is over
        } else {
            // The stage's first claim in this range: set it up with block 0 taken. If the range has blocks
            // in the stage, the stage cannot have ended, since none of them was claimed; if it has none,
            // there is nothing to claim.
            const int first = range_start(blocks, r, workers_), count = range_start(blocks, r + 1, workers_) - first;
            if (count == 0) return -1;
            next = claim_word(seq, count, 1);
        }
        if (word.compare_exchange_weak(c, next, std::memory_order_acq_rel, std::memory_order_acquire))
            return range_start(blocks, r, workers_) + next_of(next) - 1;
    }
}

int ParallelRegion::drain(int r, std::uint32_t seq, int blocks, int worker) {
    int ran = 0;
    for (int b; (b = claim(r, seq, blocks)) >= 0; ++ran) {
        // The descriptor is the claimed stage's: the calling thread rewrites it only after this block is
        // counted done.
        const int begin = b * block_, end = std::min(count_, begin + block_);
        run_block(begin, end, worker);
    }
    return ran;
}

int ParallelRegion::work_on(std::uint32_t seq, int blocks, int worker) {
    int ran = 0;
    for (int k = 0; k < workers_; ++k) ran += drain((worker + k) % workers_, seq, blocks, worker);
    return ran;
}

void ParallelRegion::publish(int count, int min_block, Thunk thunk, void* ctx) {
    assert(std::this_thread::get_id() == owner_ && "stages are published by the thread that called run()");
    // Eight blocks per worker at most balance uneven items (the stage's last block is what the other
    // workers wait for) without many claims (rigid/soft_step_solver.cpp, kBatchesPerBlock, has figures).
    const int most = 8 * workers_;
    int blocks = std::min((count + std::max(min_block, 1) - 1) / std::max(min_block, 1), most);
    blocks = std::max(blocks, 1);
    block_ = (count + blocks - 1) / blocks;
    blocks = (count + block_ - 1) / block_;
    count_ = count;
    thunk_ = thunk;
    ctx_ = ctx;
    done_.store(0, std::memory_order_relaxed);
    ++seq_;
    failed_.store(false, std::memory_order_relaxed);
    stage_.store(stage_word(seq_, blocks), std::memory_order_release);
    const int mine = work_on(seq_, blocks, 0);
    Backoff backoff;
    while (done_.load(std::memory_order_acquire) + mine < blocks) backoff.wait();
    if (failed_.load(std::memory_order_acquire)) {
        std::exception_ptr e;
        {
            std::lock_guard<std::mutex> lock(error_mutex_);
            std::swap(e, error_);
        }
        std::rethrow_exception(e);
    }
}

}  // namespace sinew
