// Issue 18 item 6: the fuzz targets' seed corpus and every input a fuzzer once broke (tests/fuzz/found),
// replayed through the same checks the fuzzers run, in every build configuration (the fuzzers themselves
// need clang: scripts/dev fuzz). A finding names the file and what went wrong.
#include <catch2/catch.hpp>

#include <algorithm>
#include <filesystem>
#include <vector>

#include "tests/fuzz/fuzz_input.hpp"
#include "tests/test_files_util.hpp"

namespace fs = std::filesystem;

namespace {

std::vector<fs::path> inputs_of(const std::string& target) {
    std::vector<fs::path> files;
    for (const char* kind : {"corpus", "found"}) {
        const fs::path dir = fs::path(SINEW_SOURCE_DIR) / "tests" / "fuzz" / kind / target;
        if (!fs::exists(dir)) continue;
        for (const auto& e : fs::directory_iterator(dir))
            if (e.is_regular_file()) files.push_back(e.path());
    }
    std::sort(files.begin(), files.end());
    return files;
}

template <class Check>
void replay(const std::string& target, Check check, std::size_t at_least) {
    const std::vector<fs::path> files = inputs_of(target);
    REQUIRE(files.size() >= at_least);
    for (const fs::path& f : files) {
        const std::string bytes = test_files::slurp(f);
        const std::string finding = check(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
        INFO(f.string());
        CHECK(finding == "");
    }
}

}  // namespace

TEST_CASE("Fuzz regressions: every scene input a fuzzer found, and the seed corpus, is refused or steps finite", "[fuzz]") {
    replay("scene", sinew::fuzz::check_scene_input, 10);
}

TEST_CASE("Fuzz regressions: every C API call sequence a fuzzer found, and the seed corpus, is handled", "[fuzz]") {
    replay("capi", sinew::fuzz::check_capi_input, 10);
}
