#include "formats/atomic_file.h"

#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <thread>

namespace iris {

namespace fs = std::filesystem;

namespace {

[[noreturn]] void fail(const std::string& path, const std::string& reason) {
    throw std::runtime_error(path + ": " + reason);
}

std::string errno_text() { return std::strerror(errno); }

}  // namespace

int remove_stale_temporaries(const std::string& path) {
    const fs::path p(path);
    const fs::path dir = p.parent_path().empty() ? fs::path(".") : p.parent_path();
    const std::string prefix = p.filename().string() + ".tmp-";
    int removed = 0;
    std::error_code ec;
    for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
        const std::string name = it->path().filename().string();
        if (name.size() <= prefix.size() || name.compare(0, prefix.size(), prefix) != 0) continue;
        const std::string digits = name.substr(prefix.size());
        if (digits.find_first_not_of("0123456789") != std::string::npos || digits.size() > 9) continue;
        const pid_t pid = pid_t(std::stol(digits));
        // kill(pid, 0) probes without signalling: ESRCH = no such process, so nobody is writing it.
        // (A live process, ours included, keeps its file; EPERM means alive under another user.)
        if (pid == ::getpid() || ::kill(pid, 0) == 0 || errno != ESRCH) continue;
        std::error_code rm;
        if (fs::remove(it->path(), rm)) ++removed;
    }
    return removed;
}

AtomicFile::AtomicFile(std::string path) : path_(std::move(path)) {
    if (path_.empty()) fail("(empty path)", "no output file name given");
    remove_stale_temporaries(path_);
    tmp_ = path_ + ".tmp-" + std::to_string(::getpid());
    fd_ = ::open(tmp_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
    if (fd_ < 0) fail(path_, "cannot create temporary file '" + tmp_ + "': " + errno_text());
}

AtomicFile::~AtomicFile() {
    if (fd_ >= 0) ::close(fd_);
    if (!committed_) ::unlink(tmp_.c_str());
}

void AtomicFile::commit() {
    // Fault injection for the kill tests (tests/pipeline/test_kill.cpp): hold the complete but not yet
    // renamed file for IRIS_TEST_COMMIT_DELAY_MS milliseconds, so a test can kill the writer at the
    // moment that matters most without racing it.
    if (const char* ms = std::getenv("IRIS_TEST_COMMIT_DELAY_MS"))
        std::this_thread::sleep_for(std::chrono::milliseconds(std::atol(ms)));
    // fsync before rename: otherwise a crash right after the rename can leave an empty file under the
    // final name on some file systems (the rename reaches the disk before the data).
    if (::fsync(fd_) != 0) fail(path_, "fsync of '" + tmp_ + "' failed: " + errno_text());
    const int fd = fd_;
    fd_ = -1;
    if (::close(fd) != 0) fail(path_, "close of '" + tmp_ + "' failed: " + errno_text());
    if (std::rename(tmp_.c_str(), path_.c_str()) != 0)
        fail(path_, "cannot rename temporary file '" + tmp_ + "' into place: " + errno_text());
    committed_ = true;
    // The directory entry itself is durable only once the directory is synced; a failure here does
    // not undo the (already visible, complete) file, so it is not an error.
    const fs::path dir = fs::path(path_).parent_path().empty() ? fs::path(".") : fs::path(path_).parent_path();
    const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (dfd >= 0) {
        ::fsync(dfd);
        ::close(dfd);
    }
}

}  // namespace iris
