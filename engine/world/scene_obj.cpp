// A minimal Wavefront OBJ reader for static triangle meshes referenced by scene files. Only geometry
// matters to a collision mesh, so `v` and `f` lines are read and everything else (normals, texture
// coordinates, groups, materials) is skipped.
#include <cmath>
#include <fstream>
#include <sstream>

#include "engine/world/scene.hpp"

namespace sinew {

namespace {

[[noreturn]] void obj_fail(const std::string& path, int line, const std::string& problem) {
    throw std::runtime_error(path + ":" + std::to_string(line) + ": " + problem);
}

// One index of a face corner ("7", "7/2", "7//3", "-1/...") -> zero-based vertex index.
std::uint32_t face_index(const std::string& token, std::size_t vertex_count, const std::string& path, int line) {
    const std::string head = token.substr(0, token.find('/'));
    long long k = 0;
    std::size_t used = 0;
    try {
        k = std::stoll(head, &used);
    } catch (const std::exception&) {
        obj_fail(path, line, "bad face index '" + token + "'");
    }
    if (used != head.size()) obj_fail(path, line, "bad face index '" + token + "'");
    // OBJ indices are 1-based; negative ones count back from the last vertex read so far.
    const long long n = static_cast<long long>(vertex_count);
    const long long zero_based = k > 0 ? k - 1 : n + k;
    if (k == 0 || zero_based < 0 || zero_based >= n)
        obj_fail(path, line, "face index " + head + " is out of range (" + std::to_string(n) + " vertices so far)");
    return static_cast<std::uint32_t>(zero_based);
}

}  // namespace

ObjMesh read_obj_file(const std::string& path) {
    std::ifstream in(path);
    if (!in) throw std::runtime_error(path + ": cannot open OBJ file");
    ObjMesh mesh;
    std::string text;
    int line = 0;
    while (std::getline(in, text)) {
        ++line;
        std::istringstream ls(text);
        std::string tag;
        if (!(ls >> tag)) continue;
        if (tag == "v") {
            double xyz[3];
            for (double& c : xyz)
                if (!(ls >> c) || !std::isfinite(c)) obj_fail(path, line, "a vertex needs 3 finite coordinates");
            mesh.vertices.emplace_back(Real(xyz[0]), Real(xyz[1]), Real(xyz[2]));
        } else if (tag == "f") {
            std::vector<std::uint32_t> corners;
            std::string token;
            while (ls >> token) corners.push_back(face_index(token, mesh.vertices.size(), path, line));
            if (corners.size() < 3) obj_fail(path, line, "a face needs at least 3 vertices");
            // Fan triangulation; exact for the convex polygons exporters write.
            for (std::size_t i = 1; i + 1 < corners.size(); ++i) {
                mesh.indices.push_back(corners[0]);
                mesh.indices.push_back(corners[i]);
                mesh.indices.push_back(corners[i + 1]);
            }
        }
    }
    if (mesh.indices.empty()) throw std::runtime_error(path + ": OBJ file has no faces");
    return mesh;
}

}  // namespace sinew
