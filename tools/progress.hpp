// Progress of a long run on stderr (issue 12 item 4): steps done, rate and time left, redrawn in place
// at most five times a second, only when stderr is a terminal and CI is not set, so pipes, logs and CI
// stay as quiet as before.
#pragma once

#include <chrono>
#include <string>

namespace sinew::tool {

class Progress {
public:
    /// `label` names the work ("pyramid-40"), `total` the steps (or runs) it will take, `unit` what is counted.
    Progress(std::string label, long long total, std::string unit = "steps");
    ~Progress();
    Progress(const Progress&) = delete;
    Progress& operator=(const Progress&) = delete;

    /// `done` of `total` are finished; redraws the line if a fifth of a second has passed.
    void update(long long done);
    /// What is being done now ("two-way h/2"), shown after the label; redraws at once.
    void set_detail(std::string detail);
    /// Clears the line (also done by the destructor), so the next output starts on a clean line.
    void finish();

    /// Whether progress is drawn at all: stderr is a terminal and the environment has no CI=true.
    static bool enabled();

private:
    std::string label_, unit_, detail_;
    long long done_ = 0;
    long long total_;
    bool on_;
    bool drawn_ = false;
    std::chrono::steady_clock::time_point start_, last_;
};

}  // namespace sinew::tool
