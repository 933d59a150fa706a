// tools/progress.hpp
#include "tools/progress.hpp"

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <unistd.h>

namespace sinew::tool {

bool Progress::enabled() {
    const char* ci = std::getenv("CI");
    if (ci && std::strcmp(ci, "true") == 0) return false;
    return isatty(fileno(stderr)) != 0;
}

Progress::Progress(std::string label, long long total, std::string unit)
    : label_(std::move(label)), unit_(std::move(unit)), total_(total), on_(enabled()),
      start_(std::chrono::steady_clock::now()), last_(start_) {}

Progress::~Progress() { finish(); }

void Progress::set_detail(std::string detail) {
    detail_ = std::move(detail);
    last_ = start_ - std::chrono::seconds(1);  // redraw now
    update(done_);
}

void Progress::update(long long done) {
    done_ = done;
    if (!on_) return;
    const auto now = std::chrono::steady_clock::now();
    if (now - last_ < std::chrono::milliseconds(200) && done < total_) return;
    last_ = now;
    const double elapsed = std::chrono::duration<double>(now - start_).count();
    const double rate = elapsed > 0 ? double(done) / elapsed : 0;
    const std::string what = detail_.empty() ? label_ : label_ + ": " + detail_;
    char line[320];
    if (rate > 0 && total_ > 0 && done > 0) {
        const double left = double(total_ - done) / rate;
        std::snprintf(line, sizeof line, "\r\033[K%s: %lld/%lld %s (%.0f%%), %.*f %s/s, %.0f s left", what.c_str(), done,
                      total_, unit_.c_str(), 100.0 * double(done) / double(total_), rate >= 100 ? 0 : rate >= 10 ? 1 : 2,
                      rate, unit_.c_str(), left);
    } else {
        std::snprintf(line, sizeof line, "\r\033[K%s: %lld/%lld %s", what.c_str(), done, total_, unit_.c_str());
    }
    std::fputs(line, stderr);
    std::fflush(stderr);
    drawn_ = true;
}

void Progress::finish() {
    if (!drawn_) return;
    std::fputs("\r\033[K", stderr);  // erase the line: the tool's own output follows on a clean one
    std::fflush(stderr);
    drawn_ = false;
}

}  // namespace sinew::tool
