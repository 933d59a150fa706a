// Changing what a body is while the world runs: its type (static, kinematic, dynamic) and whether it takes
// part in the simulation at all (Box2D v3's b2Body_SetType and b2Body_Disable/Enable).
#include <algorithm>
#include <string>

#include "engine/core/format.hpp"
#include "rigid/rigid_system.hpp"

namespace sinew {

void RigidSystem::wake_touching(std::uint32_t s) {
    // Its own island first: sleeping islands keep their union-find links (update_sleep), which must not
    // lead through a slot that changes what it is.
    wake_island(s);
    for (const ContactManifold& c : contacts_)
        if (c.body_a == s || c.body_b == s) {
            wake_island(c.body_a);
            wake_island(c.body_b);
        }
}

void RigidSystem::drop_contacts_of(std::uint32_t s) {
    restore_disabled();  // its indices are into contacts_ as it is now
    auto gone = [s](const ContactManifold& c) { return c.body_a == s || c.body_b == s; };
    contacts_.erase(std::remove_if(contacts_.begin(), contacts_.end(), gone), contacts_.end());
    pair_layout_valid_ = false;  // offsets moved: the next detection finds each pair's manifolds by key
    // Should this happen between detection and the solve, every manifold left is handed to the solver
    // (sleeping ones are immovable there, so that costs time, not results).
    list_active_contacts();  // every manifold left
}

MassProperties RigidSystem::dynamic_mass_properties(std::uint32_t s, const char* where) const {
    MassProperties mp;
    try {
        mp = def_mass_[s] > 0 ? mass_properties_for_mass(shape_[s], def_mass_[s])
                              : compute_mass_properties(shape_[s], material_[s].density);
    } catch (const ShapeError& e) {
        throw RigidError(std::string(where) + ": " + e.what());
    }
    if (!(mp.mass >= kMinBodyMass && mp.mass <= kMaxBodyMass))
        throw RigidError(std::string(where) + ": a dynamic body's mass must be in [" + to_text(kMinBodyMass) + ", " +
                         to_text(kMaxBodyMass) + "] kg, got " + to_text(mp.mass));
    return mp;
}

void RigidSystem::set_type(BodyId id, BodyType type) {
    check(id, "set_type");
    ++structure_revision_;
    const std::uint32_t s = id.index;
    if (type != BodyType::Static && type != BodyType::Kinematic && type != BodyType::Dynamic)
        throw RigidError("set_type: unknown body type " + std::to_string(int(type)));
    if (type_[s] == type) return;
    if (type != BodyType::Static && !shape_[s].can_be_dynamic())
        throw RigidError(std::string("set_type: a ") + shape_type_name(shape_[s].type) + " can only belong to a static body");
    const bool dynamic = type == BodyType::Dynamic;
    const MassProperties mp = dynamic ? dynamic_mass_properties(s, "set_type") : MassProperties{};
    // Everything is checked: from here on nothing throws.
    const Transform origin = origin_transform(s);
    wake_touching(s);  // what rested on it (or it on them) must see the change
    type_[s] = type;
    mass_[s] = dynamic ? mp.mass : 0;
    body_inv_mass_[s] = dynamic ? 1 / mp.mass : 0;
    widen_inv_mass_range(body_inv_mass_[s]);
    inertia_local_[s] = dynamic ? mp.inertia : Mat3::Zero();
    inv_inertia_local_[s] = dynamic ? Mat3(mp.inertia.inverse()) : Mat3::Zero();
    {
        const Mat3& in = inertia_local_[s];
        const Real k = in.trace() / 3;
        spherical_inertia_[s] = (in - k * Mat3::Identity()).cwiseAbs().maxCoeff() <= Real(1e-6) * std::abs(k) ? 1 : 0;
    }
    // The origin stays where it is; the centre of mass (the state's x) moves with the new local centre.
    local_com_[s] = dynamic ? mp.center : Vec3::Zero();
    state_.x[s] = origin.apply(local_com_[s]);
    if (type == BodyType::Static) {
        state_.v[s].setZero();
        state_.w[s].setZero();
    }
    state_.inv_mass[s] = enabled_[s] ? body_inv_mass_[s] : 0;
    const Mat3 r = state_.q[s].toRotationMatrix();
    state_.inv_inertia_world[s] = r * inv_inertia_local_[s] * r.transpose();
    w_frame_[s] = state_.q[s];
    awake_[s] = type != BodyType::Static && enabled_[s];
    sleep_timer_[s] = 0;
    start_x_[s] = state_.x[s];
    start_q_[s] = state_.q[s];
    ignored_changed_ = true;  // the pair list is rebuilt: pairs of two non-dynamic bodies drop out
    if (proxy_[s] != DynamicTree::kNull)
        tree_.move(proxy_[s], shape_[s].bounds(origin), Vec3::Zero(), settings_.contact_margin);
}

void RigidSystem::set_enabled(BodyId id, bool enable) {
    check(id, "set_enabled");
    const std::uint32_t s = id.index;
    if ((enabled_[s] != 0) == enable) return;
    if (!enable) {
        wake_touching(s);
        tree_.destroy(proxy_[s]);
        proxy_[s] = DynamicTree::kNull;
        drop_contacts_of(s);  // as when it is destroyed: nothing touches it while it is out
        enabled_[s] = 0;
        awake_[s] = false;
        sleep_timer_[s] = 0;
        state_.v[s].setZero();
        state_.w[s].setZero();
        state_.inv_mass[s] = 0;
    } else {
        enabled_[s] = 1;
        proxy_[s] = tree_.create(shape_[s].bounds(origin_transform(s)), s, settings_.contact_margin);
        awake_[s] = type_[s] != BodyType::Static;
        sleep_timer_[s] = 0;
        state_.inv_mass[s] = awake_[s] ? body_inv_mass_[s] : 0;
        w_frame_[s] = state_.q[s];
    }
    ignored_changed_ = true;
}

bool RigidSystem::enabled(BodyId id) const {
    check(id, "enabled");
    return enabled_[id.index] != 0;
}

}  // namespace sinew
