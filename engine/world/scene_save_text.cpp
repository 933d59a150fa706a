// Saved scenes as text: a JSON layout that stays readable for large bodies (one particle, link or body
// per line), with every number printed so that the loader reads back exactly the Real it came from.
//
// Exactness: the loader reads a number with strtod (nlohmann's lexer) and then narrows it to Real, so a
// value is written as the shortest decimal whose strtod result narrows to the same bits. For double
// that is the shortest round-trip decimal (at most 17 digits); for float usually the shortest float
// decimal (at most 9 digits), checked because decimal -> double -> float rounds twice. Printing uses
// std::to_chars, which does not depend on the C locale.
#include <charconv>
#include <cmath>
#include <cstring>
#include <string>

#include "engine/world/scene_json.hpp"

namespace sinew::scene_save {

using scene_json::Json;

namespace {

bool same_bits(Real a, Real b) { return std::memcmp(&a, &b, sizeof(Real)) == 0; }

/// What the loader makes of `text`: strtod's correctly rounded double (from_chars rounds the same way),
/// narrowed to Real.
bool reads_back_as(const char* first, const char* last, Real v) {
    double d = 0;
    const auto [end, ec] = std::from_chars(first, last, d);
    return ec == std::errc() && end == last && same_bits(static_cast<Real>(d), v);
}

// Lines are wrapped near this many columns where a value can be split; an item of a list of vectors or
// objects (a particle, a link) stays on one line up to kItemWidth.
constexpr std::size_t kWidth = 110;
constexpr std::size_t kItemWidth = 200;

}  // namespace

std::string real_text(Real v) {
    if (v == 0) return std::signbit(v) ? "-0.0" : "0";  // "-0" would be read as the integer 0
    char buf[64];
    // The shortest decimal of the Real itself first; more digits of the double if that does not survive
    // the loader's two roundings.
    auto r = std::to_chars(buf, buf + sizeof(buf), v);
    if (reads_back_as(buf, r.ptr, v)) return std::string(buf, r.ptr);
    for (int digits = 1; digits <= 17; ++digits) {
        r = std::to_chars(buf, buf + sizeof(buf), static_cast<double>(v), std::chars_format::general, digits);
        if (reads_back_as(buf, r.ptr, v)) return std::string(buf, r.ptr);
    }
    r = std::to_chars(buf, buf + sizeof(buf), static_cast<double>(v));  // exact for any double
    return std::string(buf, r.ptr);
}

namespace {

/// One-line form of `j`, appended to `out`; false (out then holds a partial text) once out grows past
/// `limit`, so that large values are not rendered only to be thrown away.
bool compact(const Json& j, std::string& out, std::size_t limit) {
    switch (j.type()) {
        case Json::value_t::number_float: out += real_text(static_cast<Real>(j.get<double>())); break;
        case Json::value_t::array: {
            out += '[';
            bool first = true;
            for (const Json& e : j) {
                if (!first) out += ", ";
                first = false;
                if (!compact(e, out, limit)) return false;
            }
            out += ']';
            break;
        }
        case Json::value_t::object: {
            out += '{';
            bool first = true;
            for (const auto& item : j.items()) {
                if (!first) out += ", ";
                first = false;
                out += Json(item.key()).dump();
                out += ": ";
                if (!compact(item.value(), out, limit)) return false;
            }
            out += '}';
            break;
        }
        default: out += j.dump(); break;  // strings (escaped), integers, booleans, null
    }
    return out.size() <= limit;
}

bool is_scalar(const Json& j) { return !j.is_array() && !j.is_object(); }

/// Writes `j` whose first character goes at column `column`, its lines indented by `indent`, on one line
/// if it fits in `width` columns.
void pretty(const Json& j, std::size_t indent, std::size_t column, std::size_t width, std::string& out) {
    if (is_scalar(j)) {
        compact(j, out, std::string::npos);
        return;
    }
    std::string one_line;
    if (compact(j, one_line, width > column ? width - column : 0)) {
        out += one_line;
        return;
    }
    const std::string pad(indent + 2, ' ');
    if (j.is_object()) {
        out += "{\n";
        bool first = true;
        for (const auto& item : j.items()) {
            if (!first) out += ",\n";
            first = false;
            const std::string key = Json(item.key()).dump() + ": ";
            out += pad + key;
            pretty(item.value(), indent + 2, indent + 2 + key.size(), kWidth, out);
        }
        out += "\n" + std::string(indent, ' ') + "}";
        return;
    }
    bool scalars = true;
    for (const Json& e : j) scalars = scalars && is_scalar(e);
    out += "[\n" + pad;
    if (scalars) {  // numbers (masses, pins): as many to a line as fit
        std::size_t col = pad.size();
        bool first = true;
        for (const Json& e : j) {
            std::string s;
            compact(e, s, std::string::npos);
            if (!first) {
                out += ',';
                if (col + 2 + s.size() > kWidth) {
                    out += "\n" + pad;
                    col = pad.size();
                } else {
                    out += ' ';
                    col += 2;
                }
            }
            first = false;
            out += s;
            col += s.size();
        }
    } else {  // vectors, links, bodies: one to a line
        bool first = true;
        for (const Json& e : j) {
            if (!first) out += ",\n" + pad;
            first = false;
            pretty(e, indent + 2, indent + 2, kItemWidth, out);
        }
    }
    out += "\n" + std::string(indent, ' ') + "]";
}

/// A scene file holds finite numbers only (the loader rejects others): a NaN in a diverged world is an
/// error at its pointer rather than a file that cannot be read back.
void check_finite(const Json& j, const std::string& pointer, const std::string& origin) {
    if (j.is_number_float() && !std::isfinite(j.get<double>()))
        throw SceneError(origin, pointer,
                         "the world holds a value that is not finite (" + j.dump() +
                             "), so it cannot be saved: its state has diverged");
    if (j.is_array())
        for (std::size_t i = 0; i < j.size(); ++i) check_finite(j[i], pointer + "/" + std::to_string(i), origin);
    if (j.is_object())
        for (const auto& item : j.items())
            check_finite(item.value(), pointer + "/" + scene_json::pointer_token(item.key()), origin);
}

}  // namespace

std::string json_text(const Json& doc, const std::string& origin) {
    check_finite(doc, "", origin);
    std::string out;
    pretty(doc, 0, 0, kWidth, out);
    out += '\n';
    return out;
}

}  // namespace sinew::scene_save
