// The host hooks of the C API: the log callback receives every failure (and warnings, info), the
// allocator serves the C API's per-world buffers and nothing leaks through it, a steady game loop
// allocates nothing through it, and the threading contract holds (worlds on different threads, a
// per-thread last error).
#include <catch2/catch.hpp>

#include <atomic>
#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <cmath>
#include <cstdlib>
#include <string>
#include <thread>
#include <vector>

#include "tests/test_c_api_util.hpp"

using namespace capi_test;

namespace {

struct LogLine {
    sinew_log_level level;
    std::string text;
};
void collect(sinew_log_level level, const char* message, void* user) {
    static_cast<std::vector<LogLine>*>(user)->push_back({level, message});
}

struct Counting {
    std::atomic<long> allocs{0}, frees{0}, bytes{0}, misaligned{0};
    std::atomic<bool> refuse{false};
};
void* counting_alloc(size_t size, size_t alignment, void* user) {
    Counting& c = *static_cast<Counting*>(user);
    if (c.refuse) return nullptr;
    void* p = std::aligned_alloc(alignment < sizeof(void*) ? sizeof(void*) : alignment,
                                 (size + 15) / 16 * 16);
    if (reinterpret_cast<std::uintptr_t>(p) % alignment != 0) ++c.misaligned;
    ++c.allocs;
    c.bytes += long(size);
    return p;
}
void counting_free(void* p, size_t size, void* user) {
    Counting& c = *static_cast<Counting*>(user);
    ++c.frees;
    c.bytes -= long(size);
    std::free(p);
}

/// A static ground box, 1 m thick, its top at y = 0, `half` metres to each side.
void add_ground(sinew_world_id w, float half) {
    sinew_body_def g = sinew_body_def_default();
    g.type = SINEW_BODY_STATIC;
    g.shape.half_extents = {half, 0.5f, half};
    g.transform.p = {0, -0.5f, 0};
    sinew_body_id id;
    REQUIRE(sinew_body_create(w, &g, &id) == SINEW_OK);
}

/// A ground and a column of `n` unit boxes.
sinew_world_id stack_world(int n) {
    sinew_world_id w = make_world();
    add_ground(w, 10);
    sinew_body_id id;
    for (int i = 0; i < n; ++i) {
        sinew_body_def b = sinew_body_def_default();
        b.mass = 1;
        b.transform.p = {0, 0.5f + float(i), 0};
        REQUIRE(sinew_body_create(w, &b, &id) == SINEW_OK);
    }
    return w;
}

}  // namespace

TEST_CASE("C API hooks: every failure reaches the log callback with its level and text", "[capi][hooks]") {
    std::vector<LogLine> lines;
    REQUIRE(sinew_set_log_callback(collect, &lines) == SINEW_OK);
    sinew_world_id w = make_world();
    CHECK(lines.empty());  // successful calls log nothing
    sinew_body_def bad = sinew_body_def_default();
    bad.mass = -1;
    sinew_body_id id;
    CHECK(sinew_body_create(w, &bad, &id) == SINEW_ERROR_INVALID_ARGUMENT);
    REQUIRE(lines.size() == 1);
    CHECK(lines[0].level == SINEW_LOG_ERROR);
    CHECK(lines[0].text == sinew_last_error());
    CHECK_THAT(lines[0].text, Catch::Contains("def->mass = -1"));
    REQUIRE(sinew_world_destroy(w) == SINEW_OK);

    // A frame longer than max_steps_per_frame steps: the dropped time is a warning.
    sinew_world_def d = sinew_world_def_default();
    d.max_steps_per_frame = 2;
    REQUIRE(sinew_world_create(&d, &w) == SINEW_OK);
    lines.clear();
    int steps = 0;
    REQUIRE(sinew_world_step(w, 0.5f, &steps, nullptr) == SINEW_OK);
    CHECK(steps == 2);
    REQUIRE(lines.size() == 1);
    CHECK(lines[0].level == SINEW_LOG_WARNING);
    // 0.5 s asked, 2/60 s simulated, less than a step kept: 0.5 - 2/60 - (remainder) s dropped.
    CHECK_THAT(lines[0].text, Catch::Contains("max_steps_per_frame = 2") && Catch::Contains("dropped"));
    lines.clear();
    REQUIRE(sinew_world_step(w, 1.0f / 60, &steps, nullptr) == SINEW_OK);
    CHECK(lines.empty());  // a normal frame
    REQUIRE(sinew_world_destroy(w) == SINEW_OK);

    REQUIRE(sinew_set_log_callback(nullptr, nullptr) == SINEW_OK);
    CHECK(sinew_world_destroy(w) == SINEW_ERROR_STALE_ID);
    CHECK(lines.empty());  // removed: no more calls
}

TEST_CASE("C API hooks: the allocator serves each world's C API buffers and gets every byte back", "[capi][hooks]") {
    Counting c;
    sinew_allocator a{counting_alloc, counting_free, &c};
    REQUIRE(sinew_set_allocator(&a) == SINEW_OK);
    sinew_world_id w = stack_world(5);
    REQUIRE(sinew_set_allocator(nullptr) == SINEW_OK);  // later worlds use malloc; this one keeps its hooks
    CHECK(c.allocs >= 1);  // the world's handle record
    long at_100 = 0, bytes_100 = 0;
    for (int i = 1; i <= 300; ++i) {
        REQUIRE(sinew_world_step(w, 1.0f / 60, nullptr, nullptr) == SINEW_OK);
        if (i == 100) {
            at_100 = c.allocs;
            bytes_100 = c.bytes;
        }
    }
    CHECK(c.allocs > 1);  // event buffers grew through the hooks
    // A steady game loop (the stack is asleep by step 100) allocates nothing per frame.
    CHECK(c.allocs == at_100);
    CHECK(c.bytes == bytes_100);
    CHECK(c.misaligned == 0);
    sinew_world_id plain = stack_world(2);  // made after the reset: not through the hooks
    const long before_plain = c.allocs;
    REQUIRE(sinew_world_step(plain, 1.0f / 60, nullptr, nullptr) == SINEW_OK);
    CHECK(c.allocs == before_plain);
    REQUIRE(sinew_world_destroy(plain) == SINEW_OK);
    REQUIRE(sinew_world_destroy(w) == SINEW_OK);
    CHECK(c.frees == c.allocs);
    CHECK(c.bytes == 0);
}

TEST_CASE("C API hooks: an allocator that fails gives SINEW_ERROR_INTERNAL and no world", "[capi][hooks][errors]") {
    Counting c;
    c.refuse = true;
    sinew_allocator a{counting_alloc, counting_free, &c};
    REQUIRE(sinew_set_allocator(&a) == SINEW_OK);
    sinew_world_def d = sinew_world_def_default();
    sinew_world_id w{5, 5};
    CHECK(sinew_world_create(&d, &w) == SINEW_ERROR_INTERNAL);
    CHECK_THAT(std::string(sinew_last_error()), Catch::Contains("out of memory"));
    CHECK(w.index == 5);  // not written
    CHECK(sinew_world_create_from_scene_file(SINEW_SOURCE_DIR "/demos/scenes/showcase-c-loop.json", &w) ==
          SINEW_ERROR_INTERNAL);
    REQUIRE(sinew_set_allocator(nullptr) == SINEW_OK);
    CHECK(c.bytes == 0);

    sinew_allocator half{counting_alloc, nullptr, &c};
    CHECK(sinew_set_allocator(&half) == SINEW_ERROR_NULL_ARGUMENT);
    CHECK_THAT(std::string(sinew_last_error()), Catch::Contains("allocator->free is NULL"));
    half = {nullptr, counting_free, &c};
    CHECK(sinew_set_allocator(&half) == SINEW_ERROR_NULL_ARGUMENT);
    CHECK_THAT(std::string(sinew_last_error()), Catch::Contains("allocator->alloc is NULL"));
}

TEST_CASE("C API hooks: worlds run on different threads at once, the last error is per thread", "[capi][hooks][threads]") {
    // The same scene on two threads at once and on this one: the same engine and the same steps give
    // the same numbers (worlds share no mutable state).
    // No Catch2 assertions inside the threads (Catch2 v2 is not thread-safe): plain calls, checked after.
    auto run = [](float* top_y, std::string* error_after) {
        sinew_world_def d = sinew_world_def_default();
        sinew_world_id w{};
        sinew_world_create(&d, &w);
        sinew_body_def g = sinew_body_def_default();
        g.type = SINEW_BODY_STATIC;
        g.shape.half_extents = {10, 0.5f, 10};
        g.transform.p = {0, -0.5f, 0};
        sinew_body_id id;
        sinew_body_create(w, &g, &id);
        for (int i = 0; i < 4; ++i) {
            sinew_body_def b = sinew_body_def_default();
            b.mass = 1;
            b.transform.p = {0, 0.5f + float(i), 0};
            sinew_body_create(w, &b, &id);
        }
        for (int i = 0; i < 120; ++i) sinew_world_step_fixed(w);
        sinew_transform xf[5];
        int n = 0;
        sinew_world_get_transforms(w, nullptr, xf, 5, &n);
        *top_y = xf[4].p.y;
        *error_after = sinew_last_error();  // this thread made no failing call
        sinew_world_destroy(w);
    };
    float y_a = 0, y_b = 0, y_main = 0;
    std::string err_a = "x", err_b = "x", err_main;
    // This thread fails a call first: its message must not show up on the others.
    CHECK(sinew_world_step_fixed(sinew_world_id{}) == SINEW_ERROR_STALE_ID);
    const std::string mine = sinew_last_error();
    std::thread ta(run, &y_a, &err_a), tb(run, &y_b, &err_b);
    ta.join();
    tb.join();
    CHECK(sinew_last_error() == mine);  // untouched by the other threads' calls
    run(&y_main, &err_main);
    CHECK(err_a.empty());
    CHECK(err_b.empty());
    CHECK(y_a == y_main);
    CHECK(y_b == y_main);
    CHECK(y_main == Approx(3.5).margin(0.01));  // the top of a 4-box column stands
}

TEST_CASE("C API hooks: a callback during a step cannot change the stepping world", "[capi][hooks][errors]") {
    sinew_world_id w = stack_world(1);
    sinew_world_id other = make_world();
    sinew_body_id box{};
    int n = 0;
    REQUIRE(sinew_world_get_transforms(w, nullptr, nullptr, 0, &n) == SINEW_OK);
    sinew_body_id ids[2];
    REQUIRE(sinew_world_get_transforms(w, ids, nullptr, 2, &n) == SINEW_OK);
    box = ids[1];
    std::vector<sinew_status> changes;
    sinew_status read = SINEW_ERROR_INTERNAL, elsewhere = SINEW_ERROR_INTERNAL;
    int bodies_before = 0;
    REQUIRE(sinew_world_body_count(w, &bodies_before) == SINEW_OK);
    run_during_step(w, [&] {
        const sinew_body_def d = sinew_body_def_default();
        sinew_body_id out;
        const sinew_transform t{{0, 9, 0}, {0, 0, 0, 1}};
        changes = {sinew_body_create(w, &d, &out),
                   sinew_body_destroy(box),
                   sinew_body_set_transform(box, &t),
                   sinew_body_set_velocity(box, {1, 0, 0}, {0, 0, 0}),
                   sinew_body_apply_force(box, {1, 0, 0}, {0, 0, 0}),
                   sinew_body_apply_impulse(box, {1, 0, 0}, {0, 0, 0}),
                   sinew_world_step(w, 0.1f, nullptr, nullptr),
                   sinew_world_step_fixed(w),
                   sinew_world_destroy(w)};
        sinew_transform now;
        read = sinew_body_get_transform(box, &now);  // reading is allowed
        elsewhere = sinew_world_step_fixed(other);   // another world is not stepping
    });
    REQUIRE(changes.size() == 9);
    for (sinew_status s : changes) CHECK(s == SINEW_ERROR_IN_STEP);
    CHECK(read == SINEW_OK);
    CHECK(elsewhere == SINEW_OK);
    int bodies_after = 0;
    REQUIRE(sinew_world_body_count(w, &bodies_after) == SINEW_OK);  // the world is still there
    CHECK(bodies_after == bodies_before + 2);  // only run_during_step's anchor and bob were added
    sinew_transform t;
    REQUIRE(sinew_body_get_transform(box, &t) == SINEW_OK);
    CHECK(t.p.y == Approx(0.5).margin(0.01));  // not moved to y = 9
    REQUIRE(sinew_world_destroy(other) == SINEW_OK);
    REQUIRE(sinew_world_destroy(w) == SINEW_OK);
}

// A world that blows up says so (issue 18): a body created past its method's documented stability limit
// gets a warning at creation; the step in which its state turns non-finite returns SINEW_ERROR_NON_FINITE
// with an error line naming the body, the step and the method's limit; the body is put back where that
// step found it, at rest, and the rest of the world steps on unaffected.
namespace {
bool finite3(const sinew_vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

}  // namespace

TEST_CASE("C API: a semi-implicit cloth past 2/omega is warned at creation, reported when it blows up, and "
          "contained", "[capi][errors][blowup]") {
    std::vector<LogLine> log;
    REQUIRE(sinew_set_log_callback(collect, &log) == SINEW_OK);
    sinew_world_id w = make_world();

    // A box in free fall beside the cloth: the blow-up must not touch it.
    sinew_body_def b = sinew_body_def_default();
    b.transform.p = {10, 100, 0};
    b.mass = 1;
    sinew_body_id box;
    REQUIRE(sinew_body_create(w, &b, &box) == SINEW_OK);

    // The default 16 x 16 cloth of 1 kg (3.9 g per particle) with 1000 N/m springs: omega = 716 rad/s for
    // one spring alone, so semi-implicit Euler is stable only below h = 2.8 ms and the world steps at 16.7 ms.
    sinew_soft_def d = sinew_soft_def_default();
    d.method = SINEW_SOFT_SEMI_IMPLICIT;
    d.allow_sleep = 0;
    sinew_cloth_def c = sinew_cloth_def_default();
    c.origin = {0, 4, 0};
    c.edge_u = {2, 0, 0};
    c.edge_v = {0, 0, 2};
    c.pinned_corners = SINEW_CLOTH_PIN_00 | SINEW_CLOTH_PIN_10;
    sinew_soft_body_id cloth;
    REQUIRE(sinew_soft_create_cloth(w, &d, &c, &cloth) == SINEW_OK);
    REQUIRE(log.size() == 1);
    CHECK(log[0].level == SINEW_LOG_WARNING);
    CHECK(log[0].text.find("sinew_soft_create_cloth") != std::string::npos);
    CHECK(log[0].text.find("semi-implicit") != std::string::npos);
    CHECK(log[0].text.find("0.00279") != std::string::npos);  // 2 / sqrt(4 k / (2 m)) = 2.795 ms
    log.clear();

    // Step until the cloth blows up: the status says so and the log names it.
    int n = 0, faulted = -1;
    std::vector<sinew_vec3> before(256), after(256);
    int got = 0;
    for (; n < 400 && faulted < 0; ++n) {
        REQUIRE(sinew_soft_get_positions(cloth, before.data(), 256, &got) == SINEW_OK);
        const sinew_status s = sinew_world_step_fixed(w);
        if (s == SINEW_OK) continue;
        REQUIRE(s == SINEW_ERROR_NON_FINITE);
        faulted = n;
    }
    REQUIRE(faulted >= 0);
    REQUIRE(log.size() == 1);
    const std::string& line = log[0].text;
    INFO(line);
    CHECK(log[0].level == SINEW_LOG_ERROR);
    CHECK(line == sinew_last_error());
    CHECK(line.find("sinew_world_step_fixed: step " + std::to_string(faulted) + ": soft body") == 0);
    CHECK(line.find("index " + std::to_string(cloth.index)) != std::string::npos);
    CHECK(line.find("semi-implicit") != std::string::npos);
    CHECK(line.find("2/omega") != std::string::npos);

    // Contained: the cloth is back where the step found it, at rest; the box fell freely all along.
    REQUIRE(sinew_soft_get_positions(cloth, after.data(), 256, &got) == SINEW_OK);
    for (int i = 0; i < 256; ++i) {
        REQUIRE(finite3(after[i]));
        CHECK(after[i].x == before[i].x);
        CHECK(after[i].y == before[i].y);
        CHECK(after[i].z == before[i].z);
    }
    // The box is where the same box in a world of its own is after as many steps.
    sinew_world_id alone = make_world();
    sinew_body_id box_alone;
    REQUIRE(sinew_body_create(alone, &b, &box_alone) == SINEW_OK);
    for (int i = 0; i <= faulted; ++i) REQUIRE(sinew_world_step_fixed(alone) == SINEW_OK);
    sinew_transform t, t_alone;
    REQUIRE(sinew_body_get_transform(box, &t) == SINEW_OK);
    REQUIRE(sinew_body_get_transform(box_alone, &t_alone) == SINEW_OK);
    CHECK(t.p.y == t_alone.p.y);
    CHECK(t.p.y < 100);
    REQUIRE(sinew_world_destroy(alone) == SINEW_OK);

    // The world steps on; the game loop keeps its steps and alpha on the error too.
    log.clear();
    int taken = -1;
    float alpha = -1;
    const sinew_status s = sinew_world_step(w, 4.5f / 60, &taken, &alpha);
    CHECK((s == SINEW_OK || s == SINEW_ERROR_NON_FINITE));
    CHECK(taken == 4);
    CHECK(alpha == Approx(0.5f).margin(1e-3));
    if (s == SINEW_ERROR_NON_FINITE) CHECK(log.size() == 1);  // one line per body, however many steps
    REQUIRE(sinew_soft_get_positions(cloth, after.data(), 256, &got) == SINEW_OK);
    for (int i = 0; i < 256; ++i) REQUIRE(finite3(after[i]));
    REQUIRE(sinew_set_log_callback(nullptr, nullptr) == SINEW_OK);
    REQUIRE(sinew_world_destroy(w) == SINEW_OK);
}

namespace {

/// A host's job system as a game engine has one: its own threads take one-item tasks from a queue.
struct HostJobs {
    struct Job {
        sinew_task_fn* fn;
        void* ctx;
        int count;
        std::atomic<bool> done{false};
    };
    std::mutex mutex;
    std::condition_variable cv;
    std::deque<Job*> queue;
    std::vector<std::unique_ptr<Job>> jobs;
    std::vector<std::thread> threads;
    std::atomic<long> run_by_host{0};
    bool stop = false;

    explicit HostJobs(int n) {
        for (int k = 1; k <= n; ++k)
            threads.emplace_back([this, k] {
                for (;;) {
                    std::unique_lock<std::mutex> lock(mutex);
                    cv.wait(lock, [this] { return stop || !queue.empty(); });
                    if (queue.empty()) return;
                    Job* job = queue.front();
                    queue.pop_front();
                    lock.unlock();
                    job->fn(0, job->count, k, job->ctx);
                    ++run_by_host;
                    job->done = true;
                }
            });
    }
    ~HostJobs() {
        {
            std::lock_guard<std::mutex> lock(mutex);
            stop = true;
        }
        cv.notify_all();
        for (std::thread& t : threads) t.join();
    }
    static void* enqueue(sinew_task_fn* fn, int count, int, void* ctx, void* user) {
        HostJobs& h = *static_cast<HostJobs*>(user);
        std::lock_guard<std::mutex> lock(h.mutex);
        h.jobs.push_back(std::make_unique<Job>());
        Job* job = h.jobs.back().get();
        job->fn = fn;
        job->ctx = ctx;
        job->count = count;
        h.queue.push_back(job);
        h.cv.notify_one();
        return job;
    }
    static void finish(void* handle, void* user) {
        // As sinew.h asks: a task no worker has started runs here.
        HostJobs& h = *static_cast<HostJobs*>(user);
        Job* job = static_cast<Job*>(handle);
        {
            std::unique_lock<std::mutex> lock(h.mutex);
            for (auto it = h.queue.begin(); it != h.queue.end(); ++it)
                if (*it == job) {
                    h.queue.erase(it);
                    lock.unlock();
                    job->fn(0, job->count, 0, job->ctx);
                    job->done = true;
                    return;
                }
        }
        while (!job->done) std::this_thread::yield();
    }
};

/// A 16-row pyramid of unit boxes on the ground (enough contacts for the step to use its workers),
/// stepped 120 times; returns its fingerprint.
std::vector<float> pyramid_after_two_seconds(const sinew_world_def& d) {
    sinew_world_id w{};
    REQUIRE(sinew_world_create(&d, &w) == SINEW_OK);
    add_ground(w, 20);
    sinew_body_id id;
    for (int row = 0; row < 16; ++row)
        for (int i = 0; i < 16 - row; ++i) {
            sinew_body_def b = sinew_body_def_default();
            b.transform.p = {float(i) * 1.05f + 0.525f * float(row), 0.5f + float(row), 0};
            REQUIRE(sinew_body_create(w, &b, &id) == SINEW_OK);
        }
    for (int i = 0; i < 120; ++i) REQUIRE(sinew_world_step_fixed(w) == SINEW_OK);
    std::vector<float> f = fingerprint(w);
    REQUIRE(sinew_world_destroy(w) == SINEW_OK);
    return f;
}

}  // namespace

// Issue 18, item 1: the host's job system runs the step's parallel parts (Sinew starts no thread then),
// or the world's own pool does; either gives the serial state bit for bit.
TEST_CASE("C API hooks: a step on the host's job system or the world's threads gives the serial state",
          "[capi][hooks][threads]") {
    const std::vector<float> serial = pyramid_after_two_seconds(sinew_world_def_default());
    HostJobs host(2);
    sinew_world_def d = sinew_world_def_default();
    d.worker_count = 3;
    d.enqueue_task = &HostJobs::enqueue;
    d.finish_task = &HostJobs::finish;
    d.user_task_context = &host;
    CHECK(pyramid_after_two_seconds(d) == serial);
    CHECK(host.run_by_host > 0);
    sinew_world_def own = sinew_world_def_default();
    own.worker_count = 2;
    CHECK(pyramid_after_two_seconds(own) == serial);
    // The pyramid stood: the top box (the last of 137 bodies; 14 numbers each after the two counts, its
    // y the third) is still 15.5 m up, within the soft contacts' millimetre of give per row.
    REQUIRE(serial.size() >= 2 + 137 * 14);
    CHECK(serial[2 + 136 * 14 + 2] == Approx(15.5).margin(0.03));

    own.worker_count = 0;
    sinew_world_id w{};
    CHECK(sinew_world_create(&own, &w) == SINEW_ERROR_INVALID_ARGUMENT);
    CHECK(std::string(sinew_last_error()).find("def->worker_count = 0 must be in [1, 64]") != std::string::npos);
    own.worker_count = 2;
    own.finish_task = &HostJobs::finish;
    CHECK(sinew_world_create(&own, &w) == SINEW_ERROR_INVALID_ARGUMENT);
    CHECK(std::string(sinew_last_error()).find("enqueue_task and def->finish_task must be set together") != std::string::npos);
    w = make_world();
    CHECK(sinew_world_set_workers(w, 65, nullptr, nullptr, nullptr) == SINEW_ERROR_INVALID_ARGUMENT);
    CHECK(sinew_world_set_workers(w, 2, nullptr, nullptr, nullptr) == SINEW_OK);
    CHECK(sinew_world_set_workers(w, 2, &HostJobs::enqueue, &HostJobs::finish, &host) == SINEW_OK);
    CHECK(sinew_world_step_fixed(w) == SINEW_OK);
    CHECK(sinew_world_destroy(w) == SINEW_OK);
    CHECK(sinew_world_set_workers(w, 1, nullptr, nullptr, nullptr) == SINEW_ERROR_STALE_ID);
}
