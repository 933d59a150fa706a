// JSON reading for the scene loader: a SAX-built DOM that knows pointers, and the Node cursor.
#include "engine/world/scene_json.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdlib>

namespace sinew::scene_json {

std::string pointer_token(const std::string& key) {
    std::string out;
    for (char c : key) {
        if (c == '~') out += "~0";
        else if (c == '/') out += "~1";
        else out += c;
    }
    return out;
}

namespace {

// ---- JSON text -> DOM, with pointers -------------------------------------------------------------

/// nlohmann SAX handler building an ordered_json DOM while tracking the JSON pointer of the value being
/// read. It refuses duplicate keys (which nlohmann's own parser would silently overwrite).
class DomBuilder {
public:
    DomBuilder(Json& root, const std::string& text) : root_(root), text_(text) {}

    bool null() { return put(Json(nullptr)); }
    bool boolean(bool b) { return put(Json(b)); }
    bool number_integer(Json::number_integer_t v) { return put(Json(v)); }
    bool number_unsigned(Json::number_unsigned_t v) { return put(Json(v)); }
    bool number_float(Json::number_float_t v, const Json::string_t&) { return put(Json(v)); }
    bool string(Json::string_t& s) { return put(Json(std::move(s))); }
    bool binary(Json::binary_t&) { return put(Json()); }  // never produced by text JSON
    bool start_object(std::size_t) { return open(Json::object()); }
    bool start_array(std::size_t) { return open(Json::array()); }
    bool end_object() { return close(); }
    bool end_array() { return close(); }
    bool key(Json::string_t& k) {
        Frame& f = frames_.back();
        if (f.node->contains(k)) {
            error_path_ = pointer(frames_.size() - 1) + "/" + pointer_token(k);
            error_ = "duplicate key \"" + k + "\"";
            return false;
        }
        f.key = k;
        return true;
    }
    bool parse_error(std::size_t position, const std::string& last_token, const Json::exception& ex) {
        std::string what = ex.what();
        const std::size_t bracket = what.find("] ");
        if (bracket != std::string::npos) what = what.substr(bracket + 2);
        if (ex.id == 406) {  // number overflow (1e999): the reader knows which value it was
            error_path_ = pointer(frames_.size());
            error_ = what + " (numbers must be finite and in range)";
            return false;
        }
        // "parse error at line 3, column 5: syntax error ..." -> keep what follows the position,
        // which we compute ourselves so the format does not depend on the nlohmann version.
        if (what.rfind("parse error", 0) == 0) {
            const std::size_t colon = what.find(": ");
            if (colon != std::string::npos) what = what.substr(colon + 2);
        }
        // nlohmann reports the position after the offending token; point at its first character instead.
        const std::size_t end = std::min(position - std::min(position, last_token.size()), text_.size());
        std::size_t line = 1, column = 1;
        for (std::size_t i = 0; i < end; ++i) {
            if (text_[i] == '\n') {
                ++line;
                column = 1;
            } else {
                ++column;
            }
        }
        error_path_.clear();
        error_ = "malformed JSON at line " + std::to_string(line) + ", column " + std::to_string(column) + ": " + what;
        return false;
    }

    const std::string& error() const { return error_; }
    const std::string& error_path() const { return error_path_; }

private:
    struct Frame {
        Json* node;
        std::string key;  // objects: key of the value being read
    };

    // Pointer through the first `depth` open containers. With depth = all, that is the pointer of the value
    // being read: for the innermost array its next element; outer arrays hold their open child last.
    std::string pointer(std::size_t depth) const {
        std::string p;
        for (std::size_t i = 0; i < depth; ++i) {
            const Frame& f = frames_[i];
            if (f.node->is_array()) {
                std::size_t index = f.node->size();
                if (i + 1 < frames_.size()) --index;
                p += "/" + std::to_string(index);
            } else {
                p += "/" + pointer_token(f.key);
            }
        }
        return p;
    }
    Json* put_get(Json&& v) {
        if (frames_.empty()) {
            root_ = std::move(v);
            return &root_;
        }
        Frame& f = frames_.back();
        if (f.node->is_array()) {
            f.node->push_back(std::move(v));
            return &f.node->back();
        }
        Json& slot = (*f.node)[f.key];
        slot = std::move(v);
        return &slot;
    }
    bool put(Json&& v) {
        put_get(std::move(v));
        return true;
    }
    bool open(Json&& v) {
        Json* node = put_get(std::move(v));
        frames_.push_back({node, {}});
        return true;
    }
    bool close() {
        frames_.pop_back();
        return true;
    }

    Json& root_;
    const std::string& text_;
    std::vector<Frame> frames_;
    std::string error_, error_path_;
};

// ---- wording of messages --------------------------------------------------------------------------

// Extra advice when a number was written as a string.
std::string quoted_number_hint(const Json& j) {
    if (!j.is_string()) return {};
    std::string s = j.get<std::string>();
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    if (!s.empty() && (s[0] == '-' || s[0] == '+')) s = s.substr(1);
    if (s == "nan" || s == "inf" || s == "infinity") return " (NaN and infinity are not allowed)";
    char* end = nullptr;
    const std::string& raw = j.get_ref<const std::string&>();
    std::strtod(raw.c_str(), &end);
    if (!raw.empty() && end && *end == '\0') return " (write numbers without quotes)";
    return {};
}

std::size_t edit_distance(const std::string& a, const std::string& b) {
    std::vector<std::size_t> row(b.size() + 1);
    for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
    for (std::size_t i = 1; i <= a.size(); ++i) {
        std::size_t diag = row[0];
        row[0] = i;
        for (std::size_t j = 1; j <= b.size(); ++j) {
            const std::size_t up = row[j];
            row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] == b[j - 1] ? 0 : 1)});
            diag = up;
        }
    }
    return row[b.size()];
}

}  // namespace

std::string describe(const Json& j) {
    switch (j.type()) {
        case Json::value_t::string: {
            std::string s = j.get<std::string>();
            if (s.size() > 40) s = s.substr(0, 40) + "...";
            return "the string \"" + s + "\"";
        }
        case Json::value_t::object: return "an object";
        case Json::value_t::array: return "an array of " + std::to_string(j.size());
        case Json::value_t::null: return "null";
        default: return j.dump();
    }
}

Json parse_json_text(const std::string& text, const std::string& file) {
    Json root;
    DomBuilder builder(root, text);
    if (!Json::sax_parse(text, &builder)) throw SceneError(file, builder.error_path(), builder.error());
    return root;
}

// ---- Node -----------------------------------------------------------------------------------------

void Node::type_error(const char* expected) const {
    fail(name_ + " must be " + expected + ", got " + describe(*j_) + quoted_number_hint(*j_));
}

void Node::expect_object() const {
    if (!j_->is_object()) type_error("an object");
}

void Node::allow_keys(std::initializer_list<const char*> allowed) const {
    expect_object();
    for (const auto& item : j_->items()) {
        const std::string& k = item.key();
        bool known = false;
        for (const char* a : allowed) known = known || k == a;
        if (known) continue;
        std::string hint;
        for (const char* a : allowed)
            if (hint.empty() && edit_distance(k, a) <= 2) hint = std::string(" (did you mean \"") + a + "\"?)";
        if (hint.empty()) hint = " (expected one of: " + one_of(allowed) + ")";
        Node(j_->at(k), path_ + "/" + pointer_token(k), k, *ctx_).fail("unknown key \"" + k + "\"" + hint);
    }
}

std::optional<Node> Node::find(const char* key) const {
    expect_object();
    auto it = j_->find(key);
    if (it == j_->end()) return std::nullopt;
    return Node(*it, path_ + "/" + pointer_token(key), key, *ctx_);
}

Node Node::get(const char* key) const {
    std::optional<Node> n = find(key);
    if (!n) ctx_->fail(path_ + "/" + pointer_token(key), std::string("missing required key \"") + key + "\"");
    return *n;
}

std::size_t Node::array_size() const {
    if (!j_->is_array()) type_error("an array");
    return j_->size();
}

Node Node::item(std::size_t i) const {
    return Node((*j_)[i], path_ + "/" + std::to_string(i), name_ + "[" + std::to_string(i) + "]", *ctx_);
}

double Node::number() const {
    if (!j_->is_number()) type_error("a number");
    const double v = j_->get<double>();
    if (!std::isfinite(v)) fail(name_ + " must be finite, got " + j_->dump());
    return v;
}

Real Node::real() const {
    const double v = number();
    // A finite double may still overflow a float Real (1e300): that would be an inf in the world.
    if (std::abs(v) > double(kRealMax))
        fail(name_ + " = " + j_->dump() + " is out of range for " + (sizeof(Real) == 4 ? "single" : "double") +
             " precision");
    return Real(v);
}

long long Node::integer() const {
    if (j_->is_number_integer()) {
        if (j_->is_number_unsigned() && j_->get<std::uint64_t>() > std::uint64_t(INT64_MAX))
            fail(name_ + " = " + j_->dump() + " is too large");
        return j_->get<long long>();
    }
    if (j_->is_number_float()) {
        const double v = j_->get<double>();
        // Writers that only have doubles emit 3.0 for 3; accept integral values.
        if (std::isfinite(v) && v == std::floor(v) && std::abs(v) < 9e15) return static_cast<long long>(v);
    }
    type_error("an integer");
}

bool Node::boolean() const {
    if (!j_->is_boolean()) type_error("true or false");
    return j_->get<bool>();
}

const std::string& Node::string() const {
    if (!j_->is_string()) type_error("a string");
    return j_->get_ref<const std::string&>();
}

Vec3 Node::vec3() const {
    if (!j_->is_array() || j_->size() != 3) type_error("[x, y, z] (an array of 3 numbers)");
    return Vec3(item(0).real(), item(1).real(), item(2).real());
}

// ---- value checks ---------------------------------------------------------------------------------

Real checked(const Node& n, Range range) {
    const Real v = n.real();
    const std::string got = ", got " + n.json().dump();
    switch (range) {
        case Range::Any: break;
        case Range::Positive:
            if (!(v > 0)) n.fail(n.name() + " must be > 0" + got);
            break;
        case Range::NonNegative:
            if (!(v >= 0)) n.fail(n.name() + " must be >= 0" + got);
            break;
        case Range::UnitInterval:
            if (!(v >= 0 && v <= 1)) n.fail(n.name() + " must be in [0, 1]" + got);
            break;
    }
    return v;
}

Real read_real(const Node& obj, const char* key, Real fallback, Range range) {
    std::optional<Node> n = obj.find(key);
    return n ? checked(*n, range) : fallback;
}

int checked_int(const Node& n, long long lo, long long hi) {
    const long long v = n.integer();
    if (v < lo) n.fail(n.name() + " must be >= " + std::to_string(lo) + ", got " + n.json().dump());
    if (v > hi) n.fail(n.name() + " must be <= " + std::to_string(hi) + ", got " + n.json().dump());
    return static_cast<int>(v);
}

int read_int(const Node& obj, const char* key, int fallback, long long lo, long long hi) {
    std::optional<Node> n = obj.find(key);
    return n ? checked_int(*n, lo, hi) : fallback;
}

bool read_bool(const Node& obj, const char* key, bool fallback) {
    std::optional<Node> n = obj.find(key);
    return n ? n->boolean() : fallback;
}

Vec3 read_vec3(const Node& obj, const char* key, const Vec3& fallback) {
    std::optional<Node> n = obj.find(key);
    return n ? n->vec3() : fallback;
}

CollisionFilter read_filter(const Node& obj) {
    CollisionFilter f;
    std::optional<Node> n = obj.find("filter");
    if (!n) return f;
    n->allow_keys({"category", "mask", "group"});
    const auto bits = [&](const char* key, std::uint32_t fallback) -> std::uint32_t {
        std::optional<Node> k = n->find(key);
        if (!k) return fallback;
        const long long v = k->integer();
        if (v < 0 || v > 0xFFFFFFFFll)
            k->fail(std::string(key) + " must be an integer in [0, 4294967295] (32 category bits), got " + k->json().dump());
        return std::uint32_t(v);
    };
    f.category = bits("category", f.category);
    f.mask = bits("mask", f.mask);
    if (std::optional<Node> g = n->find("group")) {
        const long long v = g->integer();
        if (v < -2147483648ll || v > 2147483647ll)
            g->fail("group must be an integer in [-2147483648, 2147483647], got " + g->json().dump());
        f.group = std::int32_t(v);
    }
    return f;
}

Json filter_json(const CollisionFilter& f) {
    if (f == CollisionFilter{}) return Json(nullptr);
    return Json{{"category", f.category}, {"mask", f.mask}, {"group", f.group}};
}

}  // namespace sinew::scene_json
