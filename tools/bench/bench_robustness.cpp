// `sinew bench robustness [--scenes a,b] [--engines ...] [--markdown FILE]`
//
// The hard scenes (demos/scenes/hard-*.json, written by scripts/hard_scenes.py): each one a place where
// rigid solvers are known to fail. Every scene runs under each Sinew solver and under Bullet (where Bullet
// can build it), and one physical figure per scene is checked against a limit drawn from the scene's
// analytic answer (the scene's description says which). The soft hard scenes (hard-soft-*: soft bodies
// under contact, issue 14 items 7 and 8) run under each soft method instead, and under Bullet's btSoftBody where
// its peer can build them (one soft body against a static sphere and ground). One JSON line per (scene,
// engine, variant); with --markdown, pass/fail matrices in the bench-robustness and
// bench-robustness-soft sections of a results file.
#include "tools/bench/bench_robustness.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <iostream>
#include <sstream>
#include <stdexcept>

#include "engine/world/scene.hpp"
#include "engine/world/world.hpp"
#include "tools/bench/bench_cloth.hpp"  // BenchClock
#include "tools/bench/bench_rigid.hpp"
#include "tools/bench/peers.hpp"
#include "tools/bench/results_file.hpp"
#include "tools/commands.hpp"
#include "tools/progress.hpp"

namespace sinew::bench {

namespace {

const char* kHardScenes[] = {"hard-heavy-on-pyramid", "hard-heavy-on-light", "hard-chain", "hard-fast",
                             "hard-overlap", "hard-arch", "hard-ramp-stack", "hard-spin",
                             "hard-soft-drape", "hard-soft-pressure", "hard-soft-collide", "hard-soft-fold",
                             "hard-soft-tunnel"};

bool soft_scene(const std::string& name) { return name.rfind("hard-soft-", 0) == 0; }

struct Solver {
    const char* variant;
    RigidSolverKind kind;
};
const Solver kSolvers[] = {{"soft-step", RigidSolverKind::SoftStep},
                           {"split-impulse", RigidSolverKind::SplitImpulse},
                           {"baumgarte", RigidSolverKind::Baumgarte},
                           {"newton", RigidSolverKind::Newton}};

/// The soft methods each soft hard scene runs under, with their iterations: Verlet's relaxations, implicit
/// Euler's CG cap, fast mass-spring's local/global iterations (the settings `bench cloth` charts).
struct SoftColumn {
    const char* variant;
    SoftMethod method;
    int iterations;
};
const SoftColumn kSoftColumns[] = {{"verlet-it10", SoftMethod::Verlet, 10},
                                   {"semi-implicit", SoftMethod::SemiImplicitEuler, 1},
                                   {"implicit-cg100", SoftMethod::ImplicitEuler, 100},
                                   {"fast-ms-it3", SoftMethod::FastMassSpring, 3}};

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

// ---- Soft bodies under contact ----------------------------------------------------------------------

/// A soft scene's check: fed the world after every step; `finish` fills figure, limit, below and note.
class SoftCheck {
public:
    virtual ~SoftCheck() = default;
    virtual void sample(const World& w) = 0;
    virtual void finish(const World& w, HardRun& r) = 0;
};

const SoftBody& soft_body(const World& w, std::size_t k) { return w.soft().body(w.soft().bodies()[k]); }

/// The largest link stretch (current / rest length) at the end, against issue 5's 1.10.
class StretchCheck final : public SoftCheck {
public:
    void sample(const World&) override {}
    void finish(const World& w, HardRun& r) override {
        r.figure_name = "largest link stretch at the end";
        for (std::size_t k = 0; k < w.soft().bodies().size(); ++k)
            r.figure = std::max(r.figure, double(soft_body(w, k).max_stretch()));
        r.limit = 1.10;
    }
};

/// The closed body's volume at the end within 10% of its rest volume, and never below the isothermal gas's
/// energy bound on the way down (0.80 of it).
class VolumeCheck final : public SoftCheck {
public:
    void sample(const World& w) override { lowest_ = std::min(lowest_, ratio(w)); }
    void finish(const World& w, HardRun& r) override {
        r.figure_name = "volume error at the end (fraction of rest)";
        r.figure = std::abs(ratio(w) - 1);
        r.limit = 0.1;
        if (lowest_ < 0.8) {
            char buf[96];
            std::snprintf(buf, sizeof buf, "lowest %.3f on the way (bound 0.80)", lowest_);
            r.note = buf;
        }
    }

private:
    static double ratio(const World& w) {
        const SoftBody& b = soft_body(w, 0);
        return b.rest_volume > 0 ? double(b.volume() / b.rest_volume) : 0.0;
    }
    double lowest_ = 1e30;
};

/// Generalised winding number of the closed triangle surface of `b` around `p` (Jacobson et al. 2013:
/// the solid angles of its triangles over 4 pi; 1 inside, 0 outside).
double winding_number(const SoftBody& b, const Vec3& p) {
    double total = 0;
    for (std::size_t t = 0; t + 2 < b.triangles.size(); t += 3) {
        const Vec3 a = b.p.x[b.triangles[t]] - p, c = b.p.x[b.triangles[t + 1]] - p, d = b.p.x[b.triangles[t + 2]] - p;
        const double la = double(a.norm()), lc = double(c.norm()), ld = double(d.norm());
        // Van Oosterom & Strackee 1983: tan(omega / 2) = det / (la lc ld + (a.c) ld + (a.d) lc + (c.d) la).
        const double det = double(a.dot(c.cross(d)));
        const double den = la * lc * ld + double(a.dot(c)) * ld + double(a.dot(d)) * lc + double(c.dot(d)) * la;
        total += 2 * std::atan2(det, den);
    }
    return total / (4 * 3.14159265358979);
}

/// Two closed bodies thrown at each other: the most particles of either found inside the other's surface
/// at the end of any step (each body's surface is closed, so inside is its winding number above one half).
class InsideCheck final : public SoftCheck {
public:
    void sample(const World& w) override {
        const SoftBody& a = soft_body(w, 0);
        const SoftBody& b = soft_body(w, 1);
        int inside = 0;
        for (const Vec3& x : a.p.x) inside += std::abs(winding_number(b, x)) > 0.5;
        for (const Vec3& x : b.p.x) inside += std::abs(winding_number(a, x)) > 0.5;
        most_ = std::max(most_, inside);
    }
    void finish(const World&, HardRun& r) override {
        r.figure_name = "most particles inside the other body";
        r.figure = most_;
        r.limit = 0;
    }

private:
    int most_ = 0;
};

/// The folded cloth of scripts/hard_scenes.py (node (i, k) = vertex 11 i + k; i > 10 the upper layer, laid
/// back over node 20 - i): the least height of the upper layer's inner nodes (away from the fold and the
/// rim) above the nodes under them, at the end.
class FoldCheck final : public SoftCheck {
public:
    void sample(const World&) override {}
    void finish(const World& w, HardRun& r) override {
        const Particles& p = soft_body(w, 0).p;
        r.figure_name = "least height of the upper layer above the lower (m)";
        r.limit = 0.017;
        r.below = false;
        if (p.size() != 21 * 11) {
            r.note = "not the folded cloth of scripts/hard_scenes.py";
            return;
        }
        r.figure = 1e30;
        for (int i = 13; i + 1 < 21; ++i)
            for (int k = 1; k + 1 < 11; ++k)
                r.figure = std::min(r.figure, double(p.x[std::size_t(i * 11 + k)].y() - p.x[std::size_t((20 - i) * 11 + k)].y()));
    }
};

/// A cloth thrown along +x at a wall: how far any particle's centre got past the wall's near face less the
/// particle's thickness, over the run.
class TunnelCheck final : public SoftCheck {
public:
    explicit TunnelCheck(const SceneDesc& s) {
        const SceneBody& wall = s.bodies.at(body_index(s, "wall"));
        stop_ = double(wall.def.pose.p.x() - wall.def.shape.half_extents.x()) -
                double(s.soft_bodies.at(0).def.thickness);
    }
    void sample(const World& w) override {
        for (const Vec3& x : soft_body(w, 0).p.x) furthest_ = std::max(furthest_, double(x.x()));
    }
    void finish(const World&, HardRun& r) override {
        r.figure_name = "furthest past the wall's face (m)";
        r.figure = std::max(0.0, furthest_ - stop_);
        r.limit = 0.005;
    }

private:
    double stop_ = 0, furthest_ = -1e30;
};

std::unique_ptr<SoftCheck> make_soft_check(const SceneDesc& s) {
    const std::string& n = s.name;
    if (n == "hard-soft-drape") return std::make_unique<StretchCheck>();
    if (n == "hard-soft-pressure") return std::make_unique<VolumeCheck>();
    if (n == "hard-soft-collide") {
        if (s.soft_bodies.size() != 2) throw SceneError(s.file, "/soft_bodies", "hard-soft-collide needs two soft bodies");
        return std::make_unique<InsideCheck>();
    }
    if (n == "hard-soft-fold") return std::make_unique<FoldCheck>();
    if (n == "hard-soft-tunnel") return std::make_unique<TunnelCheck>(s);
    throw SceneError(s.file, "/name", "the robustness benchmark has no check for scene '" + n + "'");
}

/// The scene with every soft body under `column`'s method and iterations. Semi-implicit Euler is stable
/// only while omega h < 2; its links are softened to where the stiffest particle stays at half that bound
/// by Gershgorin's estimate, omega^2 <= 2 d k / m for a particle of mass m with d links: k <= m / (h^2 d).
/// Returns the stiffness it was capped at (0 if none was).
double soft_column_scene(SceneDesc& s, const SoftColumn& column) {
    double capped = 0;
    const double h = double(s.settings.time_step);
    for (SceneSoftBody& sb : s.soft_bodies) {
        SoftBodyDef& d = sb.def;
        d.method = column.method;
        d.iterations = column.iterations;
        if (column.method != SoftMethod::SemiImplicitEuler || d.links.empty()) continue;
        std::vector<int> degree(d.positions.size(), 0);
        for (const Link& l : d.links) ++degree[l.a], ++degree[l.b];
        double k_max = 1e30;
        for (std::size_t i = 0; i < degree.size(); ++i)
            if (degree[i] > 0) k_max = std::min(k_max, double(d.masses[i]) / (h * h * degree[i]));
        for (Link& l : d.links)
            if (double(l.stiffness) > k_max) {
                l.stiffness = Real(k_max);
                capped = k_max;
            }
    }
    return capped;
}

HardRun run_soft_one(const SceneDesc& scene, const SoftColumn& column, BenchClock clock) {
    HardRun r;
    r.scene = scene.name;
    r.engine = "sinew";
    r.variant = column.variant;
    SceneDesc s = scene;
    const double capped = soft_column_scene(s, column);
    std::unique_ptr<World> w = build_world(s);
    std::unique_ptr<SoftCheck> check = make_soft_check(s);
    std::vector<double> ms;
    for (int i = 0; i < s.steps; ++i) {
        const double t0 = bench_clock_ms(clock);
        w->step();
        ms.push_back(bench_clock_ms(clock) - t0);
        if (!w->soft().all_finite() || !w->soft().faults().empty()) {
            r.finite = false;
            break;
        }
        check->sample(*w);
        ++r.steps;
    }
    r.ms_per_step_median = median(ms);
    check->finish(*w, r);
    if (capped > 0) {
        char buf[96];
        std::snprintf(buf, sizeof buf, "links capped at %.3g N/m (stability)", capped);
        r.note = r.note.empty() ? buf : r.note + "; " + buf;
    }
    r.pass = r.finite && (r.below ? r.figure <= r.limit : r.figure >= r.limit) &&
             (r.note.empty() || r.note.rfind("links capped", 0) == 0);
    return r;
}

/// Bullet's btSoftBody on the scenes its peer builds (one cloth or pressure ball against a static sphere
/// and ground: hard-soft-drape and hard-soft-pressure), judged by the same figure at the end.
HardRun run_bullet_soft_hard(const SceneDesc& scene, BenchClock clock) {
    HardRun r;
    r.scene = scene.name;
    r.engine = "bullet";
    r.variant = "btSoftBody";
    if (scene.name != "hard-soft-drape" && scene.name != "hard-soft-pressure")
        throw SceneError(scene.file, "", "not a scene Bullet's peer builds");
    const ClothScene cs = cloth_scene_from(scene);  // SceneError: not a scene the peer builds
    const ClothRun c = run_bullet_soft(cs, scene.steps, clock);
    r.steps = c.steps;
    r.ms_per_step_median = c.ms_per_step_median;
    r.finite = c.finite;
    if (scene.name == "hard-soft-drape") {
        r.figure_name = "largest link stretch at the end";
        r.figure = c.max_stretch;
        r.limit = 1.10;
    } else {
        r.figure_name = "volume error at the end (fraction of rest)";
        r.figure = std::abs(c.volume_ratio - 1);
        r.limit = 0.1;
    }
    r.pass = r.finite && (r.below ? r.figure <= r.limit : r.figure >= r.limit);
    return r;
}

// ---- Rigid bodies -------------------------------------------------------------------------------------

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
                std::snprintf(buf, sizeof buf, " %s %.5g, %.2f ms%s%s |", hit->pass ? "pass" : "**FAIL**", hit->figure,
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
    std::vector<std::string> columns, soft_columns;
    for (const Solver& v : kSolvers)
        if (wanted("sinew", v.variant)) columns.push_back(std::string("sinew ") + v.variant);
    const bool bullet = wanted("bullet", "default") && bullet_peer_available();
    if (bullet) columns.push_back("bullet default");
    for (const SoftColumn& v : kSoftColumns)
        if (wanted("sinew", v.variant)) soft_columns.push_back(std::string("sinew ") + v.variant);
    const bool bullet_soft = wanted("bullet", "btSoftBody") && bullet_peer_available();
    if (bullet_soft) soft_columns.push_back("bullet btSoftBody");
    std::vector<SceneDesc> loaded;
    for (const std::string& name : scenes) {
        loaded.push_back(parse_scene_file(scene_dir + "/" + name + ".json"));  // SceneError: exit 1
        // An unknown scene is refused before anything runs.
        if (soft_scene(name)) make_soft_check(loaded.back());
        else make_check(loaded.back());
    }
    std::vector<HardRun> runs, soft_runs;
    for (const SceneDesc& scene : loaded) {
        const std::string& name = scene.name;
        std::cerr << "bench robustness: " << name << "...\n";
        if (soft_scene(name)) {
            for (const SoftColumn& v : kSoftColumns) {
                if (!wanted("sinew", v.variant)) continue;
                soft_runs.push_back(run_soft_one(scene, v, BenchClock::ThreadCpu));
                std::cout << to_json(soft_runs.back()) << std::endl;
            }
            if (!bullet_soft) continue;
            try {
                soft_runs.push_back(run_bullet_soft_hard(scene, BenchClock::ThreadCpu));
            } catch (const SceneError&) {
                HardRun r;
                r.scene = name;
                r.engine = "bullet";
                r.variant = "btSoftBody";
                r.note = "its peer builds one soft body against a static sphere and ground only";
                soft_runs.push_back(r);
            }
            std::cout << to_json(soft_runs.back()) << std::endl;
            continue;
        }
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
    if (!markdown_file.empty()) {
        if ((!runs.empty() && !replace_section(markdown_file, "bench-robustness", markdown(runs, columns))) ||
            (!soft_runs.empty() && !replace_section(markdown_file, "bench-robustness-soft", markdown(soft_runs, soft_columns)))) {
            std::cerr << "sinew bench: could not write " << markdown_file << "\n";
            return 1;
        }
    }
    return 0;
}

}  // namespace sinew::bench
