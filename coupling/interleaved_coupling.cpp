// Interleaved coupling (Baraff & Witkin 1997, "Partitioned dynamics"; seed 001 ch.4 §1): the soft and the
// rigid system step alternately, each against the other's previous result, and only forces cross.
//
//   - the soft bodies meet each rigid body where its previous motion takes it: the collider poses
//     predicted before the rigid solve are kept (the one-way part would refine them with the solved
//     velocities, which an interleaved soft step does not know yet);
//   - the impulses the soft contacts gave the particles become forces -J/h on the rigid bodies, applied
//     in the next step (the rigid system's "previous result" of the soft one);
//   - repair: the rigid bodies moved differently from the prediction the soft bodies stepped against,
//     so the particles that touched one are carried by the difference, A P^-1, from the predicted pose P
//     to the actual one A. last_repair() is the largest such move: the discrepancy seed 001 names.
// A collider counts as interleaved when any soft body is interleaved against its rigid body.
#include "coupling/coupling_layer.hpp"

#include <algorithm>

namespace sinew {

void CouplingLayer::apply_interleaved_forces() {
    for (const PendingForce& f : pending_forces_) {
        if (f.rigid >= rigid_.slot_count() || !rigid_.slot_alive(f.rigid)) continue;
        const BodyId id = rigid_.id_of_slot(f.rigid);
        if (id.generation != f.generation) continue;  // destroyed since
        // A soft body that blew up (an explicit exchange past its stability limit, docs/coupling.md) has
        // non-finite impulses: they are dropped here rather than thrown out of the middle of a step.
        if (!is_finite(f.force)) continue;
        rigid_.apply_force(id, f.force, rigid_.slot_transform(f.rigid).apply(f.local_point));
    }
    pending_forces_.clear();
}

void CouplingLayer::snapshot_colliders() {
    const std::vector<Collider>& colliders = soft_.colliders();
    snapshot_ = colliders;
    interleaved_.assign(colliders.size(), 0);
    if (!any(CouplingStrategy::Interleaved)) return;
    for (std::size_t c = 0; c < colliders.size(); ++c) {
        const Collider& col = colliders[c];
        if (!col.dynamic || col.owner >= rigid_.slot_count() || !rigid_.slot_alive(col.owner)) continue;
        const BodyId rid = rigid_.id_of_slot(col.owner);
        for (std::uint32_t s = 0; s < soft_.slot_count() && !interleaved_[c]; ++s)
            if (soft_.slot_alive(s) &&
                coupling_strategy_of(settings_, soft_.id_of_slot(s), rid) == CouplingStrategy::Interleaved)
                interleaved_[c] = 1;
    }
}

void CouplingLayer::keep_previous_poses() {
    std::vector<Collider>& colliders = soft_.colliders();
    for (std::size_t c = 0; c < colliders.size() && c < interleaved_.size(); ++c)
        if (interleaved_[c]) colliders[c] = snapshot_[c];
}

void CouplingLayer::gather_interleaved_forces(Real h) {
    repairs_.clear();
    const std::vector<Collider>& colliders = soft_.colliders();
    for (const ParticleContact& pc : soft_.contacts()) {
        if (pc.collider >= interleaved_.size() || !interleaved_[pc.collider]) continue;
        const Collider& c = colliders[pc.collider];
        if (coupling_strategy_of(settings_, soft_.id_of_slot(pc.body), rigid_.id_of_slot(c.owner)) !=
            CouplingStrategy::Interleaved)
            continue;
        repairs_.push_back({pc.body, pc.particle, pc.collider});
        if (pc.impulse.isZero()) continue;
        PendingForce f;
        f.rigid = c.owner;
        f.generation = rigid_.id_of_slot(c.owner).generation;
        f.local_point = c.xf.apply_inverse(pc.point);  // the predicted pose the contact was found at
        f.force = -pc.impulse / h;
        pending_forces_.push_back(f);
        sent_back_.push_back({c.owner, pc.body, pc.particle, pc.point, pc.normal, -pc.impulse});  // given as a force over the next step
    }
}

void CouplingLayer::repair_interleaved() {
    last_repair_ = 0;
    for (const Repair& r : repairs_) {
        const Collider& predicted = snapshot_[r.collider];
        if (predicted.owner >= rigid_.slot_count() || !rigid_.slot_alive(predicted.owner)) continue;
        const Transform actual = rigid_.slot_transform(predicted.owner);
        Vec3& x = soft_.slot_body(r.soft).p.x[r.particle];
        const Vec3 moved = actual.apply(predicted.xf.apply_inverse(x));
        last_repair_ = std::max(last_repair_, (moved - x).norm());
        x = moved;
    }
    repairs_.clear();
}

}  // namespace sinew
