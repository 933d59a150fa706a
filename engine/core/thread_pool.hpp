// The default task system: worker_count - 1 threads that a world starts only when it is asked for
// more than one worker and the host brings no task system of its own (engine/core/task_system.hpp).
#pragma once

#include <atomic>
#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "engine/core/task_system.hpp"

namespace sinew {

class ThreadPool {
public:
    /// worker_count counts the calling thread: 2 starts one thread. Throws std::invalid_argument
    /// outside [1, kMaxWorkers].
    explicit ThreadPool(int worker_count);
    ~ThreadPool();
    ThreadPool(const ThreadPool&) = delete;
    ThreadPool& operator=(const ThreadPool&) = delete;

    /// The callbacks to hand to a world (valid while the pool lives).
    const TaskSystem& task_system() const { return tasks_; }
    int worker_count() const { return tasks_.worker_count; }

private:
    struct Job {
        TaskFn fn = nullptr;
        int count = 0;
        void* ctx = nullptr;
        std::atomic<int> state{0};  // 0 queued, 1 running, 2 done (written under mutex_; finish spins on it)
    };
    static void* enqueue(TaskFn fn, int count, int min_range, void* ctx, void* pool);
    static void finish(void* job, void* pool);
    void worker_loop(int worker);
    void stop_threads();
    Job* take_job();

    TaskSystem tasks_;
    std::mutex mutex_;
    std::condition_variable wake_, done_;
    std::deque<Job*> queue_;
    std::vector<std::unique_ptr<Job>> jobs_;  // every job ever made; the free ones are reused
    std::vector<Job*> free_;
    std::atomic<int> queued_{0};
    bool stop_ = false;
    std::vector<std::thread> threads_;
};

}  // namespace sinew
