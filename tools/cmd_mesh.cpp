// `sinew mesh SURFACE.obj OUT [--max-volume V] [--quality Q] [--scale S]`: a solid tet mesh from a closed
// triangle surface, through TetGen (Si 2015, "TetGen, a Delaunay-based quality tetrahedral mesh
// generator"; the `tetgen` program of Debian's tetgen package, installed by scripts/setup). Why TetGen:
// it is one small program that meshes a closed surface with a quality bound (radius-edge ratio) and a
// volume bound, and writes the .node/.ele pair Sinew already reads; gmsh does the same inside a far larger
// package. TetGen runs here, in the tool, never in the library or at scene load: `sinew mesh` writes
// OUT.node and OUT.ele once, and scenes load those (builder "tet-mesh").
#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>

#include "engine/world/scene.hpp"
#include "soft/soft_body.hpp"
#include "soft/soft_integrators.hpp"
#include "soft/tet_mesh.hpp"
#include "tools/commands.hpp"

namespace sinew::tool {

namespace {

namespace fs = std::filesystem;

struct MeshError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

// The surface must be closed and consistently oriented for TetGen to fill it: every edge on exactly two
// triangles, in opposite directions, and a positive enclosed volume (counter-clockwise from outside).
void check_closed(const ObjMesh& m, const std::string& path) {
    std::map<std::pair<std::uint32_t, std::uint32_t>, int> directed;
    for (std::size_t t = 0; t + 2 < m.indices.size(); t += 3)
        for (int c = 0; c < 3; ++c) {
            const std::uint32_t a = m.indices[t + c], b = m.indices[t + (c + 1) % 3];
            if (++directed[{a, b}] > 1)
                throw MeshError(path + ": the edge (" + std::to_string(a) + ", " + std::to_string(b) + ") runs the same way in two triangles "
                                "(the triangles are not consistently oriented, or the surface is not a manifold)");
        }
    for (const auto& e : directed)
        if (!directed.count({e.first.second, e.first.first}))
            throw MeshError(path + ": the edge (" + std::to_string(e.first.first) + ", " + std::to_string(e.first.second) +
                            ") belongs to one triangle only: the surface is not closed");
    const Real v = enclosed_volume(m.indices, m.vertices);
    if (!(v > 0))
        throw MeshError(path + ": the surface encloses " + std::to_string(v) + " m^3: it must be closed and counter-clockwise from outside");
}

// Runs `tetgen SWITCHES INPUT` with its output into `log`, without a shell (the paths need no quoting);
// returns its exit status, 127 if it cannot be started.
int run_tetgen(const std::string& switches, const std::string& input, const std::string& log) {
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&actions, 1, 2);
    std::string a0 = "tetgen", a1 = switches, a2 = input;
    char* argv[] = {a0.data(), a1.data(), a2.data(), nullptr};
    pid_t pid = 0;
    const int started = posix_spawnp(&pid, "tetgen", &actions, nullptr, argv, environ);
    posix_spawn_file_actions_destroy(&actions);
    if (started != 0) return 127;
    int status = 0;
    if (waitpid(pid, &status, 0) < 0) return 127;
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128;
}

int mesh(const std::vector<std::string>& args) {
    std::vector<std::string> files;
    double max_volume = 0, quality = 1.4, scale = 1;
    for (std::size_t i = 0; i < args.size(); ++i) {
        const std::string& a = args[i];
        if (is_option(a, "--max-volume")) max_volume = parse_positive("--max-volume", option_value(args, i, "--max-volume"));
        else if (is_option(a, "--quality")) quality = parse_positive("--quality", option_value(args, i, "--quality"));
        else if (is_option(a, "--scale")) scale = parse_positive("--scale", option_value(args, i, "--scale"));
        else if (!a.empty() && a[0] == '-') throw UsageError("unknown option '" + a + "'");
        else files.push_back(a);
    }
    if (files.size() != 2) throw UsageError("expected SURFACE.obj and OUT");
    if (quality < 1.0) throw UsageError("--quality must be >= 1 (TetGen's radius-edge bound; 1.4 is a good start)");
    const std::string& in = files[0];
    const std::string& out = files[1];
    try {
        ObjMesh surface = read_obj_file(in);
        for (Vec3& v : surface.vertices) v *= Real(scale);
        check_closed(surface, in);

        // TetGen's .smesh input: the nodes, then one facet per triangle.
        const fs::path dir = fs::temp_directory_path() / ("sinew-mesh-" + std::to_string(::getpid()));
        fs::create_directories(dir);
        struct Cleanup {
            fs::path d;
            ~Cleanup() {
                std::error_code ec;
                fs::remove_all(d, ec);
            }
        } cleanup{dir};
        {
            std::ofstream s(dir / "in.smesh");
            s.precision(9);
            s << surface.vertices.size() << " 3 0 0\n";
            for (std::size_t i = 0; i < surface.vertices.size(); ++i)
                s << i << " " << surface.vertices[i].x() << " " << surface.vertices[i].y() << " " << surface.vertices[i].z() << "\n";
            s << surface.indices.size() / 3 << " 0\n";
            for (std::size_t t = 0; t + 2 < surface.indices.size(); t += 3)
                s << "3 " << surface.indices[t] << " " << surface.indices[t + 1] << " " << surface.indices[t + 2] << "\n";
            s << "0\n0\n";
        }
        // -p: a piecewise linear complex (the surface); -q: radius-edge ratio bound; -a: volume bound;
        // -Q: quiet; -z: number from 0.
        char switches[96];
        if (max_volume > 0)
            std::snprintf(switches, sizeof switches, "-pzQq%ga%g", quality, max_volume);
        else
            std::snprintf(switches, sizeof switches, "-pzQq%g", quality);
        const int status = run_tetgen(switches, (dir / "in.smesh").string(), (dir / "tetgen.log").string());
        if (status == 127) throw MeshError("the tetgen program is not installed: run scripts/setup (Debian package tetgen)");
        if (status != 0) {
            std::ifstream log(dir / "tetgen.log");
            std::string text((std::istreambuf_iterator<char>(log)), std::istreambuf_iterator<char>());
            throw MeshError("tetgen failed on " + in + " (status " + std::to_string(status) + "): " + text);
        }
        TetMesh m = load_tetgen((dir / "in.1.node").string(), (dir / "in.1.ele").string());
        check_tet_mesh(m.nodes, m.tets, in + " (as TetGen meshed it)");
        save_tetgen(m, out + ".node", out + ".ele");
        double volume = 0, smallest = 1e300;
        for (std::size_t e = 0; e < m.tet_count(); ++e) {
            const std::uint32_t* t = &m.tets[4 * e];
            const double v = double(tet_volume(m.nodes[t[0]], m.nodes[t[1]], m.nodes[t[2]], m.nodes[t[3]]));
            volume += v;
            smallest = std::min(smallest, v);
        }
        std::printf("{\"surface\":\"%s\",\"out\":\"%s\",\"nodes\":%zu,\"tets\":%zu,\"volume\":%.6g,\"surface_volume\":%.6g,"
                    "\"min_tet_volume\":%.6g}\n",
                    in.c_str(), out.c_str(), m.nodes.size(), m.tet_count(), volume,
                    double(enclosed_volume(surface.indices, surface.vertices)), smallest);
        return kExitOk;
    } catch (const MeshError& e) {
        std::cerr << "sinew mesh: " << e.what() << std::endl;
    } catch (const SoftError& e) {
        std::cerr << "sinew mesh: " << e.what() << std::endl;
    } catch (const std::runtime_error& e) {
        std::cerr << "sinew mesh: " << e.what() << std::endl;
    }
    return kExitFailure;
}

}  // namespace

const Command mesh_command = {
    "mesh", mesh, "fill a closed OBJ surface with tetrahedra (TetGen) for FEM bodies",
    "usage: sinew mesh SURFACE.obj OUT [--max-volume V] [--quality Q] [--scale S]\n"
    "\n"
    "Meshes the solid inside a closed, counter-clockwise triangle surface with TetGen (the tetgen program,\n"
    "installed by scripts/setup) and writes OUT.node and OUT.ele, checked as Sinew loads them; a scene uses\n"
    "them with the soft builder \"tet-mesh\" (\"file\": \"OUT.node\"). Prints one JSON line: nodes, tets,\n"
    "volume (of the tets), surface_volume (enclosed by the OBJ), min_tet_volume.\n"
    "\n"
    "  --max-volume V  largest tet volume (m^3, after --scale); default: no bound\n"
    "  --quality Q     TetGen's radius-edge ratio bound, >= 1 (default 1.4)\n"
    "  --scale S       multiply the OBJ's coordinates by S first (default 1)\n"
    "\n"
    "Exit status: 0 ok, 1 a bad or open surface, a missing tetgen or a failed mesh, 2 bad arguments.\n"};

}  // namespace sinew::tool
