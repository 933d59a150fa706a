// ThreadPool: a queue of whole tasks under one mutex. Sinew enqueues a handful of tasks per step (one
// per helper of each parallel region), so a lock per task costs nothing next to the stages; threads spin
// a little after each task before sleeping, so the next region of the same step finds them awake.
#include "engine/core/thread_pool.hpp"

#include <chrono>
#include <stdexcept>
#include <string>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

namespace sinew {

namespace {
void cpu_relax() {
#if defined(__x86_64__) || defined(__i386__)
    _mm_pause();
#else
    std::this_thread::yield();
#endif
}
}  // namespace

ThreadPool::ThreadPool(int worker_count) {
    if (worker_count < 1 || worker_count > kMaxWorkers)
        throw std::invalid_argument("ThreadPool: worker_count must be in [1, " + std::to_string(kMaxWorkers) +
                                    "], got " + std::to_string(worker_count));
    tasks_.worker_count = worker_count;
    tasks_.enqueue = &ThreadPool::enqueue;
    tasks_.finish = &ThreadPool::finish;
    tasks_.user_context = this;
    threads_.reserve(std::size_t(worker_count - 1));
    try {
        for (int k = 1; k < worker_count; ++k) threads_.emplace_back([this, k] { worker_loop(k); });
    } catch (...) {
        stop_threads();  // the threads started so far, before the exception leaves the constructor
        throw;
    }
}

ThreadPool::~ThreadPool() { stop_threads(); }

void ThreadPool::stop_threads() {
    {
        std::lock_guard<std::mutex> lock(mutex_);
        stop_ = true;
    }
    wake_.notify_all();
    for (std::thread& t : threads_) t.join();
    threads_.clear();
}

void* ThreadPool::enqueue(TaskFn fn, int count, int, void* ctx, void* user) {
    ThreadPool& pool = *static_cast<ThreadPool*>(user);
    if (pool.threads_.empty()) {
        fn(0, count, 0, ctx);
        return nullptr;
    }
    Job* job;
    {
        std::lock_guard<std::mutex> lock(pool.mutex_);
        if (pool.free_.empty()) {
            pool.jobs_.push_back(std::make_unique<Job>());
            pool.free_.push_back(pool.jobs_.back().get());
        }
        job = pool.free_.back();
        pool.free_.pop_back();
        job->fn = fn;
        job->count = count;
        job->ctx = ctx;
        job->state.store(0, std::memory_order_relaxed);
        pool.queue_.push_back(job);
        pool.queued_.fetch_add(1, std::memory_order_release);
    }
    pool.wake_.notify_one();
    return job;
}

void ThreadPool::finish(void* handle, void* user) {
    ThreadPool& pool = *static_cast<ThreadPool*>(user);
    Job* job = static_cast<Job*>(handle);
    // A started job is usually a region's helper, which leaves within microseconds of the region's end:
    // wait for it spinning, briefly, rather than on the condition variable, whose wake-up cost 10-50 us
    // on this project's virtual machines (four regions a step).
    if (job->state.load(std::memory_order_acquire) == 1) {
        const auto until = std::chrono::steady_clock::now() + std::chrono::microseconds(20);
        while (job->state.load(std::memory_order_acquire) != 2 && std::chrono::steady_clock::now() < until)
            for (int i = 0; i < 16; ++i) cpu_relax();
    }
    std::unique_lock<std::mutex> lock(pool.mutex_);
    if (job->state == 0) {
        // Not started: run it here rather than wait for a thread (worker 0 is the calling thread).
        for (auto it = pool.queue_.begin(); it != pool.queue_.end(); ++it)
            if (*it == job) {
                pool.queue_.erase(it);
                pool.queued_.fetch_sub(1, std::memory_order_relaxed);
                break;
            }
        job->state = 1;
        lock.unlock();
        job->fn(0, job->count, 0, job->ctx);
        lock.lock();
        job->state = 2;
    }
    pool.done_.wait(lock, [job] { return job->state.load(std::memory_order_relaxed) == 2; });
    pool.free_.push_back(job);
}

ThreadPool::Job* ThreadPool::take_job() {
    if (queue_.empty()) return nullptr;
    Job* job = queue_.front();
    queue_.pop_front();
    queued_.fetch_sub(1, std::memory_order_relaxed);
    job->state = 1;
    return job;
}

void ThreadPool::worker_loop(int worker) {
    for (;;) {
        // Spin up to 50 us for the next task before sleeping: the regions of one step come back to back.
        const auto spin_until = std::chrono::steady_clock::now() + std::chrono::microseconds(50);
        while (queued_.load(std::memory_order_acquire) == 0 && std::chrono::steady_clock::now() < spin_until)
            std::this_thread::yield();
        std::unique_lock<std::mutex> lock(mutex_);
        wake_.wait(lock, [this] { return stop_ || !queue_.empty(); });
        if (stop_ && queue_.empty()) return;
        Job* job = take_job();
        lock.unlock();
        job->fn(0, job->count, worker, job->ctx);
        lock.lock();
        job->state = 2;
        lock.unlock();
        done_.notify_all();
    }
}

}  // namespace sinew
