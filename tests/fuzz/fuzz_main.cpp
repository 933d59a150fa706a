// libFuzzer entry point of one target (SINEW_FUZZ_TARGET names the check): a finding is printed and
// aborts, so libFuzzer keeps the input as a crash file.
#include <cstdio>
#include <cstdlib>

#include "tests/fuzz/fuzz_input.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string finding = sinew::fuzz::SINEW_FUZZ_TARGET(data, size);
    if (!finding.empty()) {
        std::fprintf(stderr, "sinew fuzz finding: %s\n", finding.c_str());
        std::abort();
    }
    return 0;
}
