// Subcommands of the `sinew` tool. Each lives in its own cmd_*.cpp and defines one Command; adding a
// subcommand means adding that file, declaring its Command here and listing it in sinew_main.cpp.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

namespace sinew::tool {

/// Bad command-line arguments: the dispatcher prints the message and the command's usage on stderr and
/// exits with status 2.
struct UsageError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

/// Exit statuses shared by all subcommands.
enum ExitStatus : int {
    kExitOk = 0,
    kExitFailure = 1,   ///< a bad scene file, an unwritable output, ...
    kExitUsage = 2,     ///< bad arguments
    kExitNonFinite = 3  ///< `run`: the simulation produced NaN or infinity
};

struct Command {
    const char* name;
    /// Runs with the arguments after the subcommand name; returns the exit status. May throw UsageError,
    /// SceneError (printed, status 1) or any std::exception (printed, status 1).
    int (*run)(const std::vector<std::string>& args);
    const char* summary;  ///< one line for `sinew --help`
    const char* usage;    ///< full help for `sinew CMD --help`, starting with the synopsis line
};

extern const Command run_command;
extern const Command validate_command;
extern const Command bench_command;  // tools/bench/bench_rigid.cpp
extern const Command mesh_command;
extern const Command compare_command;  // tools/cmd_compare.cpp

// ---- argument helpers ------------------------------------------------------------------------------

/// The value of option args[i] (given as "--opt VALUE" or "--opt=VALUE"); advances i past it.
std::string option_value(const std::vector<std::string>& args, std::size_t& i, const std::string& option);
/// True if args[i] is `option` or starts with "option=".
bool is_option(const std::string& arg, const std::string& option);
/// Parses an integer in [lo, hi] or throws UsageError naming the option.
long long parse_int(const std::string& option, const std::string& text, long long lo, long long hi);
/// Parses a finite number > 0 or throws UsageError naming the option.
double parse_positive(const std::string& option, const std::string& text);

}  // namespace sinew::tool
