// Small, strict argument parsing shared by the subcommands: a typo in a number is a usage error, never a
// silent zero.
#include <cerrno>
#include <cmath>
#include <cstdlib>

#include "tools/commands.hpp"

namespace sinew::tool {

bool is_option(const std::string& arg, const std::string& option) {
    return arg == option || arg.rfind(option + "=", 0) == 0;
}

std::string option_value(const std::vector<std::string>& args, std::size_t& i, const std::string& option) {
    const std::string& arg = args[i];
    if (arg.size() > option.size() && arg[option.size()] == '=') return arg.substr(option.size() + 1);
    if (i + 1 >= args.size()) throw UsageError(option + " needs a value");
    return args[++i];
}

long long parse_int(const std::string& option, const std::string& text, long long lo, long long hi) {
    errno = 0;
    char* end = nullptr;
    const long long v = std::strtoll(text.c_str(), &end, 10);
    if (text.empty() || *end != '\0' || errno == ERANGE)
        throw UsageError(option + " expects an integer, got '" + text + "'");
    if (v < lo || v > hi)
        throw UsageError(option + " must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got " + text);
    return v;
}

double parse_positive(const std::string& option, const std::string& text) {
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    if (text.empty() || *end != '\0' || !std::isfinite(v) || !(v > 0))
        throw UsageError(option + " expects a finite number > 0, got '" + text + "'");
    return v;
}

}  // namespace sinew::tool
