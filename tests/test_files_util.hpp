// File helpers shared by the tests that run programs (tests/test_sinew_tool.cpp, tests/test_c_api_example.cpp):
// read a whole file, and a scratch folder per process (CTest runs test cases as parallel processes)
// removed at exit.
#pragma once

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <system_error>

namespace test_files {

namespace fs = std::filesystem;

inline std::string slurp(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

/// A folder named PREFIX-PID under the temporary directory, created on construction, removed on destruction.
struct ScratchDir {
    fs::path dir;
    explicit ScratchDir(const std::string& prefix)
        : dir(fs::temp_directory_path() / (prefix + "-" + std::to_string(::getpid()))) {
        fs::create_directories(dir);
    }
    ~ScratchDir() {
        std::error_code ec;
        fs::remove_all(dir, ec);
    }
    ScratchDir(const ScratchDir&) = delete;
    ScratchDir& operator=(const ScratchDir&) = delete;
};

}  // namespace test_files
