// `sinew bench robustness [--scenes a,b] [--engines ...] [--markdown FILE]`
//
// The hard scenes (demos/scenes/hard-*.json, written by scripts/hard_scenes.py): each one a place where
// rigid solvers are known to fail. Every scene runs under each Sinew solver and under Bullet (where Bullet
// can build it), and one physical figure per scene is checked against a limit drawn from the scene's
// analytic answer (the scene's description says which). One JSON line per (scene, engine, variant); with
// --markdown, a pass/fail matrix in the bench-robustness section of a results file.
#include "tools/bench/bench_robustness.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <iostream>
#include <sstream>
#include <stdexcept>

#include "engine/world/scene.hpp"
#include "tools/bench/bench_cloth.hpp"  // BenchClock
#include "tools/bench/bench_rigid.hpp"
#include "tools/bench/peers.hpp"
#include "tools/bench/results_file.hpp"
#include "tools/commands.hpp"
#include "tools/progress.hpp"

namespace sinew::bench {

namespace {

const char* kHardScenes[] = {"hard-heavy-on-pyramid", "hard-heavy-on-light", "hard-chain", "hard-fast",
                             "hard-overlap", "hard-arch", "hard-ramp-stack", "hard-spin"};

struct Solver {
    const char* variant;
    RigidSolverKind kind;
};
const Solver kSolvers[] = {{"soft-step", RigidSolverKind::SoftStep},
                           {"split-impulse", RigidSolverKind::SplitImpulse},
                           {"baumgarte", RigidSolverKind::Baumgarte},
                           {"newton", RigidSolverKind::Newton}};

struct HardRun {
    std::string scene, engine, variant;
    int steps = 0;
    double ms_per_step_median = 0;
    std::string figure_name;  ///< what `figure` measures
    double figure = 0;
    double limit = 0;
    bool below = true;        ///< pass when figure <= limit (else when figure >= limit)
    bool pass = false;
    bool finite = true;
    std::string note;         ///< why the run could not be made, or a second condition that failed
};

/// A scene's check: fed every step's poses (all bodies, scene order), it keeps what it needs; `finish`
/// fills figure, limit, below and note.
class Check {
public:
    virtual ~Check() = default;
    virtual void start(const std::vector<Transform>& p) { first_ = p; }
    virtual void sample(const std::vector<Transform>& prev, const std::vector<Transform>& p, double h, int step) = 0;
    virtual void finish(const std::vector<Transform>& last, HardRun& r) = 0;

protected:
    std::vector<Transform> first_;
};

bool dynamic(const SceneDesc& s, std::size_t i) { return s.bodies[i].def.type == BodyType::Dynamic; }
std::size_t body_index(const SceneDesc& s, const std::string& name) {
    for (std::size_t i = 0; i < s.bodies.size(); ++i)
        if (s.bodies[i].name == name) return i;
    throw SceneError(s.file, "/bodies", "the robustness benchmark needs a body named '" + name + "'");
}

/// Largest distance any dynamic body moves from where it started (or, for `settled`, from a given rest
/// position), over the run.
class DriftCheck final : public Check {
public:
    DriftCheck(const SceneDesc& s, double limit, std::size_t settled = SIZE_MAX, Vec3 rest = Vec3::Zero())
        : scene_(s), limit_(limit), settled_(settled), rest_(rest) {}
    void sample(const std::vector<Transform>&, const std::vector<Transform>& p, double, int) override {
        for (std::size_t i = 0; i < p.size(); ++i)
            if (dynamic(scene_, i) && i != settled_) worst_ = std::max(worst_, double((p[i].p - first_[i].p).norm()));
    }
    void finish(const std::vector<Transform>& last, HardRun& r) override {
        r.figure_name = "max drift (m)";
        r.figure = worst_;
        if (settled_ != SIZE_MAX) {
            // The dropped body is judged where it ends: at rest on the stack.
            r.figure_name = "max drift, dropped body's final error (m)";
            r.figure = std::max(worst_, double((last[settled_].p - rest_).norm()));
        }
        r.limit = limit_;
    }

private:
    const SceneDesc& scene_;
    double limit_, worst_ = 0;
    std::size_t settled_;
    Vec3 rest_;
};

/// Largest distance between the two anchor points of any joint, over the run.
class JointErrorCheck final : public Check {
public:
    explicit JointErrorCheck(const SceneDesc& s) : scene_(s) {}
    void sample(const std::vector<Transform>&, const std::vector<Transform>& p, double, int) override {
        for (const SceneJoint& j : scene_.joints) {
            const Vec3 a = p[j.body_a].apply(j.def.local_anchor_a), b = p[j.body_b].apply(j.def.local_anchor_b);
            worst_ = std::max(worst_, double((a - b).norm()));
        }
    }
    void finish(const std::vector<Transform>&, HardRun& r) override {
        r.figure_name = "max joint error (m)";
        r.figure = worst_;
        r.limit = 0.01;
    }

private:
    const SceneDesc& scene_;
    double worst_ = 0;
};

/// Fast bodies flying along +x at walls: each body's furthest x against its wall's near face. A body
/// whose centre passes the face tunnelled; one that never comes within 2 cm of touching stopped short.
class WallCheck final : public Check {
public:
    explicit WallCheck(const SceneDesc& s) : scene_(s) {
        for (std::size_t i = 0; i < s.bodies.size(); ++i) {
            if (!dynamic(s, i)) continue;
            const Shape& sh = s.bodies[i].def.shape;
            // The wall in the body's lane (same z); the body touches it with its centre between
            // face - outer and face - inner (a sphere: both its radius; a cube: half side to half diagonal).
            Flyer f;
            f.body = i;
            f.inner = sh.type == ShapeType::Sphere ? double(sh.radius) : double(sh.half_extents.minCoeff());
            f.outer = sh.type == ShapeType::Sphere ? double(sh.radius) : double(sh.half_extents.norm());
            for (std::size_t w = 0; w < s.bodies.size(); ++w)
                if (!dynamic(s, w) && std::abs(s.bodies[w].def.pose.p.z() - s.bodies[i].def.pose.p.z()) < 1e-3)
                    f.face = double(s.bodies[w].def.pose.p.x() - s.bodies[w].def.shape.half_extents.x());
            f.max_x = double(s.bodies[i].def.pose.p.x());
            flyers_.push_back(f);
        }
    }
    void sample(const std::vector<Transform>&, const std::vector<Transform>& p, double, int) override {
        for (Flyer& f : flyers_) f.max_x = std::max(f.max_x, double(p[f.body].p.x()));
    }
    void finish(const std::vector<Transform>&, HardRun& r) override {
        r.figure_name = "worst overshoot or shortfall (m)";
        r.limit = 0.02;
        std::string worst;
        for (const Flyer& f : flyers_) {
            const double over = f.max_x - (f.face - f.inner);    // > 0: into the wall
            const double short_of = (f.face - f.outer) - f.max_x;  // > 0: never touched it
            const double e = std::max({over, short_of, 0.0});
            if (e > r.figure) {
                r.figure = e;
                worst = scene_.bodies[f.body].name + (over > 0 ? (f.max_x > f.face ? " tunnelled" : " went in")
                                                               : " stopped short");
            }
        }
        if (r.figure > r.limit) r.note = worst;
    }

private:
    struct Flyer {
        std::size_t body = 0;
        double inner = 0, outer = 0, face = 0, max_x = 0;
    };
    const SceneDesc& scene_;
    std::vector<Flyer> flyers_;
};

/// The fastest any dynamic body moves (from consecutive poses), and whether two named boxes end apart.
class PushCheck final : public Check {
public:
    PushCheck(const SceneDesc& s) : scene_(s), a_(body_index(s, "box-a")), b_(body_index(s, "box-b")) {}
    void sample(const std::vector<Transform>& prev, const std::vector<Transform>& p, double h, int) override {
        for (std::size_t i = 0; i < p.size(); ++i)
            if (dynamic(scene_, i)) fastest_ = std::max(fastest_, double((p[i].p - prev[i].p).norm()) / h);
    }
    void finish(const std::vector<Transform>& last, HardRun& r) override {
        r.figure_name = "fastest speed (m/s)";
        r.figure = fastest_;
        // The solvers' push-out caps (the scene sets both to 3 m/s), and 0.5 m/s for what gravity and
        // friction add while bodies are being pushed.
        const RigidSettings& rs = scene_.settings.rigid;
        r.limit = double(std::max(rs.contact_push_velocity, rs.max_correction_velocity)) + 0.5;
        const double gap = double((last[a_].p - last[b_].p).norm());
        if (gap < 0.98) {
            char buf[96];
            std::snprintf(buf, sizeof buf, "box-a and box-b still overlap (centres %.3f m apart)", gap);
            r.note = buf;
        }
    }

private:
    const SceneDesc& scene_;
    std::size_t a_, b_;
    double fastest_ = 0;
};

/// Every dynamic body's slide down the ramp (along its start orientation's x axis, the ramp's down-slope
/// direction) at the end, against 0.5 a t^2.
class SlideCheck final : public Check {
public:
    explicit SlideCheck(const SceneDesc& s) : scene_(s) {}
    void sample(const std::vector<Transform>&, const std::vector<Transform>&, double h, int step) override {
        t_ = double(step + 1) * h;
    }
    void finish(const std::vector<Transform>& last, HardRun& r) override {
        const double g = 9.81, th = 30 * 3.14159265358979 / 180, mu = 0.2;
        const double expected = 0.5 * g * (std::sin(th) - mu * std::cos(th)) * t_ * t_;
        r.figure_name = "worst slide error (fraction of 0.5 a t^2)";
        for (std::size_t i = 0; i < last.size(); ++i) {
            if (!dynamic(scene_, i)) continue;
            const Vec3 down = first_[i].q * Vec3::UnitX();
            const double slid = double((last[i].p - first_[i].p).dot(down));
            r.figure = std::max(r.figure, std::abs(slid - expected) / expected);
        }
        r.limit = 0.03;
    }

private:
    const SceneDesc& scene_;
    double t_ = 0;
};

/// The spinning box's y axis against where it pointed at the start: the smallest dot product over the
/// run (-1: turned fully over).
class FlipCheck final : public Check {
public:
    void sample(const std::vector<Transform>&, const std::vector<Transform>& p, double, int) override {
        lowest_ = std::min(lowest_, double((p.back().q * Vec3::UnitY()).dot(first_.back().q * Vec3::UnitY())));
    }
    void finish(const std::vector<Transform>&, HardRun& r) override {
        r.figure_name = "lowest y-axis alignment with its start";
        r.figure = lowest_;
        r.limit = -0.9;
        r.below = true;
    }

private:
    double lowest_ = 1;
};

std::unique_ptr<Check> make_check(const SceneDesc& s) {
    const std::string& n = s.name;
    if (n == "hard-heavy-on-pyramid") return std::make_unique<DriftCheck>(s, 0.05, body_index(s, "heavy"), Vec3(0, Real(10.5), 0));
    if (n == "hard-heavy-on-light") return std::make_unique<DriftCheck>(s, 0.01);
    if (n == "hard-chain") return std::make_unique<JointErrorCheck>(s);
    if (n == "hard-fast") return std::make_unique<WallCheck>(s);
    if (n == "hard-overlap") return std::make_unique<PushCheck>(s);
    if (n == "hard-arch") return std::make_unique<DriftCheck>(s, 0.05);
    if (n == "hard-ramp-stack") return std::make_unique<SlideCheck>(s);
    if (n == "hard-spin") return std::make_unique<FlipCheck>();
    throw SceneError(s.file, "/name", "the robustness benchmark has no check for scene '" + n + "'");
}

class SinewHard final : public RigidContender {
public:
    SinewHard(const SceneDesc& scene, const Solver& v, int iterations) {
        SceneDesc s = scene;
        s.settings.rigid.solver = v.kind;
        s.settings.rigid.velocity_iterations = iterations;
        s.settings.rigid.newton_contact_iterations = iterations;
        world_ = build_world(s, &ids_);
        run.scene = scene.name;
        run.engine = "sinew";
        run.variant = v.variant;
    }
    void step() override { world_->step(); }
    bool healthy() const override { return world_->faults().empty(); }
    std::vector<Vec3> positions() const override { return {}; }
    std::vector<Transform> poses() const override {
        std::vector<Transform> p;
        p.reserve(ids_.size());
        for (BodyId id : ids_) p.push_back(world_->rigid().transform(id));
        return p;
    }

private:
    std::unique_ptr<World> world_;
    std::vector<BodyId> ids_;
};

HardRun run_one(const SceneDesc& scene, RigidContender& c, BenchClock clock) {
    HardRun r;
    r.scene = scene.name;
    r.engine = c.run.engine;
    r.variant = c.run.variant;
    std::unique_ptr<Check> check = make_check(scene);
    std::vector<Transform> prev = c.poses();
    check->start(prev);
    std::vector<double> ms;
    const double h = double(scene.settings.time_step);
    for (int i = 0; i < scene.steps; ++i) {
        const double t0 = bench_clock_ms(clock);
        c.step();
        ms.push_back(bench_clock_ms(clock) - t0);
        std::vector<Transform> p = c.poses();
        bool ok = c.healthy();
        for (const Transform& t : p) ok = ok && is_finite(t.p) && std::isfinite(double(t.q.w()));
        if (!ok) {
            r.finite = false;
            break;
        }
        check->sample(prev, p, h, i);
        prev = std::move(p);
        ++r.steps;
    }
    r.ms_per_step_median = median(ms);
    check->finish(prev, r);
    r.pass = r.finite && r.note.empty() && (r.below ? r.figure <= r.limit : r.figure >= r.limit);
    return r;
}

std::string to_json(const HardRun& r) {
    char buf[768];
    std::snprintf(buf, sizeof buf,
                  "{\"scene\":\"%s\",\"engine\":\"%s\",\"variant\":\"%s\",\"steps\":%d,\"ms_per_step_median\":%.4f,"
                  "\"figure\":\"%s\",\"value\":%.6g,\"limit\":%.6g,\"pass\":%s,\"finite\":%s,\"note\":\"%s\"}",
                  r.scene.c_str(), r.engine.c_str(), r.variant.c_str(), r.steps, r.ms_per_step_median,
                  r.figure_name.c_str(), r.figure, r.limit, r.pass ? "true" : "false", r.finite ? "true" : "false",
                  r.note.c_str());
    return buf;
}

std::string markdown(const std::vector<HardRun>& runs, const std::vector<std::string>& columns) {
    std::ostringstream md;
    md << "Each cell: pass or FAIL, the scene's figure, and median ms per step (thread CPU). The figure and its "
          "limit per scene are in the first columns; the scenes' descriptions (`demos/scenes/hard-*.json`) "
          "say what each one is.\n\n| scene | figure | limit |";
    for (const std::string& c : columns) md << " " << c << " |";
    md << "\n|---|---|---:|";
    for (std::size_t i = 0; i < columns.size(); ++i) md << "---|";
    md << "\n";
    std::vector<std::string> scenes;
    for (const HardRun& r : runs)
        if (std::find(scenes.begin(), scenes.end(), r.scene) == scenes.end()) scenes.push_back(r.scene);
    char buf[256];
    for (const std::string& s : scenes) {
        const HardRun* any = nullptr;
        for (const HardRun& r : runs)
            if (r.scene == s && !r.figure_name.empty()) { any = &r; break; }
        std::snprintf(buf, sizeof buf, "| %s | %s | %s%.3g |", s.c_str(), any ? any->figure_name.c_str() : "-",
                      any && !any->below ? ">= " : "", any ? any->limit : 0.0);
        md << buf;
        for (const std::string& c : columns) {
            const HardRun* hit = nullptr;
            for (const HardRun& r : runs)
                if (r.scene == s && r.engine + " " + r.variant == c) hit = &r;
            if (!hit) md << " - |";
            else if (hit->figure_name.empty()) md << " not run: " << hit->note << " |";
            else {
                std::snprintf(buf, sizeof buf, " %s %.4g, %.2f ms%s%s |", hit->pass ? "pass" : "**FAIL**", hit->figure,
                              hit->ms_per_step_median, hit->finite ? "" : ", blew up",
                              hit->note.empty() ? "" : (", " + hit->note).c_str());
                md << buf;
            }
        }
        md << "\n";
    }
    return md.str();
}

}  // namespace

int cmd_bench_robustness(const std::vector<std::string>& args) {
    using tool::UsageError;
    std::vector<std::string> scenes(std::begin(kHardScenes), std::end(kHardScenes));
    std::vector<std::string> only;
    std::string markdown_file, scene_dir = "demos/scenes";
    int iterations = 10;
    for (std::size_t i = 1; i < args.size(); ++i) {
        const std::string& a = args[i];
        if (tool::is_option(a, "--scenes")) scenes = split_list(tool::option_value(args, i, "--scenes"));
        else if (tool::is_option(a, "--engines")) only = split_list(tool::option_value(args, i, "--engines"));
        else if (tool::is_option(a, "--iterations"))
            iterations = int(tool::parse_int("--iterations", tool::option_value(args, i, "--iterations"), 1, 1000));
        else if (tool::is_option(a, "--markdown")) markdown_file = tool::option_value(args, i, "--markdown");
        else if (tool::is_option(a, "--scene-dir")) scene_dir = tool::option_value(args, i, "--scene-dir");
        else throw UsageError("unknown option '" + a + "'");
    }
    if (scenes.empty()) throw UsageError("--scenes is empty");
    auto wanted = [&](const std::string& engine, const std::string& variant) {
        if (only.empty()) return true;
        for (const std::string& o : only)
            if (o == engine || o == engine + "/" + variant) return true;
        return false;
    };
    std::vector<std::string> columns;
    for (const Solver& v : kSolvers)
        if (wanted("sinew", v.variant)) columns.push_back(std::string("sinew ") + v.variant);
    const bool bullet = wanted("bullet", "default") && bullet_peer_available();
    if (bullet) columns.push_back("bullet default");
    std::vector<HardRun> runs;
    for (const std::string& name : scenes) {
        const SceneDesc scene = parse_scene_file(scene_dir + "/" + name + ".json");  // SceneError: exit 1
        make_check(scene);  // an unknown scene is refused before anything runs
        std::cerr << "bench robustness: " << name << "...\n";
        for (const Solver& v : kSolvers) {
            if (!wanted("sinew", v.variant)) continue;
            SinewHard c(scene, v, iterations);
            runs.push_back(run_one(scene, c, BenchClock::ThreadCpu));
            std::cout << to_json(runs.back()) << std::endl;
        }
        if (bullet) {
            std::unique_ptr<RigidContender> c;
            try {
                c = make_bullet_contender(scene, iterations);
            } catch (const std::runtime_error& e) {
                HardRun r;
                r.scene = name;
                r.engine = "bullet";
                r.variant = "default";
                r.note = e.what();
                runs.push_back(r);
                std::cout << to_json(r) << std::endl;
                continue;
            }
            runs.push_back(run_one(scene, *c, BenchClock::ThreadCpu));
            std::cout << to_json(runs.back()) << std::endl;
        }
    }
    if (!markdown_file.empty() && !replace_section(markdown_file, "bench-robustness", markdown(runs, columns))) {
        std::cerr << "sinew bench: could not write " << markdown_file << "\n";
        return 1;
    }
    return 0;
}

}  // namespace sinew::bench
