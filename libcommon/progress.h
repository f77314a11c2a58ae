// Progress reporting on stderr. On a terminal: one line redrawn in place with a bar, percentage,
// elapsed time and ETA. Otherwise (logs, CI): one line when a phase starts and one when it ends.
// Thread-safe: advance() may be called from any worker; redraws are rate-limited.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <mutex>
#include <string>

namespace iris {

class Progress {
public:
    // `label` names the phase (e.g. "render"), `total` is in arbitrary work units.
    Progress(std::string label, uint64_t total, bool quiet);
    ~Progress();
    void advance(uint64_t units);
    // Changes the total (time-budgeted renders learn it as they go).
    void set_total(uint64_t total);
    void finish(const std::string& summary = "");
    double elapsed_seconds() const;

private:
    void draw(bool final);
    std::string label_;
    std::atomic<uint64_t> done_{0};
    std::atomic<uint64_t> total_;
    bool quiet_, tty_, finished_ = false;
    std::chrono::steady_clock::time_point start_, last_draw_;
    std::mutex mutex_;
};

// Seconds as "1h02m", "3m05s" or "4.2s".
std::string format_duration(double seconds);

}  // namespace iris
