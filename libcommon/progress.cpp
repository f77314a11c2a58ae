#include "libcommon/progress.h"

#include <unistd.h>

#include <cstdio>

namespace iris {

std::string format_duration(double s) {
    char buf[64];
    if (s < 60) std::snprintf(buf, sizeof buf, "%.1fs", s);
    else if (s < 3600) std::snprintf(buf, sizeof buf, "%dm%02ds", int(s) / 60, int(s) % 60);
    else std::snprintf(buf, sizeof buf, "%dh%02dm", int(s) / 3600, (int(s) / 60) % 60);
    return buf;
}

Progress::Progress(std::string label, uint64_t total, bool quiet)
    : label_(std::move(label)), total_(total), quiet_(quiet), tty_(isatty(STDERR_FILENO) != 0) {
    start_ = last_draw_ = std::chrono::steady_clock::now();
    if (!quiet_ && !tty_) std::fprintf(stderr, "%s: started\n", label_.c_str());
}

Progress::~Progress() {
    if (!finished_) finish();
}

double Progress::elapsed_seconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

void Progress::set_total(uint64_t total) { total_ = total; }

void Progress::advance(uint64_t units) {
    done_ += units;
    if (quiet_ || !tty_) return;
    auto now = std::chrono::steady_clock::now();
    if (std::chrono::duration<double>(now - last_draw_).count() < 0.2) return;
    std::unique_lock<std::mutex> lock(mutex_, std::try_to_lock);
    if (!lock.owns_lock()) return;
    last_draw_ = now;
    draw(false);
}

void Progress::draw(bool final) {
    uint64_t total = total_.load(), done = done_.load();
    double frac = total ? std::min(1.0, double(done) / double(total)) : 1.0;
    double el = elapsed_seconds();
    const int width = 30;
    int filled = int(frac * width);
    std::string bar(filled, '#');
    bar.resize(width, '.');
    std::string eta = (frac > 0 && !final) ? ", ETA " + format_duration(el * (1 - frac) / frac) : "";
    std::fprintf(stderr, "\r%s [%s] %5.1f%% %s%s   ", label_.c_str(), bar.c_str(), 100 * frac,
                 format_duration(el).c_str(), eta.c_str());
    std::fflush(stderr);
}

void Progress::finish(const std::string& summary) {
    if (finished_) return;
    finished_ = true;
    if (quiet_) return;
    if (tty_) {
        draw(true);
        std::fprintf(stderr, "\n");
    }
    std::fprintf(stderr, "%s: done in %s%s%s\n", label_.c_str(), format_duration(elapsed_seconds()).c_str(),
                 summary.empty() ? "" : ", ", summary.c_str());
}

}  // namespace iris
