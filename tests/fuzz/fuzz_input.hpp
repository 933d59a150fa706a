// Fuzz targets (issue 18 item 6): each checks one input and returns what went wrong, or "" when the input
// was handled (accepted and stepped finite, or refused with a clear error). The libFuzzer executables
// (tests/fuzz/fuzz_main.cpp, SINEW_FUZZ=ON, clang) abort on a non-empty answer; test_fuzz_regressions
// replays the committed corpus and every input a fuzzer once broke in every build configuration.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

namespace sinew::fuzz {

/// The bytes as a scene file: parse, build, step. A parse or build may refuse (SceneError); any other
/// exception, a step that throws, or a state that turns non-finite without the step reporting a fault is
/// a finding.
std::string check_scene_input(const std::uint8_t* data, std::size_t size);

/// The bytes as a sequence of C API calls (fuzz_capi.cpp decodes them): any SINEW_ERROR_INTERNAL, a step
/// that reports SINEW_OK while a body or particle is non-finite, or a crash is a finding.
std::string check_capi_input(const std::uint8_t* data, std::size_t size);

}  // namespace sinew::fuzz
