// Sensor overlaps and their events (see sensor_tracker.hpp for the rules).
#include "engine/world/sensor_tracker.hpp"

#include <algorithm>
#include <tuple>

#include "soft/particle_collision.hpp"

namespace sinew {

bool SensorTracker::Key::operator<(const Key& o) const {
    return std::tie(sensor, sensor_generation, soft, slot, generation) <
           std::tie(o.sensor, o.sensor_generation, o.soft, o.slot, o.generation);
}
bool SensorTracker::Key::operator==(const Key& o) const {
    return sensor == o.sensor && sensor_generation == o.sensor_generation && soft == o.soft && slot == o.slot &&
           generation == o.generation;
}

SensorOverlap SensorTracker::overlap_of(const Key& k) {
    SensorOverlap o;
    o.sensor = {k.sensor, k.sensor_generation};
    o.soft = k.soft != 0;
    if (o.soft) o.soft_body = {k.slot, k.generation};
    else o.body = {k.slot, k.generation};
    return o;
}

void SensorTracker::find(const RigidSystem& rigid, const SoftSystem& soft, const CouplingLayer& coupling,
                         std::uint32_t s) {
    const Shape& shape = rigid.slot_shape(s);
    const Transform xf = rigid.slot_transform(s);
    const Aabb box = shape.bounds(xf);
    const CollisionFilter& filter = rigid.slot_filter(s);
    const std::uint32_t sg = rigid.id_of_slot(s).generation;
    const std::size_t first = next_.size();
    rigid.query_all_bodies(box, [&](std::uint32_t v) {
        if (v == s || rigid.slot_sensor(v) || rigid.slot_type(v) == BodyType::Static) return;
        if (!should_collide(filter, rigid.slot_filter(v))) return;
        if (coupling.embedding().is_proxy(rigid.id_of_slot(v))) return;
        const Shape& vs = rigid.slot_shape(v);
        const Transform vx = rigid.slot_transform(v);
        if (!vs.bounds(vx).overlaps(box)) return;  // the tree's boxes are fattened
        if (shapes_touch(shape, xf, vs, vx, manifolds_)) next_.push_back({s, sg, 0, v, rigid.id_of_slot(v).generation});
    });
    // The tree reports in its own order: visitors by slot.
    std::sort(next_.begin() + static_cast<std::ptrdiff_t>(first), next_.end());
    for (std::uint32_t b = 0; b < soft.slot_count(); ++b) {
        if (!soft.slot_alive(b)) continue;
        const SoftBody& body = soft.slot_body(b);
        if (!should_collide(filter, body.def.filter)) continue;
        const Real r = body.def.thickness;
        if (!soft.bounds(b).fattened(r).overlaps(box)) continue;
        bool inside = false;
        for (std::size_t i = 0; i < body.p.size() && !inside; ++i) {
            const Vec3& x = body.p.x[i];
            if (x.x() < box.lo.x() - r || x.x() > box.hi.x() + r || x.y() < box.lo.y() - r || x.y() > box.hi.y() + r ||
                x.z() < box.lo.z() - r || x.z() > box.hi.z() + r)
                continue;
            Vec3 point, normal;
            Real d = 0;
            inside = point_shape_distance(x, shape, xf, r, point, normal, d) && d <= r;
        }
        if (inside) next_.push_back({s, sg, 1, b, soft.id_of_slot(b).generation});
    }
}

void SensorTracker::update(const RigidSystem& rigid, const SoftSystem& soft, const CouplingLayer& coupling,
                           std::uint64_t step) {
    events_.clear();
    next_.clear();
    for (std::uint32_t s : rigid.sensor_slots())
        if (rigid.slot_enabled(s)) find(rigid, soft, coupling, s);  // a disabled sensor sees nothing
    // Merge join: keys only in the old list ended, keys only in the new one began.
    std::size_t i = 0, j = 0;
    while (i < current_.size() || j < next_.size()) {
        if (j == next_.size() || (i < current_.size() && current_[i] < next_[j])) {
            events_.push_back({overlap_of(current_[i++]), false, step});
        } else if (i == current_.size() || next_[j] < current_[i]) {
            events_.push_back({overlap_of(next_[j++]), true, step});
        } else {
            ++i;
            ++j;
        }
    }
    std::swap(current_, next_);
}

void SensorTracker::overlaps(BodyId sensor, std::vector<SensorOverlap>& out) const {
    out.clear();
    const Key lo{sensor.index, sensor.generation, 0, 0, 0};
    for (auto it = std::lower_bound(current_.begin(), current_.end(), lo);
         it != current_.end() && it->sensor == sensor.index && it->sensor_generation == sensor.generation; ++it)
        out.push_back(overlap_of(*it));
}

}  // namespace sinew
