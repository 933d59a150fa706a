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

namespace {

// A rigid body's pose at the end of the step, predicted from its current motion over `t`.
void place_collider(Collider& c, const RigidSystem& rigid, std::uint32_t slot, Real t) {
    const RigidSystem::State& st = rigid.state();
    c.xf = rigid.predicted_transform(slot, t);
    c.com = st.x[slot] + t * st.v[slot];
    c.v = st.v[slot];
    c.w = st.w[slot];
    c.box = c.shape->bounds(c.xf);
}

void place_attachment(Attachment& a, const RigidSystem& rigid, Real t) {
    const BodyId id = unpack_body_id(a.target);
    a.frame_valid = rigid.valid(id);
    if (!a.frame_valid) return;
    const RigidSystem::State& st = rigid.state();
    a.frame = rigid.predicted_transform(id.index, t);
    a.frame_com = st.x[id.index] + t * st.v[id.index];
    a.frame_v = st.v[id.index];
    a.frame_w = st.w[id.index];
}

}  // namespace

void OneWayCoupling::update() {
    const Real t = rigid_.unintegrated_time();
    for (Collider& c : soft_.colliders())
        if (c.owner != kNoOwner && c.owner < rigid_.slot_count() && rigid_.slot_alive(c.owner))
            place_collider(c, rigid_, c.owner, t);
    refresh_attachments();
}

void OneWayCoupling::refresh_attachments() {
    const Real t = rigid_.unintegrated_time();
    for (std::uint32_t s = 0; s < soft_.slot_count(); ++s) {
        if (!soft_.slot_alive(s)) continue;
        // Read even when the body sleeps: a moving attachment wakes it.
        for (Attachment& a : soft_.slot_body(s).attachments) place_attachment(a, rigid_, t);
    }
}

void OneWayCoupling::refresh_colliders(Real h) {
    std::vector<Collider>& colliders = soft_.colliders();
    colliders.clear();
    if (soft_.body_count() == 0) return;
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
            for (const Vec3& v : body.p.v) vmax2 = std::max(vmax2, v.squaredNorm());
            for (std::size_t i = 0; i < body.p.size(); ++i)
                if (body.p.inv_mass[i] > 0) amax = std::max(amax, g.norm() + body.p.f[i].norm() * body.p.inv_mass[i]);
        }
        const Aabb reach = soft_.bounds(s).fattened(std::sqrt(vmax2) * h + amax * h * h);
        rigid_.query_bodies(reach, [&](std::uint32_t slot) {
            if (mark_[slot] == stamp_) return;
            mark_[slot] = stamp_;
            Collider c;
            c.shape = &rigid_.slot_shape(slot);
            place_collider(c, rigid_, slot, t);
            c.friction = rigid_.slot_material(slot).friction;
            c.restitution = rigid_.slot_material(slot).restitution;
            c.owner = slot;
            c.dynamic = rigid_.slot_type(slot) == BodyType::Dynamic ? 1 : 0;
            colliders.push_back(c);
        });
    }
}

}  // namespace sinew
