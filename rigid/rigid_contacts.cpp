// Contact detection for the rigid system: broad phase (refit, persistent pairs), each body placed once,
// narrow phase or the body-pair manifold cache, and warm-start impulses matched from the last step.
#include "rigid/rigid_system.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "rigid/joint_set.hpp"
#include "rigid/rigid_solver.hpp"

namespace sinew {

namespace {
/// Candidate pairs from which detection runs on the workers (below it, on the calling thread alone).
constexpr std::size_t kParallelPairs = 256;
std::uint64_t pair_key(std::uint32_t a, std::uint32_t b) { return (std::uint64_t(a) << 32) | b; }
bool manifold_less(const ContactManifold& x, const ContactManifold& y) {
    std::uint64_t kx = pair_key(x.body_a, x.body_b), ky = pair_key(y.body_a, y.body_b);
    return kx != ky ? kx < ky : x.manifold.sub_key < y.manifold.sub_key;
}
}  // namespace

void RigidSystem::restore_disabled() {
    for (const auto& [i, count] : disabled_) {
        if (i >= contacts_.size()) continue;
        Manifold& m = contacts_[i].manifold;
        m.count = count;
        for (int k = 0; k < count; ++k) {
            m.points[k].normal_impulse = 0;
            m.points[k].tangent_impulse[0] = m.points[k].tangent_impulse[1] = 0;
        }
    }
    disabled_.clear();
}

void RigidSystem::apply_pre_solve() {
    for (std::size_t i = 0; i < contacts_.size(); ++i) {
        ContactManifold& c = contacts_[i];
        if (c.manifold.count == 0) continue;
        const std::uint32_t a = c.body_a, b = c.body_b;
        // The combined material afresh: a change the callback made last step holds for that step only.
        c.friction = std::sqrt(material_[a].friction * material_[b].friction);
        c.restitution = std::max(material_[a].restitution, material_[b].restitution);
        PreSolveContact p;
        p.body_a = {a, slots_.generation(a)};
        p.body_b = {b, slots_.generation(b)};
        p.normal = c.manifold.normal;
        p.point_count = c.manifold.count;
        for (int k = 0; k < c.manifold.count; ++k) {
            p.points[k] = c.manifold.points[k].position;
            p.depths[k] = c.manifold.points[k].depth;
        }
        p.friction = c.friction;
        p.restitution = c.restitution;
        if (!pre_solve_(p)) {
            disabled_.emplace_back(std::uint32_t(i), c.manifold.count);
            c.manifold.count = 0;
            continue;
        }
        if (std::isfinite(p.friction) && p.friction >= 0) c.friction = p.friction;
        if (std::isfinite(p.restitution)) c.restitution = std::clamp(p.restitution, Real(0), Real(1));
    }
}

void RigidSystem::detect_collisions(Real h) {
    restore_disabled();
    // One region for the whole detection: helpers when the last step had enough pairs (waking them
    // costs more than a small scene's whole detection). The first step runs on this thread alone.
    region_.run(pair_keys_.size() >= kParallelPairs ? tasks_ : nullptr, [&] { detect_in_region(h); });
    pair_layout_valid_ = true;
    // A sleeping body touched by an awake one wakes with its whole island.
    for (const PairWork& w : pair_work_)
        if (!w.asleep && w.count > 0 && w.wakes != kNoSlot) wake_island(w.wakes);
    list_active_contacts();
    std::fill(reshaped_.begin(), reshaped_.end(), std::uint8_t(0));
    if (pre_solve_) apply_pre_solve();
}

void RigidSystem::detect_in_region(Real h) {
    const Real margin = settings_.contact_margin;
    // pair_work_ describes contacts_ again only once this detection has finished: one that throws
    // leaves the next to find each pair's manifolds by key.
    const bool layout_was_valid = pair_layout_valid_;
    pair_layout_valid_ = false;
    // Broad phase: refit proxies of moving bodies; resting ones stay inside their fat boxes for free.
    // Their boxes on the workers, the tree (a body's box left its fat box: re-inserted) on this thread.
    const std::size_t slots = slots_.size();
    // Whether a box left its fat box is found on the workers too: pyramid-40's 820 resting boxes cost
    // about 10 us a step on this thread when each was tested here.
    detect_box_.resize(slots);
    detect_moves_.resize(slots);
    if (detect_placed_capacity_ < slots) {
        detect_placed_capacity_ = std::max(slots, 2 * detect_placed_capacity_);
        detect_placed_ = std::make_unique<std::atomic<std::uint8_t>[]>(detect_placed_capacity_);
    }
    region_.for_each(int(slots), 256, [&](int begin, int end, int) {
        for (int i = begin; i < end; ++i) {
            const std::uint32_t s = std::uint32_t(i);
            detect_placed_[s].store(0, std::memory_order_relaxed);  // pass 1 marks the bodies to place
            detect_moves_[s] = 0;
            if (!slots_.alive(s) || type_[s] == BodyType::Static || !awake_[s]) continue;
            detect_box_[s] = shape_[s].bounds(origin_transform(s));
            detect_moves_[s] = tree_.would_move(proxy_[s], detect_box_[s], h * state_.v[s]);
        }
    });
    for (std::uint32_t s = 0; s < slots; ++s)
        if (detect_moves_[s]) tree_.move(proxy_[s], detect_box_[s], h * state_.v[s], margin);
    // Candidate pairs change only when a fat box was re-inserted (or a body or joint came or went): a
    // resting scene keeps last step's sorted list (as Box2D keeps its pair set between moves).
    const bool pairs_rebuilt = tree_.revision() != pairs_tree_revision_ ||
                               joints_->filter_revision() != pairs_filter_revision_ || ignored_changed_;
    if (pairs_rebuilt) {
        ignored_changed_ = false;
        pairs_tree_revision_ = tree_.revision();
        pairs_filter_revision_ = joints_->filter_revision();
        candidate_pairs_.clear();
        tree_.all_pairs(candidate_pairs_);
        pair_keys_.clear();
        for (const auto& [pa, pb] : candidate_pairs_) {
            std::uint32_t a = tree_.user_data(pa), b = tree_.user_data(pb);
            if (a > b) std::swap(a, b);
            if (type_[a] != BodyType::Dynamic && type_[b] != BodyType::Dynamic) continue;
            if (!may_touch(a, b)) continue;
            pair_keys_.push_back(pair_key(a, b));
        }
        std::sort(pair_keys_.begin(), pair_keys_.end());
    }

    // Pass 1, cheap (on the workers while the pair list stands): where each pair's manifolds from the
    // last step are, whether it sleeps, and the bodies to place. Sleep is read as the step found it: a
    // pair that wakes a sleeping island does so after the narrow phase (pass 4), so no pair's outcome
    // depends on the order the pairs are handled in, and the passes below can run on any number of
    // workers. Each pair's last manifolds stay at their old place in contacts_ until pass 4: the narrow
    // phase reads its cache there, or carries the manifolds there to this step's poses.
    detect_xf_.resize(slots);
    detect_rot_.resize(slots);
    const std::size_t np = pair_keys_.size();
    // While the pair list stands, each pair's manifolds are where the last step put them; else a merge
    // join of the two lists, both sorted by key, finds them (reading every manifold's key: 50,000 boxes
    // asleep spent about 1.5 ms a step on it).
    const bool same_pairs = layout_was_valid && !pairs_rebuilt && pair_work_.size() == np;
    pair_work_.resize(np);
    // The rest of pass 1, pair by pair; returns whether the pair sleeps.
    auto classify = [&](std::size_t i) {
        const std::uint64_t key = pair_keys_[i];
        const std::uint32_t a = std::uint32_t(key >> 32), b = std::uint32_t(key & 0xFFFFFFFFu);
        PairWork& w = pair_work_[i];
        w.was_left_asleep = w.left_asleep;
        const bool asleep_a = type_[a] == BodyType::Static || !awake_[a];
        const bool asleep_b = type_[b] == BodyType::Static || !awake_[b];
        w.asleep = asleep_a && asleep_b;
        if (!w.asleep) w.left_asleep = false;  // as list_active_contacts would find it
        w.wakes = asleep_a != asleep_b ? (asleep_a ? a : b) : kNoSlot;
        w.count = 0;
        w.kept = w.asleep;
        // Each body's detection pose once per step (a body is in several pairs), with its rotation as a
        // matrix: carrying a cached manifold's points costs two rotations per point. Only bodies in a
        // tested pair: 50,176 boxes asleep on the ground spent 0.7 ms a step placing every body.
        if (!w.asleep) {
            detect_placed_[a].store(1, std::memory_order_relaxed);
            detect_placed_[b].store(1, std::memory_order_relaxed);
        }
        return w.asleep;
    };
    std::size_t sleeping_pairs = 0;
    if (same_pairs) {
        // On the workers: each pair writes its own PairWork, and the placed flags only ever become 1
        // (pyramid-40 spent about 10 us a step here on the calling thread).
        const std::size_t workers = std::size_t(region_.workers());
        sleeping_per_worker_.assign(workers, 0);
        region_.for_each(int(np), 256, [&](int begin, int end, int worker) {
            std::size_t sleeping = 0;
            for (int i = begin; i < end; ++i) {
                PairWork& w = pair_work_[std::size_t(i)];
                w.prev_begin = w.offset;
                w.prev_end = w.offset + w.stored;
                sleeping += classify(std::size_t(i)) ? 1 : 0;
            }
            sleeping_per_worker_[std::size_t(worker)] += sleeping;
        });
        for (const std::size_t n : sleeping_per_worker_) sleeping_pairs += n;
    } else {
        std::size_t prev_i = 0;
        for (std::size_t i = 0; i < np; ++i) {
            const std::uint64_t key = pair_keys_[i];
            PairWork& w = pair_work_[i];
            while (prev_i < contacts_.size() && pair_key(contacts_[prev_i].body_a, contacts_[prev_i].body_b) < key) ++prev_i;
            std::size_t prev_end = prev_i;
            while (prev_end < contacts_.size() && pair_key(contacts_[prev_end].body_a, contacts_[prev_end].body_b) == key)
                ++prev_end;
            w.prev_begin = std::uint32_t(prev_i);
            w.prev_end = std::uint32_t(prev_end);
            w.left_asleep = false;  // not known: it goes to the solver once more
            sleeping_pairs += classify(i) ? 1 : 0;
        }
    }
    all_pairs_awake_ = sleeping_pairs == 0;
    {
        const std::size_t workers = std::size_t(region_.workers());
        if (detect_out_.size() < workers) detect_out_.resize(workers);
        if (detect_scratch_.size() < workers) detect_scratch_.resize(workers);
        for (std::size_t k = 0; k < workers; ++k) detect_out_[k].clear();
        // Pass 2: place the bodies.
        region_.for_each(int(slots), 512, [&](int begin, int end, int) {
            for (int s = begin; s < end; ++s) {
                if (!detect_placed_[std::size_t(s)].load(std::memory_order_relaxed)) continue;
                detect_xf_[std::size_t(s)] = detection_transform(std::uint32_t(s), h);
                detect_rot_[std::size_t(s)] = detect_xf_[std::size_t(s)].q.toRotationMatrix();
            }
        });
        // Pass 3: each awake pair's manifolds into its worker's list.
        region_.for_each(int(np), 16, [&](int begin, int end, int worker) {
            for (int i = begin; i < end; ++i)
                if (!pair_work_[std::size_t(i)].asleep) detect_pair(std::size_t(i), h, margin, worker);
        });
        // Pass 4: the manifolds in key order. Sleeping pairs and pairs whose cached manifolds were carried
        // in place keep theirs, moved within contacts_ only when a pair before them changed its count
        // (here, serially); the other awake pairs' are copied from the workers' lists (on the workers).
        // Then, after the region, the islands the awake pairs touch are woken.
        // A pair whose manifolds land elsewhere, or in another number, changes which pair an index of
        // contacts_ holds: the active list's revision moves on (list_active_contacts).
        std::size_t total = 0, to_copy = 0;
        bool moved = !same_pairs;
        for (PairWork& w : pair_work_) {
            const std::uint32_t stored = w.kept ? w.prev_end - w.prev_begin : w.count;
            to_copy += w.kept ? 0 : w.count;
            moved = moved || w.offset != total || w.stored != stored;
            w.offset = std::uint32_t(total);
            w.stored = stored;
            total += w.stored;
        }
        layout_moved_ = layout_moved_ || moved;
        if (total > contacts_.size()) contacts_.resize(total);
        move_kept_manifolds();
        // No stage when every pair was kept (a stack at rest).
        if (to_copy > 0) region_.for_each(int(np), 64, [&](int begin, int end, int) {
            for (int i = begin; i < end; ++i) {
                const PairWork& w = pair_work_[std::size_t(i)];
                if (w.kept) continue;
                const ContactManifold* from = detect_out_[std::size_t(w.worker)].data() + w.first;
                std::copy(from, from + w.count, contacts_.begin() + std::ptrdiff_t(w.offset));
            }
        });
        contacts_.resize(total);
    }
}

void RigidSystem::list_active_contacts() {
    // What the solve sees: pairs with a body awake now (a sleeping pair in an island just woken counts),
    // and sleeping pairs once, in the step they fell asleep. Listed again if a body wakes between
    // detection and the solve (a coupling hook, a pre-solve callback): the same step's answer then.
    active_stale_ = false;
    std::swap(active_contacts_, last_active_contacts_);
    active_contacts_.clear();
    if (!pair_layout_valid_ || all_pairs_awake_) {
        // Every manifold, in order: contacts were dropped since detection (sleeping ones are immovable
        // in the solve), or no pair sleeps, so none was woken and none is left asleep (pass 1 cleared
        // left_asleep). pyramid-40 spent about 10 us a step on the pair by pair list.
        active_contacts_.resize(contacts_.size());
        std::iota(active_contacts_.begin(), active_contacts_.end(), std::uint32_t(0));
        layout_moved_ = layout_moved_ || !pair_layout_valid_;
    } else {
        for (std::size_t i = 0; i < pair_work_.size(); ++i) {
            PairWork& w = pair_work_[i];
            bool woken = false;
            if (w.asleep && w.stored > 0) {
                const std::uint32_t a = std::uint32_t(pair_keys_[i] >> 32), b = std::uint32_t(pair_keys_[i] & 0xFFFFFFFFu);
                woken = (type_[a] != BodyType::Static && awake_[a]) || (type_[b] != BodyType::Static && awake_[b]);
            }
            const bool active = !w.asleep || !w.was_left_asleep || woken;
            w.left_asleep = w.asleep && !woken;
            if (active)
                for (std::uint32_t k = 0; k < w.stored; ++k) active_contacts_.push_back(w.offset + k);
        }
    }
    if (layout_moved_ || active_contacts_ != last_active_contacts_) ++active_revision_;
    layout_moved_ = false;
}

void RigidSystem::move_kept_manifolds() {
    // A kept pair keeps its count, and both its old and new ranges come in pair order. Those moving
    // towards the front, taken front to back, land on nothing not yet moved; so do those moving towards
    // the back, taken back to front (memmove's argument, pair by pair). The other pairs write afterwards.
    ContactManifold* c = contacts_.data();
    for (const PairWork& w : pair_work_)
        if (w.kept && w.offset < w.prev_begin) std::copy(c + w.prev_begin, c + w.prev_end, c + w.offset);
    for (auto it = pair_work_.rbegin(); it != pair_work_.rend(); ++it)
        if (it->kept && it->offset > it->prev_begin)
            std::copy_backward(c + it->prev_begin, c + it->prev_end, c + it->offset + it->stored);
}

void RigidSystem::detect_pair(std::size_t i, Real h, Real margin, int worker) {
    PairWork& w = pair_work_[i];
    std::vector<ContactManifold>& out = detect_out_[std::size_t(worker)];
    w.worker = worker;
    w.first = std::uint32_t(out.size());
    const std::uint64_t key = pair_keys_[i];
    const std::uint32_t a = std::uint32_t(key >> 32), b = std::uint32_t(key & 0xFFFFFFFFu);
    const Transform& xa = detect_xf_[a];
    const Transform& xb = detect_xf_[b];
    const Mat3& rot_a = detect_rot_[a];
    const Mat3& rot_b = detect_rot_[b];
    const Transform relative = xa.inverse() * xb;
    const std::size_t prev_i = w.prev_begin, prev_end = w.prev_end;
    if (prev_end > prev_i && !reshaped_[a] && !reshaped_[b] && can_reuse(contacts_[prev_i].relative, relative)) {
        // Body-pair cache (as Jolt does): the pair moved as one within 1 mm and 0.5 degrees since
        // its manifold was computed, so the cached points are carried with the bodies instead of
        // running the narrow phase again. Points stay attached to A and B; the depth follows the
        // bodies' relative motion along the normal. Warm-start impulses are kept as they are.
        // Carried where they are (pass 4 keeps them, as a sleeping pair's): no pair but this one reads
        // or writes its cached range in this pass. Copied out and back, pyramid-40's 2,380 manifolds
        // moved about 2 MB a step.
        for (std::size_t j = prev_i; j < prev_end; ++j) {
            ContactManifold& c = contacts_[j];
            Manifold& m = c.manifold;
            m.normal = rot_a * c.normal_local_a;
            for (int k = 0; k < m.count; ++k) {
                ContactPoint& p = m.points[k];
                const Vec3 pa = rot_a * p.local_a + xa.p, pb = rot_b * p.local_b + xb.p;
                p.position = Real(0.5) * (pa + pb);
                p.depth = c.detected_depth[k] - (pb - pa).dot(m.normal);
                if (!settings_.warm_starting) p.normal_impulse = p.tangent_impulse[0] = p.tangent_impulse[1] = 0;
            }
        }
        w.kept = true;
        w.count = std::uint32_t(prev_end - prev_i);
        return;
    } else {
        ManifoldList& fresh = detect_scratch_[std::size_t(worker)];
        fresh.clear();
        // Speculative margin grown by how far the pair can close this step, so a fast body gets its
        // contact before it penetrates (the solvers let it close exactly the gap).
        const Real closing = h * (state_.v[a].norm() + state_.v[b].norm());
        collide(shape_[a], xa, shape_[b], xb, margin + closing, fresh);
        if (fresh.empty()) return;
        add_fresh_manifolds(a, b, xa, xb, relative, prev_i, prev_end, fresh, out);
        // Pairs come in key order; collide() may return a pair's sub_keys unordered, so only this
        // pair's few manifolds need sorting to keep the list ordered for the next merge join.
        if (out.size() - w.first > 1) std::sort(out.begin() + std::ptrdiff_t(w.first), out.end(), manifold_less);
    }
    w.count = std::uint32_t(out.size() - w.first);
}

void RigidSystem::ignore_pair(BodyId a, BodyId b, bool ignore) {
    check(a, "ignore_pair");
    check(b, "ignore_pair");
    if (a == b) throw RigidError("ignore_pair: a body never collides with itself (both ids are index " + std::to_string(a.index) + ")");
    const std::uint64_t key = a.index < b.index ? pair_key(a.index, b.index) : pair_key(b.index, a.index);
    auto it = std::lower_bound(ignored_pairs_.begin(), ignored_pairs_.end(), key);
    const bool there = it != ignored_pairs_.end() && *it == key;
    if (ignore && !there) ignored_pairs_.insert(it, key);
    else if (!ignore && there) ignored_pairs_.erase(it);
    else return;
    ignored_changed_ = true;
}

Transform RigidSystem::detection_transform(std::uint32_t s, Real h) const {
    if (!solver_->detects_at_candidate_poses() || type_[s] == BodyType::Static || !awake_[s])
        return origin_transform(s);
    // Guendelman 2003: contacts are found where the bodies would be after a step with the current
    // velocities, so the impulses act before the penetration happens.
    Quat q = integrate_rotation(state_.q[s], state_.w[s], h);
    Vec3 x = state_.x[s] + h * state_.v[s];
    return {x - q * local_com_[s], q};
}

bool RigidSystem::can_reuse(const Transform& cached, const Transform& now) const {
    const Real max_move = Real(1e-3);         // m
    const Real min_cos_half = Real(0.9999905); // cos(0.25 degree): 0.5 degree of relative rotation
    return (now.p - cached.p).squaredNorm() < max_move * max_move && std::abs(now.q.dot(cached.q)) > min_cos_half;
}

void RigidSystem::add_fresh_manifolds(std::uint32_t a, std::uint32_t b, const Transform& xa, const Transform& xb,
                                  const Transform& relative, std::size_t prev_i, std::size_t prev_end,
                                  ManifoldList& fresh, std::vector<ContactManifold>& out) const {
    const Real match_dist2 = (2 * settings_.contact_margin) * (2 * settings_.contact_margin);
    Real friction = std::sqrt(material_[a].friction * material_[b].friction);
    Real restitution = std::max(material_[a].restitution, material_[b].restitution);
    for (Manifold& m : fresh) {
        for (int k = 0; k < m.count; ++k) {
            ContactPoint& p = m.points[k];
            p.local_a = xa.apply_inverse(p.position);
            p.local_b = xb.apply_inverse(p.position);
        }
        // Warm starting: carry impulses from the cached manifold with the same sub_key, matching
        // points by feature id, else by proximity in A's local frame (seed 001 ch.5).
        if (settings_.warm_starting) {
            for (std::size_t i = prev_i; i < prev_end; ++i) {
                const Manifold& old = contacts_[i].manifold;
                if (old.sub_key != m.sub_key) continue;
                for (int k = 0; k < m.count; ++k) {
                    ContactPoint& p = m.points[k];
                    int best = -1;
                    Real best_d2 = match_dist2;
                    for (int j = 0; j < old.count; ++j) {
                        if (old.points[j].feature_id == p.feature_id) {
                            best = j;
                            break;
                        }
                        Real d2 = (old.points[j].local_a - p.local_a).squaredNorm();
                        if (d2 < best_d2) {
                            best_d2 = d2;
                            best = j;
                        }
                    }
                    if (best >= 0) {
                        p.normal_impulse = old.points[best].normal_impulse;
                        p.tangent_impulse[0] = old.points[best].tangent_impulse[0];
                        p.tangent_impulse[1] = old.points[best].tangent_impulse[1];
                    }
                }
                break;
            }
        }
        ContactManifold c;
        c.body_a = a;
        c.body_b = b;
        c.friction = friction;
        c.restitution = restitution;
        c.manifold = m;
        c.relative = relative;
        c.normal_local_a = xa.q.conjugate() * m.normal;
        for (int k = 0; k < m.count; ++k) c.detected_depth[k] = m.points[k].depth;
        out.push_back(c);
    }
}

Real RigidSystem::max_penetration() const {
    Real d = 0;
    for (const ContactManifold& c : contacts_)
        for (int i = 0; i < c.manifold.count; ++i) d = std::max(d, c.manifold.points[i].depth);
    return d;
}

bool RigidSystem::may_touch(std::uint32_t a, std::uint32_t b) const {
    if (a > b) std::swap(a, b);
    if (sensor_[a] | sensor_[b]) return false;  // sensors detect, never touch
    if (joints_->filters_pair(a, b)) return false;
    if (!should_collide(filter_[a], filter_[b])) return false;
    return ignored_pairs_.empty() || !std::binary_search(ignored_pairs_.begin(), ignored_pairs_.end(), pair_key(a, b));
}

}  // namespace sinew
