// Internal to the scene loader; not part of the API and not included by any public header (it brings in
// nlohmann/json, which the library links privately).
//
// Reading JSON so that every problem can be named by its RFC 6901 pointer: parse_json_text() reads the
// text through nlohmann's SAX interface into a DOM while tracking the pointer of the value being read,
// and Node is a cursor over that DOM which knows its own pointer and throws SceneError with it.
#pragma once

#include <initializer_list>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "engine/world/scene.hpp"

namespace sinew::scene_json {

// Document order is kept so that the first error reported is the first one in the file.
using Json = nlohmann::ordered_json;

/// Parses JSON text; malformed text, duplicate keys and numbers that overflow a double throw SceneError
/// (with line and column, or with the pointer of the value).
Json parse_json_text(const std::string& text, const std::string& file);

/// A key escaped for use in a JSON pointer ("~" -> "~0", "/" -> "~1").
std::string pointer_token(const std::string& key);

struct Context {
    std::string file;
    std::string dir;  ///< directory of the scene file, for relative paths inside it
    [[noreturn]] void fail(const std::string& path, const std::string& problem) const {
        throw SceneError(file, path, problem);
    }
};

/// A value for messages: the string "nan", an array of 2, 1e300, ...
std::string describe(const Json& j);

/// "a, b, c"
template <class Names>
std::string one_of(const Names& names) {
    std::string s;
    for (const auto& n : names) s += (s.empty() ? "" : ", ") + std::string(n);
    return s;
}

/// A value in the document together with its pointer and a name for messages.
class Node {
public:
    Node(const Json& j, std::string path, std::string name, const Context& ctx)
        : j_(&j), path_(std::move(path)), name_(std::move(name)), ctx_(&ctx) {}

    const Json& json() const { return *j_; }
    const std::string& path() const { return path_; }
    const std::string& name() const { return name_; }  ///< the key, or "key[i]" for array items
    const Context& ctx() const { return *ctx_; }
    [[noreturn]] void fail(const std::string& problem) const { ctx_->fail(path_, problem); }
    /// "NAME must be EXPECTED, got VALUE" (with a hint for quoted numbers, "nan", ...).
    [[noreturn]] void type_error(const char* expected) const;

    // objects
    void expect_object() const;
    /// Every key must be one of `allowed`; the error names the first unknown key and a near miss.
    void allow_keys(std::initializer_list<const char*> allowed) const;
    std::optional<Node> find(const char* key) const;
    /// A required key: fails with "missing required key" at the key's pointer.
    Node get(const char* key) const;

    // arrays
    std::size_t array_size() const;
    Node item(std::size_t i) const;

    // scalars, type-checked
    double number() const;  ///< finite
    Real real() const;      ///< finite and within Real's range
    long long integer() const;
    bool boolean() const;
    const std::string& string() const;
    Vec3 vec3() const;

private:
    const Json* j_;
    std::string path_;
    std::string name_;
    const Context* ctx_;
};

// ---- value checks: read, check a range, report "NAME must be > 0, got -1" ---------------------------

enum class Range { Any, Positive, NonNegative, UnitInterval };

Real checked(const Node& n, Range range);
int checked_int(const Node& n, long long lo, long long hi);
// Optional keys: the fallback when absent.
Real read_real(const Node& obj, const char* key, Real fallback, Range range);
int read_int(const Node& obj, const char* key, int fallback, long long lo, long long hi = 1000000000);
bool read_bool(const Node& obj, const char* key, bool fallback);
Vec3 read_vec3(const Node& obj, const char* key, const Vec3& fallback);
/// The optional "filter" object of a body or soft body: {"category", "mask"} (integers in [0, 2^32 - 1])
/// and "group" (an integer in [-2^31, 2^31 - 1]), each optional (engine/core/collision_filter.hpp).
CollisionFilter read_filter(const Node& obj);
/// The same as JSON, or null when it is the default (saved scenes write it only when set).
Json filter_json(const CollisionFilter& f);

/// Maps the string at `key` to one of `choices` (name, value), or fails listing them.
template <class T, std::size_t N>
T read_enum(const Node& obj, const char* key, T fallback, const std::pair<const char*, T> (&choices)[N]) {
    std::optional<Node> n = obj.find(key);
    if (!n) return fallback;
    const std::string& s = n->string();
    for (const auto& c : choices)
        if (s == c.first) return c.second;
    std::vector<std::string> names;
    for (const auto& c : choices) names.emplace_back(c.first);
    n->fail("unknown " + n->name() + " \"" + s + "\" (expected one of: " + one_of(names) + ")");
}

/// An enum read by the names its layer gives it: name(T(i)) for i in [0, count), so a new value of the
/// enum needs no edit here.
template <class T, class NameFn>
T read_enum_named(const Node& obj, const char* key, T fallback, int count, NameFn name) {
    std::optional<Node> n = obj.find(key);
    if (!n) return fallback;
    const std::string& s = n->string();
    std::vector<std::string> names;
    for (int i = 0; i < count; ++i) {
        if (s == name(T(i))) return T(i);
        names.emplace_back(name(T(i)));
    }
    n->fail("unknown " + n->name() + " \"" + s + "\" (expected one of: " + one_of(names) + ")");
}

}  // namespace sinew::scene_json

namespace sinew::scene_json {

/// Reads the "soft_bodies" array into desc.soft_bodies (engine/world/scene_soft.cpp). Attachments name
/// bodies of desc.bodies, so it runs after the bodies and generators.
void parse_soft_bodies(const Node& array, SceneDesc& desc);
/// Reads the "coupling" object into desc.coupling (engine/world/scene_coupling.cpp); its pairs name soft
/// and rigid bodies, so it runs after both.
void parse_coupling(const Node& node, SceneDesc& desc);

}  // namespace sinew::scene_json
