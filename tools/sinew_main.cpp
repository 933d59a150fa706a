// `sinew`: the command-line tool. This file only dispatches; each subcommand is a Command defined in its
// own cmd_*.cpp (see commands.hpp).
#include <cstring>
#include <iostream>

#include "engine/api/sinew.h"
#include "engine/world/scene.hpp"
#include "tools/commands.hpp"

namespace {

using sinew::tool::Command;

// Listed in `sinew --help` in this order.
const Command* const kCommands[] = {
    &sinew::tool::run_command,
    &sinew::tool::validate_command,
    &sinew::tool::bench_command,
    &sinew::tool::mesh_command,
    &sinew::tool::compare_command,
};

const Command* find_command(const std::string& name) {
    for (const Command* c : kCommands)
        if (name == c->name) return c;
    return nullptr;
}

void print_usage(std::ostream& out) {
    out << "usage: sinew COMMAND [ARGS...]\n"
           "       sinew --help | --version\n"
           "       sinew COMMAND --help\n\ncommands:\n";
    for (const Command* c : kCommands) {
        out << "  " << c->name;
        for (std::size_t i = std::strlen(c->name); i < 10; ++i) out << ' ';
        out << c->summary << '\n';
    }
    out << "\nScene files are described in docs/scene-format.md.\n";
}

int dispatch(const Command& cmd, const std::vector<std::string>& args) {
    for (const std::string& a : args)
        if (a == "--help" || a == "-h") {
            std::cout << cmd.usage;
            return sinew::tool::kExitOk;
        }
    try {
        return cmd.run(args);
    } catch (const sinew::tool::UsageError& e) {
        std::cerr << "sinew " << cmd.name << ": " << e.what() << "\n\n" << cmd.usage;
        return sinew::tool::kExitUsage;
    } catch (const sinew::SceneError& e) {
        std::cerr << e.what() << '\n';
        return sinew::tool::kExitFailure;
    } catch (const std::exception& e) {
        std::cerr << "sinew " << cmd.name << ": error: " << e.what() << '\n';
        return sinew::tool::kExitFailure;
    }
}

}  // namespace

int main(int argc, char** argv) {
    std::vector<std::string> args(argv + 1, argv + argc);
    if (args.empty()) {
        print_usage(std::cerr);
        return sinew::tool::kExitUsage;
    }
    const std::string& first = args[0];
    if (first == "--help" || first == "-h" || first == "help") {
        if (args.size() > 1) {
            if (const Command* c = find_command(args[1])) {
                std::cout << c->usage;
                return sinew::tool::kExitOk;
            }
        }
        print_usage(std::cout);
        return sinew::tool::kExitOk;
    }
    if (first == "--version") {
        std::cout << "sinew " << sinew_version() << '\n';
        return sinew::tool::kExitOk;
    }
    const Command* cmd = find_command(first);
    if (!cmd) {
        std::cerr << "sinew: unknown command '" << first << "'\n\n";
        print_usage(std::cerr);
        return sinew::tool::kExitUsage;
    }
    return dispatch(*cmd, std::vector<std::string>(args.begin() + 1, args.end()));
}
