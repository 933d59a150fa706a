// Recording a run for playback: the header names every body and its shape (and every soft body with its
// surface), then one line per frame holds each body's transform and each soft body's particle positions. Format: docs/record-format.md.
#pragma once

#include <fstream>
#include <string>
#include <vector>

#include "engine/world/scene.hpp"

namespace sinew::tool {

constexpr const char* kRecordFormat = "sinew-record";
constexpr int kRecordVersion = 2;

/// How frames are written: JSON lines (small files, readable) or raw little-endian float32 frames after the
/// JSON header line (large runs: 28 bytes per body per frame, read by the viewer without parsing).
enum class RecordEncoding { JsonLines, Float32 };

/// The encoding a file name asks for: ".sinrec" is Float32, anything else JSON lines.
RecordEncoding record_encoding_for(const std::string& path);

class Recorder {
public:
    /// Opens `path` and writes the header line, in the encoding the file name asks for
    /// (record_encoding_for). Throws std::runtime_error if the file cannot be written.
    /// `contacts`: every frame also lists the step's contact points and normals (rigid manifolds and soft
    /// particle contacts), for the viewer's overlay; off by default (a 5,500-box pyramid grid has 80,000).
    Recorder(const std::string& path, const SceneDesc& scene, const World& world, const std::vector<BodyId>& ids,
             bool contacts = false);
    /// Appends one frame with the current transform of every body, in header order, and every soft body's
    /// particle positions.
    void write_frame(const World& world, std::uint64_t frame);
    /// Flushes and checks the stream; throws std::runtime_error on a write failure (disk full, ...).
    void finish();

private:
    std::string path_;
    std::ofstream out_;
    std::vector<BodyId> ids_;
    std::vector<SoftBodyId> soft_ids_;  ///< soft bodies at the start, in creation order
    RecordEncoding encoding_ = RecordEncoding::JsonLines;
    std::vector<float> floats_;  // one Float32 frame, reused
    std::size_t frame_floats_ = 0;  // the header's promise for every Float32 frame (before its contacts)
    bool contacts_ = false;
    std::vector<float> contact_values_;  // this frame's contacts: x y z nx ny nz per point, reused
    void gather_contacts(const World& world);
    std::string line_;  // reused for every frame, so recording allocates nothing per frame once warm
};

}  // namespace sinew::tool
