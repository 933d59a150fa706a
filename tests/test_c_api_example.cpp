// The plain-C example demos/c/scene_loop.c (built as strict C99 against libsinew.so) loads
// demos/scenes/showcase-c-loop.json, steps it with variable frame times through the accumulator and
// prints its final state; `sinew run` of the same file for the same number of fixed steps must end in
// the same state. Both run the same engine on the same scene, so the positions agree to the last bit of
// the float the C API returns (the record file stores floats too); the brief allows 1e-6 m.
#include <sys/wait.h>
#include <unistd.h>

#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "tests/test_files_util.hpp"

namespace fs = std::filesystem;

namespace {

const std::string kBin = SINEW_BIN_DIR;
const std::string kScene = std::string(SINEW_SOURCE_DIR) + "/demos/scenes/showcase-c-loop.json";

using test_files::slurp;

/// Runs a command with stdout to `out`; returns its exit status (-1 if it did not exit normally).
int run(const std::string& cmd, const fs::path& out) {
    const int w = std::system((cmd + " >'" + out.string() + "' 2>&1 </dev/null").c_str());
    return w != -1 && WIFEXITED(w) ? WEXITSTATUS(w) : -1;
}

}  // namespace

TEST_CASE("C example: the C game loop over a scene ends where `sinew run` of the same scene does", "[capi][example]") {
    REQUIRE(fs::exists(kBin + "/c_scene_loop"));
    REQUIRE(fs::exists(kBin + "/sinew"));
    test_files::ScratchDir scratch("sinew-c-example");
    const fs::path c_out = scratch.dir / "c.txt", record = scratch.dir / "run.jsonl", tool_out = scratch.dir / "tool.txt";
    REQUIRE(run("'" + kBin + "/c_scene_loop' '" + kScene + "' 150", c_out) == 0);

    // Parse the example's final block: "final steps N", "body i px py pz qw qx qy qz",
    // "particle s k x y z".
    std::istringstream in(slurp(c_out));
    long steps = -1;
    std::vector<std::vector<double>> bodies;
    std::vector<std::vector<double>> particles;  // soft body 0
    for (std::string line; std::getline(in, line);) {
        std::istringstream l(line);
        std::string word;
        l >> word;
        if (word == "final") {
            l >> word >> steps;
        } else if (word == "body") {
            int i;
            l >> i;
            std::vector<double> v(7);
            for (double& x : v) l >> x;
            REQUIRE(i == int(bodies.size()));
            bodies.push_back(v);
        } else if (word == "particle") {
            int s, k;
            l >> s >> k;
            std::vector<double> v(3);
            for (double& x : v) l >> x;
            REQUIRE(k == int(particles.size()));
            particles.push_back(v);
        }
    }
    // 150 frames of 1/60 s +- 4 ms through the accumulator: about 150 fixed steps.
    REQUIRE(steps >= 140);
    REQUIRE(steps <= 160);
    REQUIRE(bodies.size() == 4);
    REQUIRE(particles.size() == 256);

    REQUIRE(run("'" + kBin + "/sinew' run '" + kScene + "' --steps " + std::to_string(steps) + " --record '" +
                    record.string() + "'",
                tool_out) == 0);
    std::istringstream rec(slurp(record));
    std::string line, last;
    while (std::getline(rec, line))
        if (!line.empty()) last = line;
    const nlohmann::json frame = nlohmann::json::parse(last);
    REQUIRE(frame.at("frame").get<long>() == steps);

    // Both sides print floats exactly (%.9g, shortest round-trip): compare as floats.
    double worst = 0;
    int identical = 0, total = 0;
    auto compare = [&](double c_value, double tool_value) {
        const float a = float(c_value), b = float(tool_value);
        worst = std::max(worst, double(std::abs(a - b)));
        identical += a == b;
        ++total;
    };
    for (std::size_t i = 0; i < bodies.size(); ++i)
        for (std::size_t k = 0; k < 7; ++k) compare(bodies[i][k], frame.at("bodies").at(i).at(k).get<double>());
    const nlohmann::json& cloth = frame.at("particles").at(0);
    REQUIRE(cloth.size() == 3 * particles.size());
    for (std::size_t p = 0; p < particles.size(); ++p)
        for (std::size_t k = 0; k < 3; ++k) compare(particles[p][k], cloth.at(3 * p + k).get<double>());
    INFO("steps " << steps << ", " << identical << " of " << total << " values identical, worst difference " << worst);
    CHECK(worst <= 1e-6);
    CHECK(identical == total);
    // The scene did something: the cloth hangs over the top box, whose top face is at y = 3.
    double lowest = 1e9;
    for (const auto& p : particles) lowest = std::min(lowest, p[1]);
    CHECK(lowest < 3.0);
    CHECK(bodies[3][1] == Approx(2.5).margin(0.01));  // the top box of the stack stands
}
