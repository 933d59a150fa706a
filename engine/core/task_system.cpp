// ParallelRegion: stages published by the calling thread, blocks claimed by helpers (task_system.hpp).
#include "engine/core/task_system.hpp"

#include <algorithm>
#include <cassert>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

namespace sinew {

namespace {

constexpr int kBlockBits = 20;
constexpr std::uint64_t kBlockMask = (std::uint64_t(1) << kBlockBits) - 1;
constexpr std::uint32_t kSeqMask = (1u << 24) - 1;

std::uint32_t seq_of(std::uint64_t c) { return std::uint32_t(c >> (2 * kBlockBits)); }
int blocks_of(std::uint64_t c) { return int((c >> kBlockBits) & kBlockMask); }
int next_of(std::uint64_t c) { return int(c & kBlockMask); }
/// A range's claim word for stage `seq`: `blocks` blocks, none claimed yet.
std::uint64_t claim_word(std::uint32_t seq, int blocks) {
    return (std::uint64_t(seq) << (2 * kBlockBits)) | (std::uint64_t(blocks) << kBlockBits);
}

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
    for (int r = 0; r < workers_; ++r) ranges_[r].claim.store(claim_word(seq_, 0), std::memory_order_relaxed);
    stage_.store(seq_, std::memory_order_release);
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
    if (!failed_.load(std::memory_order_acquire)) {
        try {
            thunk_(ctx_, begin, end, worker);
        } catch (...) {
            std::lock_guard<std::mutex> lock(error_mutex_);
            if (!error_) error_ = std::current_exception();
            failed_.store(true, std::memory_order_release);
        }
    }
    done_.fetch_add(1, std::memory_order_release);
}

void ParallelRegion::helper_entry(int, int, int, void* ctx) {
    const Helper& h = *static_cast<const Helper*>(ctx);
    ParallelRegion& r = *h.region;
    // Run inline inside enqueue (or by finish on the calling thread): the calling thread does the work.
    if (std::this_thread::get_id() == r.owner_) return;
    std::uint32_t last = kSeqMask + 1;  // no stage: a helper arriving mid-stage joins it
    Backoff backoff;
    while (!r.exit_.load(std::memory_order_acquire)) {
        const std::uint32_t seq = r.stage_.load(std::memory_order_acquire);
        if (seq != last) {
            r.work_on(seq, h.worker);
            last = seq;
            backoff = Backoff{};
        } else {
            backoff.wait();
        }
    }
}

void ParallelRegion::drain(Range& r, std::uint32_t seq, int worker) {
    std::uint64_t c = r.claim.load(std::memory_order_acquire);
    for (;;) {
        if (seq_of(c) != seq || next_of(c) >= blocks_of(c)) return;
        if (!r.claim.compare_exchange_weak(c, c + 1, std::memory_order_acq_rel, std::memory_order_acquire)) continue;
        // The descriptor is the claimed stage's: the calling thread rewrites it only after this block is
        // counted done.
        const int begin = (r.first + next_of(c)) * block_, end = std::min(count_, begin + block_);
        run_block(begin, end, worker);
        c = r.claim.load(std::memory_order_acquire);
    }
}

void ParallelRegion::work_on(std::uint32_t seq, int worker) {
    for (int k = 0; k < workers_; ++k) drain(ranges_[(worker + k) % workers_], seq, worker);
}

void ParallelRegion::publish(int count, int min_block, Thunk thunk, void* ctx) {
    assert(std::this_thread::get_id() == owner_ && "stages are published by the thread that called run()");
    // Eight blocks per worker at most balance uneven items (the stage's last block is what the other
    // workers wait for) without many claims (rigid/soft_step_solver.cpp, kBatchesPerBlock, has figures).
    const int most = std::min<int>(8 * workers_, int(kBlockMask));
    int blocks = std::min((count + std::max(min_block, 1) - 1) / std::max(min_block, 1), most);
    blocks = std::max(blocks, 1);
    block_ = (count + blocks - 1) / blocks;
    blocks = (count + block_ - 1) / block_;
    count_ = count;
    thunk_ = thunk;
    ctx_ = ctx;
    done_.store(0, std::memory_order_relaxed);
    seq_ = (seq_ + 1) & kSeqMask;
    failed_.store(false, std::memory_order_relaxed);
    for (int r = 0; r < workers_; ++r) {
        const int first = int(std::int64_t(blocks) * r / workers_), next = int(std::int64_t(blocks) * (r + 1) / workers_);
        ranges_[r].first = first;
        ranges_[r].claim.store(claim_word(seq_, next - first), std::memory_order_release);
    }
    stage_.store(seq_, std::memory_order_release);
    work_on(seq_, 0);
    Backoff backoff;
    while (done_.load(std::memory_order_acquire) < blocks) backoff.wait();
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
