#include "coupling/one_way_coupling.hpp"

#include <algorithm>
#include <cmath>

namespace sinew {

OneWayCoupling::OneWayCoupling(Pipeline& pipeline, RigidSystem& rigid, SoftSystem& soft)
    : pipeline_(pipeline), rigid_(rigid), soft_(soft) {
    const int soft_index = pipeline.find_system(soft.name());
    hook_ = pipeline.add_hook(soft_index, Stage::IntegratePositions, HookWhen::Before,
                              [this](const StepContext& ctx) { refresh(ctx.h); }, "one-way rigid->soft");
}

OneWayCoupling::~OneWayCoupling() { pipeline_.remove_hook(hook_); }

void OneWayCoupling::refresh(Real h) {
    std::vector<Collider>& colliders = soft_.colliders();
    colliders.clear();
    if (soft_.body_count() == 0) return;
    mark_.resize(rigid_.slot_count(), 0);
    if (++stamp_ == 0) {
        std::fill(mark_.begin(), mark_.end(), 0);
        stamp_ = 1;
    }
    const RigidSystem::State& st = rigid_.state();
    for (std::uint32_t s = 0; s < soft_.slot_count(); ++s) {
        if (!soft_.slot_alive(s)) continue;
        SoftBody& body = soft_.slot_body(s);
        // Attachments first: their frames are read even when the body sleeps (a moving body wakes it).
        for (Attachment& a : body.attachments) {
            const BodyId id = unpack_body_id(a.target);
            a.frame_valid = rigid_.valid(id);
            if (!a.frame_valid) continue;
            a.frame = rigid_.slot_transform(id.index);
            a.frame_com = st.x[id.index];
            a.frame_v = st.v[id.index];
            a.frame_w = st.w[id.index];
        }
        // Reach of the body this step: its box grown by the distance its fastest particle can travel.
        Real vmax2 = 0;
        for (const Vec3& v : body.p.v) vmax2 = std::max(vmax2, v.squaredNorm());
        // Gravity as this step will apply it (the body's own field still holds last step's).
        const Vec3 g = soft_.settings().gravity * body.def.gravity_scale;
        Real amax = g.norm();
        for (std::size_t i = 0; i < body.p.size(); ++i)
            if (body.p.inv_mass[i] > 0) amax = std::max(amax, g.norm() + body.p.f[i].norm() * body.p.inv_mass[i]);
        const Aabb reach = soft_.bounds(s).fattened(std::sqrt(vmax2) * h + amax * h * h);
        rigid_.query_bodies(reach, [&](std::uint32_t slot) {
            if (mark_[slot] == stamp_) return;
            mark_[slot] = stamp_;
            Collider c;
            c.shape = &rigid_.slot_shape(slot);
            c.xf = rigid_.slot_transform(slot);
            c.com = st.x[slot];
            c.v = st.v[slot];
            c.w = st.w[slot];
            c.box = c.shape->bounds(c.xf);
            c.friction = rigid_.slot_material(slot).friction;
            c.restitution = rigid_.slot_material(slot).restitution;
            c.owner = slot;
            c.dynamic = rigid_.slot_type(slot) == BodyType::Dynamic ? 1 : 0;
            colliders.push_back(c);
        });
    }
}

}  // namespace sinew
