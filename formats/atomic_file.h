// Writing a file so that it appears under its final name complete or not at all.
//
// Every output of every iris tool goes through this: the data are written to "<path>.tmp-<pid>" in the
// same directory, fsynced, and renamed over the final name (rename within one file system is atomic).
// A failure before commit() removes the temporary file; a process killed outright (SIGKILL, power loss)
// leaves only a temporary file, which the next writer of the same path removes once its owner is dead.
#pragma once

#include <string>

namespace iris {

class AtomicFile {
public:
    // Creates the temporary file (mode 0666 & ~umask). Throws std::runtime_error "PATH: reason" when the
    // directory is missing or not writable.
    explicit AtomicFile(std::string path);
    AtomicFile(const AtomicFile&) = delete;
    AtomicFile& operator=(const AtomicFile&) = delete;
    // Removes the temporary file unless commit() succeeded.
    ~AtomicFile();

    const std::string& path() const { return path_; }
    const std::string& temp_path() const { return tmp_; }
    // An open, writable descriptor of the temporary file (owned by this object; do not close it).
    int fd() const { return fd_; }

    // fsync, close, rename into place, fsync the directory. Throws std::runtime_error "PATH: reason"
    // (the temporary file is then removed by the destructor).
    void commit();

private:
    std::string path_, tmp_;
    int fd_ = -1;
    bool committed_ = false;
};

// Removes "<path>.tmp-<pid>" files left by writers of `path` that no longer run (killed mid-write).
// Returns how many were removed. Called by AtomicFile's constructor.
int remove_stale_temporaries(const std::string& path);

}  // namespace iris
