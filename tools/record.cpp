// Writes docs/record-format.md: a JSON header line, then one JSON line per frame or, for ".sinrec"
// files, one block of float32 values per frame.
#include "tools/record.hpp"

#include <charconv>
#include <cstring>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "rigid/joint_set.hpp"

namespace sinew::tool {

namespace {

using Json = nlohmann::ordered_json;

// Frames are written in float precision (what a viewer draws with), as the shortest decimal that reads
// back to the same float: a 5,500-body recording stays a few times smaller than with 17-digit doubles.
void append_number(std::string& out, double v) {
    if (!std::isfinite(v) || std::abs(v) > std::numeric_limits<float>::max()) {
        out += "null";  // JSON has no NaN or infinity
        return;
    }
    char buf[32];
    const auto r = std::to_chars(buf, buf + sizeof buf, static_cast<float>(v));
    out.append(buf, r.ptr);
}

// The same value as a double whose shortest decimal is the float's, so the header prints "0.1", not
// "0.10000000149011612".
Json tidy(double v) {
    std::string s;
    append_number(s, v);
    if (s == "null") return Json(nullptr);
    return Json(std::strtod(s.c_str(), nullptr));
}

Json vec_json(const Vec3& v) { return Json::array({tidy(v.x()), tidy(v.y()), tidy(v.z())}); }
Json quat_json(const Quat& q) { return Json::array({tidy(q.w()), tidy(q.x()), tidy(q.y()), tidy(q.z())}); }

// Shapes in the scene format's own shape objects (docs/scene-format.md), so a viewer can share code.
Json shape_json(const Shape& s) {
    Json j;
    j["type"] = shape_type_name(s.type);
    switch (s.type) {
        case ShapeType::Sphere: j["radius"] = tidy(s.radius); break;
        case ShapeType::Box: j["half_extents"] = vec_json(s.half_extents); break;
        case ShapeType::Capsule:
            j["radius"] = tidy(s.radius);
            j["half_height"] = tidy(s.half_height);
            break;
        case ShapeType::ConvexHull: {
            Json pts = Json::array();
            for (const Vec3& v : s.hull->vertices) pts.push_back(vec_json(v));
            j["points"] = std::move(pts);
            break;
        }
        case ShapeType::Plane:
            j["normal"] = vec_json(s.normal);
            j["offset"] = tidy(s.offset);
            break;
        case ShapeType::TriangleMesh: {
            Json verts = Json::array(), tris = Json::array();
            for (const Vec3& v : s.mesh->vertices) verts.push_back(vec_json(v));
            for (std::size_t t = 0; t + 2 < s.mesh->indices.size(); t += 3)
                tris.push_back({s.mesh->indices[t], s.mesh->indices[t + 1], s.mesh->indices[t + 2]});
            j["vertices"] = std::move(verts);
            j["indices"] = std::move(tris);
            break;
        }
        case ShapeType::Compound: {
            Json kids = Json::array();
            for (const CompoundChild& c : *s.children)
                kids.push_back({{"shape", shape_json(*c.shape)}, {"position", vec_json(c.local.p)},
                                {"rotation", quat_json(c.local.q)}});
            j["children"] = std::move(kids);
            break;
        }
        default: break;
    }
    return j;
}

// Float32 frames are little-endian on disk; every machine Sinew builds for is, and a big-endian one
// is refused rather than writing files no viewer reads.
bool little_endian() {
    const std::uint32_t one = 1;
    unsigned char b;
    std::memcpy(&b, &one, 1);
    return b == 1;
}

}  // namespace

RecordEncoding record_encoding_for(const std::string& path) {
    const std::string ext = ".sinrec";
    return path.size() >= ext.size() && path.compare(path.size() - ext.size(), ext.size(), ext) == 0
               ? RecordEncoding::Float32
               : RecordEncoding::JsonLines;
}

Recorder::Recorder(const std::string& path, const SceneDesc& scene, const World& world, const std::vector<BodyId>& ids,
                   bool contacts)
    : path_(path), out_(path, std::ios::binary | std::ios::trunc), ids_(ids), encoding_(record_encoding_for(path)),
      contacts_(contacts) {
    if (!out_) throw std::runtime_error("cannot write record file " + path);
    if (encoding_ == RecordEncoding::Float32 && !little_endian())
        throw std::runtime_error("record file " + path + ": .sinrec frames are little-endian float32; use a .jsonl name on this machine");
    Json header;
    header["format"] = kRecordFormat;
    header["version"] = kRecordVersion;
    header["encoding"] = encoding_ == RecordEncoding::Float32 ? "float32" : "json";
    header["scene"] = scene.name;
    header["time_step"] = tidy(world.settings().time_step);
    Json bodies = Json::array();
    const RigidSystem& rigid = world.rigid();
    for (std::size_t i = 0; i < ids_.size(); ++i) {
        Json b = {{"name", i < scene.bodies.size() ? scene.bodies[i].name : "body-" + std::to_string(i)},
                  {"type", body_type_name(rigid.type(ids_[i]))},
                  {"shape", shape_json(rigid.shape(ids_[i]))}};
        if (rigid.is_sensor(ids_[i])) b["sensor"] = true;
        bodies.push_back(std::move(b));
    }
    header["bodies"] = std::move(bodies);
    // Soft bodies: one entry per body in creation order (scene order), with its surface triangles so a
    // viewer can draw it; the frames carry the particle positions.
    Json soft = Json::array();
    soft_ids_ = world.soft().bodies();
    for (std::size_t i = 0; i < soft_ids_.size(); ++i) {
        const SoftBody& b = world.soft().body(soft_ids_[i]);
        Json tris = Json::array();
        for (std::size_t t = 0; t + 2 < b.triangles.size(); t += 3)
            tris.push_back({b.triangles[t], b.triangles[t + 1], b.triangles[t + 2]});
        soft.push_back({{"name", i < scene.soft_bodies.size() ? scene.soft_bodies[i].name : "soft-" + std::to_string(i)},
                        {"method", soft_method_name(b.def.method)},
                        {"count", b.p.size()},
                        {"thickness", tidy(b.def.thickness)},
                        {"triangles", std::move(tris)}});
    }
    header["particles"] = std::move(soft);
    // Joints: the bodies by header index (-1: a body the header does not list, such as a soft body's
    // proxy) and the anchors in each body's frame, so a viewer draws them from the frames' transforms.
    Json joints = Json::array();
    const auto header_index = [&](BodyId b) -> long long {
        for (std::size_t i = 0; i < ids_.size(); ++i)
            if (ids_[i].index == b.index && ids_[i].generation == b.generation) return (long long)i;
        return -1;
    };
    for (JointId id : rigid.joints().ids()) {
        const JointDef& d = rigid.joints().def(id);
        joints.push_back({{"type", joint_type_name(d.type)}, {"a", header_index(d.body_a)}, {"b", header_index(d.body_b)},
                          {"anchor_a", vec_json(d.local_anchor_a)}, {"anchor_b", vec_json(d.local_anchor_b)}});
    }
    header["joints"] = std::move(joints);
    header["contacts"] = contacts_;
    if (encoding_ == RecordEncoding::Float32) {
        std::size_t n = 1 + 7 * ids_.size();
        for (SoftBodyId id : soft_ids_) n += 3 * world.soft().body(id).p.size();
        header["frame_floats"] = n;
        frame_floats_ = n;
        floats_.reserve(n);
    }
    out_ << header.dump() << '\n';
}

// Contact points touching or within a millimetre of touching: the soft step's speculative points further
// apart are not contacts a viewer should show.
void Recorder::gather_contacts(const World& world) {
    contact_values_.clear();
    const auto add = [&](const Vec3& p, const Vec3& n) {
        const Real v[6] = {p.x(), p.y(), p.z(), n.x(), n.y(), n.z()};
        for (Real x : v) contact_values_.push_back(float(x));
    };
    for (const ContactManifold& m : world.rigid().contacts())
        for (int i = 0; i < m.manifold.count; ++i)
            if (m.manifold.points[i].depth > Real(-0.001)) add(m.manifold.points[i].position, m.manifold.normal);
    for (const ParticleContact& c : world.soft().contacts()) add(c.point, c.normal);
}

void Recorder::write_frame(const World& world, std::uint64_t frame) {
    if (contacts_) gather_contacts(world);
    if (encoding_ == RecordEncoding::Float32) {
        // [time, bodies' 7 values..., particles' xyz...]: the frame index is the block's position. Non-finite
        // values stay NaN or infinity (the viewer reports them).
        floats_.clear();
        floats_.push_back(float(world.time()));
        const RigidSystem& rigid = world.rigid();
        for (BodyId id : ids_) {
            const Transform xf = rigid.transform(id);
            const Real values[7] = {xf.p.x(), xf.p.y(), xf.p.z(), xf.q.w(), xf.q.x(), xf.q.y(), xf.q.z()};
            for (Real v : values) floats_.push_back(float(v));
        }
        for (SoftBodyId id : soft_ids_) {
            const Particles& p = world.soft().body(id).p;
            for (std::size_t k = 0; k < p.size(); ++k) {
                floats_.push_back(float(p.x[k].x()));
                floats_.push_back(float(p.x[k].y()));
                floats_.push_back(float(p.x[k].z()));
            }
        }
        if (floats_.size() != frame_floats_)
            throw std::runtime_error("record file " + path_ + ": frame " + std::to_string(frame) + " has " +
                                     std::to_string(floats_.size()) + " values where the header promised " +
                                     std::to_string(frame_floats_) + " (a soft body changed its particle count)");
        if (contacts_) {
            // Then the frame's contacts: their count (a float32, exact to 2^24), then 6 values each.
            floats_.push_back(float(contact_values_.size() / 6));
            floats_.insert(floats_.end(), contact_values_.begin(), contact_values_.end());
        }
        out_.write(reinterpret_cast<const char*>(floats_.data()), std::streamsize(floats_.size() * sizeof(float)));
        return;
    }
    line_.clear();
    line_ += "{\"frame\":";
    line_ += std::to_string(frame);
    line_ += ",\"time\":";
    char buf[32];
    const auto r = std::to_chars(buf, buf + sizeof buf, world.time());
    line_.append(buf, r.ptr);
    line_ += ",\"bodies\":[";
    const RigidSystem& rigid = world.rigid();
    for (std::size_t i = 0; i < ids_.size(); ++i) {
        const Transform xf = rigid.transform(ids_[i]);
        line_ += i ? ",[" : "[";
        const Real values[7] = {xf.p.x(), xf.p.y(), xf.p.z(), xf.q.w(), xf.q.x(), xf.q.y(), xf.q.z()};
        for (int k = 0; k < 7; ++k) {
            if (k) line_ += ',';
            append_number(line_, values[k]);
        }
        line_ += ']';
    }
    line_ += "],\"particles\":[";
    for (std::size_t i = 0; i < soft_ids_.size(); ++i) {
        const Particles& p = world.soft().body(soft_ids_[i]).p;
        line_ += i ? ",[" : "[";
        for (std::size_t k = 0; k < p.size(); ++k) {
            if (k) line_ += ',';
            append_number(line_, p.x[k].x());
            line_ += ',';
            append_number(line_, p.x[k].y());
            line_ += ',';
            append_number(line_, p.x[k].z());
        }
        line_ += ']';
    }
    line_ += ']';
    if (contacts_) {
        line_ += ",\"contacts\":[";
        for (std::size_t k = 0; k < contact_values_.size(); ++k) {
            if (k) line_ += ',';
            append_number(line_, contact_values_[k]);
        }
        line_ += ']';
    }
    line_ += "}\n";
    out_ << line_;
}

void Recorder::finish() {
    out_.flush();
    if (!out_) throw std::runtime_error("writing record file " + path_ + " failed");
    out_.close();
}

}  // namespace sinew::tool
