#include "coupling/one_way_coupling.hpp"

#include <algorithm>
#include <cmath>

namespace sinew {

OneWayCoupling::OneWayCoupling(Pipeline& pipeline, RigidSystem& rigid, SoftSystem& soft)
    : pipeline_(pipeline), rigid_(rigid), soft_(soft) {
    const int soft_index = pipeline.find_system(soft.name());
    hooks_[0] = pipeline.add_hook(soft_index, Stage::IntegrateVelocities, HookWhen::Before,
                                  [this](const StepContext&) { refresh_attachments(); }, "one-way rigid->soft: attachments");
    hooks_[1] = pipeline.add_hook(soft_index, Stage::DetectCollisions, HookWhen::Before,
                                  [this](const StepContext& ctx) { refresh_colliders(ctx.h); }, "one-way rigid->soft: colliders");
    hooks_[2] = pipeline.add_hook(soft_index, Stage::SolveVelocities, HookWhen::Before,
                                  [this](const StepContext&) { update(); }, "one-way rigid->soft: solved motion");
}

OneWayCoupling::~OneWayCoupling() {
    for (int h : hooks_) pipeline_.remove_hook(h);
}

void OneWayCoupling::set_substeps(int k) { substeps_ = k; }

Transform OneWayCoupling::between(std::uint32_t slot, Real t, Real f, Vec3& com) const {
    const RigidSystem::State& st = rigid_.state();
    const Transform end = rigid_.predicted_transform(slot, t);
    const Vec3 end_com = st.x[slot] + t * st.v[slot];
    if (f >= 1 || slot >= start_.size()) {
        com = end_com;
        return end;
    }
    com = start_com_[slot] + f * (end_com - start_com_[slot]);
    Transform out;
    out.p = start_[slot].p + f * (end.p - start_[slot].p);
    out.q = start_[slot].q.slerp(f, end.q);
    return out;
}

// A rigid body as a collider, a fraction f of the way to its pose t seconds from now (f = 1: the end of
// the step, predicted from its current motion over t).
void OneWayCoupling::place_collider(Collider& c, std::uint32_t slot, Real t, Real f) const {
    const RigidSystem::State& st = rigid_.state();
    c.xf = between(slot, t, f, c.com);
    c.v = st.v[slot];
    c.w = st.w[slot];
    c.box = c.shape->bounds(c.xf);
}

void OneWayCoupling::place_attachment(Attachment& a, Real t, Real f) const {
    const BodyId id = unpack_body_id(a.target);
    a.frame_valid = rigid_.valid(id);
    if (!a.frame_valid) return;
    const RigidSystem::State& st = rigid_.state();
    a.frame = between(id.index, t, f, a.frame_com);
    a.frame_v = st.v[id.index];
    a.frame_w = st.w[id.index];
}

void OneWayCoupling::update() {
    const Real t = rigid_.unintegrated_time();
    const Real f = Real(1) / Real(substeps_);
    for (Collider& c : soft_.colliders())
        if (c.owner != kNoOwner && c.owner < rigid_.slot_count() && rigid_.slot_alive(c.owner))
            place_collider(c, c.owner, t, f);
    place_attachments(t, f);
}

void OneWayCoupling::place_substep(int j) {
    // After the rigid step: every body is at its end pose (t = 0 from now).
    const Real f = Real(j + 1) / Real(substeps_);
    for (Collider& c : soft_.colliders())
        if (c.owner != kNoOwner && c.owner < rigid_.slot_count() && rigid_.slot_alive(c.owner))
            place_collider(c, c.owner, 0, f);
    place_attachments(0, f);
}

void OneWayCoupling::place_attachments(Real t, Real f) {
    for (std::uint32_t s = 0; s < soft_.slot_count(); ++s) {
        if (!soft_.slot_alive(s)) continue;
        // Read even when the body sleeps: a moving attachment wakes it.
        for (Attachment& a : soft_.slot_body(s).attachments) place_attachment(a, t, f);
    }
}

void OneWayCoupling::refresh_attachments() {
    if (substeps_ > 1) {
        // The start of the step: every body's pose, for the sub-steps' interpolation.
        const RigidSystem::State& st = rigid_.state();
        start_.resize(rigid_.slot_count());
        start_com_.resize(rigid_.slot_count());
        for (std::uint32_t s = 0; s < rigid_.slot_count(); ++s) {
            if (!rigid_.slot_alive(s)) continue;
            start_[s] = rigid_.slot_transform(s);
            start_com_[s] = st.x[s];
        }
    } else {
        start_.clear();
    }
    place_attachments(rigid_.unintegrated_time(), Real(1) / Real(substeps_));
}

void OneWayCoupling::refresh_colliders(Real h) {
    std::vector<Collider>& colliders = soft_.colliders();
    colliders.clear();
    if (soft_.body_count() == 0 || rigid_.body_count() == 0) return;
    mark_.resize(rigid_.slot_count(), 0);
    if (++stamp_ == 0) {
        std::fill(mark_.begin(), mark_.end(), 0);
        stamp_ = 1;
    }
    const Real t = rigid_.unintegrated_time();
    for (std::uint32_t s = 0; s < soft_.slot_count(); ++s) {
        if (!soft_.slot_alive(s)) continue;
        const SoftBody& body = soft_.slot_body(s);
        // Reach of the body this step: its box grown by the distance its fastest particle can travel. A
        // sleeping body has no velocity or force (anything that gives it one wakes it) and a kept box, so
        // it costs nothing per particle here.
        Real vmax2 = 0;
        const Vec3 g = soft_.settings().gravity * body.def.gravity_scale;
        Real amax = g.norm();
        if (body.awake) {
            for (std::size_t i = 0; i < body.p.size(); ++i) {
                vmax2 = std::max(vmax2, body.p.v[i].squaredNorm());
                // Most particles carry no external force: no square root for them.
                if (body.p.inv_mass[i] > 0 && body.p.f[i].squaredNorm() != 0)
                    amax = std::max(amax, g.norm() + body.p.f[i].norm() * body.p.inv_mass[i]);
            }
        }
        const Aabb reach = soft_.bounds(s).fattened(std::sqrt(vmax2) * h + amax * h * h);
        rigid_.query_bodies(reach, [&](std::uint32_t slot) {
            if (mark_[slot] == stamp_) return;
            mark_[slot] = stamp_;
            Collider c;
            c.shape = &rigid_.slot_shape(slot);
            place_collider(c, slot, t, Real(1) / Real(substeps_));
            c.friction = rigid_.slot_material(slot).friction;
            c.restitution = rigid_.slot_material(slot).restitution;
            c.owner = slot;
            c.dynamic = rigid_.slot_type(slot) == BodyType::Dynamic ? 1 : 0;
            c.filter = rigid_.slot_filter(slot);
            colliders.push_back(c);
        });
    }
}

}  // namespace sinew
