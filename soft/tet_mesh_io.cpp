// Loaders for tetrahedral meshes written by the meshers users have: TetGen's .node/.ele pair (the
// `tetgen` program, Debian package tetgen) and gmsh's .msh (ASCII 2.2 and 4.1). Formats: TetGen 1.5
// manual §5.2.1-5.2.3; gmsh reference manual §10.1 (MSH file format). Only what a solid needs is read:
// node coordinates and 4-node tetrahedra. Errors name the file and line.
#include <cmath>
#include <cstdint>
#include <algorithm>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <unordered_map>

#include "soft/soft_body.hpp"
#include "soft/tet_mesh.hpp"

namespace sinew {

namespace {

// Reads a text file line by line, skipping blank lines and (TetGen) comments after '#'.
class LineReader {
public:
    LineReader(const std::string& path, bool hash_comments) : path_(path), comments_(hash_comments), in_(path) {
        if (!in_) throw SoftError(path + ": cannot open the file");
    }
    // The next non-empty line as a stream; fails at the end of the file with `expected` named.
    std::istringstream next(const char* expected) {
        std::string line;
        while (std::getline(in_, line)) {
            ++number_;
            if (comments_) {
                const std::size_t hash = line.find('#');
                if (hash != std::string::npos) line.erase(hash);
            }
            if (line.find_first_not_of(" \t\r") != std::string::npos) {
                last_ = line;
                return std::istringstream(line);
            }
        }
        fail(std::string("the file ends where ") + expected + " was expected");
    }
    bool at_end() {
        in_ >> std::ws;
        return in_.eof();
    }
    [[noreturn]] void fail(const std::string& what) const {
        throw SoftError(path_ + ":" + std::to_string(number_) + ": " + what);
    }
    template <class T>
    T read(std::istringstream& s, const char* what) const {
        T v{};
        if (!(s >> v)) fail(std::string("expected ") + what + " in \"" + last_ + "\"");
        return v;
    }
    Vec3 read_point(std::istringstream& s) const {
        const double x = read<double>(s, "x"), y = read<double>(s, "y"), z = read<double>(s, "z");
        if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z)) fail("a coordinate is not finite in \"" + last_ + "\"");
        return Vec3(Real(x), Real(y), Real(z));
    }

private:
    std::string path_;
    bool comments_;
    std::ifstream in_;
    std::string last_;
    int number_ = 0;
};

constexpr long long kMaxCount = 50'000'000;

// Keeps the nodes the tets use, in file order (meshers may leave points no tet uses, e.g. a duplicate
// input point, and files carry geometry points of other elements).
void drop_unused_nodes(TetMesh& m) {
    std::vector<std::int64_t> remap(m.nodes.size(), -1);
    for (const std::uint32_t t : m.tets) remap[t] = 0;
    std::size_t kept = 0;
    for (std::size_t i = 0; i < m.nodes.size(); ++i)
        if (remap[i] == 0) {
            remap[i] = std::int64_t(kept);
            m.nodes[kept++] = m.nodes[i];
        }
    m.nodes.resize(kept);
    for (std::uint32_t& t : m.tets) t = std::uint32_t(remap[t]);
}

long long read_count(LineReader& r, std::istringstream& s, const char* what) {
    const long long n = r.read<long long>(s, what);
    if (n < 0 || n > kMaxCount) r.fail(std::string(what) + " = " + std::to_string(n) + " is out of range [0, 5e7]");
    return n;
}

}  // namespace

TetMesh load_tetgen(const std::string& node_path, const std::string& ele_path) {
    TetMesh m;
    long long first_index = 0;
    {
        LineReader r(node_path, true);
        std::istringstream head = r.next("the header (<# of points> <dimension> <# of attributes> <markers>)");
        const long long n = read_count(r, head, "the number of points");
        const int dim = r.read<int>(head, "the dimension");
        if (dim != 3) r.fail("dimension " + std::to_string(dim) + " (a tet mesh is 3)");
        m.nodes.reserve(std::size_t(std::min<long long>(n, 1 << 20)));  // a header may lie: grow past it
        for (long long i = 0; i < n; ++i) {
            std::istringstream s = r.next("a point");
            const long long index = r.read<long long>(s, "the point's index");
            if (i == 0) {
                if (index != 0 && index != 1) r.fail("the first point's index is " + std::to_string(index) + " (0 or 1 expected)");
                first_index = index;
            } else if (index != first_index + i) {
                r.fail("point index " + std::to_string(index) + " where " + std::to_string(first_index + i) + " was expected");
            }
            m.nodes.push_back(r.read_point(s));
        }
    }
    LineReader r(ele_path, true);
    std::istringstream head = r.next("the header (<# of tetrahedra> <nodes per tet> <# of attributes>)");
    const long long t = read_count(r, head, "the number of tetrahedra");
    const int per = r.read<int>(head, "the nodes per tetrahedron");
    if (per != 4 && per != 10) r.fail("nodes per tetrahedron = " + std::to_string(per) + " (4 or 10 expected)");
    m.tets.reserve(std::size_t(4 * std::min<long long>(t, 1 << 20)));
    for (long long e = 0; e < t; ++e) {
        std::istringstream s = r.next("a tetrahedron");
        r.read<long long>(s, "the tetrahedron's index");
        for (int c = 0; c < 4; ++c) {
            const long long i = r.read<long long>(s, "a node index") - first_index;
            if (i < 0 || i >= static_cast<long long>(m.nodes.size()))
                r.fail("node " + std::to_string(i + first_index) + " is not in " + node_path + " (" + std::to_string(m.nodes.size()) +
                       " points from index " + std::to_string(first_index) + ")");
            m.tets.push_back(std::uint32_t(i));
        }
    }
    drop_unused_nodes(m);
    orient_tets(m.nodes, m.tets);
    return m;
}

void save_tetgen(const TetMesh& mesh, const std::string& node_path, const std::string& ele_path) {
    // Both files opened before either is written: a failure leaves no half pair behind.
    std::ofstream node(node_path), ele(ele_path);
    if (!node) throw SoftError(node_path + ": cannot write the file");
    if (!ele) throw SoftError(ele_path + ": cannot write the file");
    node << "# written by Sinew: <points> <dimension> <attributes> <boundary markers>\n" << mesh.nodes.size() << " 3 0 0\n";
    node.precision(std::numeric_limits<Real>::max_digits10);  // round-trips exactly
    for (std::size_t i = 0; i < mesh.nodes.size(); ++i)
        node << i << " " << mesh.nodes[i].x() << " " << mesh.nodes[i].y() << " " << mesh.nodes[i].z() << "\n";
    // Quadratic tets are written with their 10 nodes (corners first); load_tetgen reads their corners back.
    const std::size_t per = std::size_t(tet_nodes(mesh.order));
    ele << "# written by Sinew: <tetrahedra> <nodes per tet> <attributes>; (b-a).((c-a)x(d-a)) > 0\n"
        << mesh.tet_count() << " " << per << " 0\n";
    for (std::size_t e = 0; e < mesh.tet_count(); ++e) {
        ele << e;
        for (std::size_t k = 0; k < per; ++k) ele << " " << mesh.tets[per * e + k];
        ele << "\n";
    }
    if (!node.flush() || !ele.flush()) throw SoftError(node_path + ": writing failed");
}

TetMesh load_gmsh(const std::string& path) {
    LineReader r(path, false);
    std::istringstream s = r.next("$MeshFormat");
    if (r.read<std::string>(s, "$MeshFormat") != "$MeshFormat") r.fail("a .msh file starts with $MeshFormat");
    s = r.next("the format line");
    const std::string version = r.read<std::string>(s, "the version");
    const int binary = r.read<int>(s, "the file type");
    if (binary != 0) r.fail("binary .msh files are not read: save as ASCII (gmsh -format msh41 or msh22 with Mesh.Binary=0)");
    // 2.x files share 2.2's layout; 4.0's node blocks differ from 4.1's and are not read.
    const bool v4 = version == "4.1";
    if (!v4 && version.rfind("2", 0) != 0) r.fail("format version " + version + " (2.2 or 4.1 expected; gmsh -format msh41 writes 4.1)");
    s = r.next("$EndMeshFormat");
    if (r.read<std::string>(s, "$EndMeshFormat") != "$EndMeshFormat") r.fail("expected $EndMeshFormat");

    std::unordered_map<long long, std::uint32_t> node_of_tag;
    std::vector<Vec3> all_nodes;
    std::vector<long long> tet_tags;  // 4 node tags per tet
    for (;;) {
        if (r.at_end()) break;
        s = r.next("a section");
        const std::string section = r.read<std::string>(s, "a section name");
        if (section == "$Nodes") {
            s = r.next("the node count");
            if (v4) {
                const long long blocks = read_count(r, s, "numEntityBlocks");
                for (long long b = 0; b < blocks; ++b) {
                    s = r.next("a node block header");
                    r.read<int>(s, "entityDim");
                    r.read<int>(s, "entityTag");
                    const int parametric = r.read<int>(s, "parametric");
                    if (parametric != 0) r.fail("parametric node coordinates are not read");
                    const long long count = read_count(r, s, "numNodesInBlock");
                    std::vector<long long> tags;
                    tags.reserve(static_cast<std::size_t>(std::min<long long>(count, 1 << 20)));
                    for (long long k = 0; k < count; ++k) {
                        s = r.next("a node tag");
                        tags.push_back(r.read<long long>(s, "a node tag"));
                    }
                    for (const long long tag : tags) {
                        s = r.next("node coordinates");
                        if (!node_of_tag.emplace(tag, std::uint32_t(all_nodes.size())).second)
                            r.fail("node tag " + std::to_string(tag) + " is defined twice");
                        all_nodes.push_back(r.read_point(s));
                    }
                }
            } else {
                const long long count = read_count(r, s, "the number of nodes");
                for (long long i = 0; i < count; ++i) {
                    s = r.next("a node");
                    const long long tag = r.read<long long>(s, "a node tag");
                    if (!node_of_tag.emplace(tag, std::uint32_t(all_nodes.size())).second)
                        r.fail("node tag " + std::to_string(tag) + " is defined twice");
                    all_nodes.push_back(r.read_point(s));
                }
            }
        } else if (section == "$Elements") {
            s = r.next("the element count");
            if (v4) {
                const long long blocks = read_count(r, s, "numEntityBlocks");
                for (long long b = 0; b < blocks; ++b) {
                    s = r.next("an element block header");
                    r.read<int>(s, "entityDim");
                    r.read<int>(s, "entityTag");
                    const int type = r.read<int>(s, "elementType");
                    const long long count = read_count(r, s, "numElementsInBlock");
                    for (long long e = 0; e < count; ++e) {
                        s = r.next("an element");
                        if (type != 4) continue;  // 4: the 4-node tetrahedron
                        r.read<long long>(s, "an element tag");
                        for (int c = 0; c < 4; ++c) tet_tags.push_back(r.read<long long>(s, "a node tag"));
                    }
                }
            } else {
                const long long count = read_count(r, s, "the number of elements");
                for (long long e = 0; e < count; ++e) {
                    s = r.next("an element");
                    r.read<long long>(s, "an element tag");
                    const int type = r.read<int>(s, "the element type");
                    if (type != 4) continue;
                    const int ntags = r.read<int>(s, "the number of tags");
                    for (int k = 0; k < ntags; ++k) r.read<long long>(s, "a tag");
                    for (int c = 0; c < 4; ++c) tet_tags.push_back(r.read<long long>(s, "a node tag"));
                }
            }
        }
        // Skip to the section's end (or ignore an unknown section whole).
        const std::string end = "$End" + section.substr(1);
        if (section != "$Nodes" && section != "$Elements") {
            for (;;) {
                s = r.next(end.c_str());
                std::string word;
                s >> word;
                if (word == end) break;
            }
        } else {
            s = r.next(end.c_str());
            std::string word;
            s >> word;
            if (word != end) r.fail("expected " + end + ", got \"" + word + "\"");
        }
    }
    if (tet_tags.empty()) throw SoftError(path + ": the file has no 4-node tetrahedra (element type 4)");
    TetMesh m;
    m.nodes = std::move(all_nodes);
    m.tets.reserve(tet_tags.size());
    for (std::size_t k = 0; k < tet_tags.size(); ++k) {
        const auto it = node_of_tag.find(tet_tags[k]);
        if (it == node_of_tag.end())
            throw SoftError(path + ": tetrahedron " + std::to_string(k / 4) + " refers to node tag " + std::to_string(tet_tags[k]) +
                            ", which $Nodes does not define");
        m.tets.push_back(it->second);
    }
    drop_unused_nodes(m);
    orient_tets(m.nodes, m.tets);
    return m;
}

}  // namespace sinew
