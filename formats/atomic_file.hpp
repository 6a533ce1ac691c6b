#pragma once
// Atomic output: write to a temporary file beside the target, rename over the target on
// success. On failure (or if commit() is never reached) the temporary is removed, so a reader
// never sees a half-written file and an existing target is left untouched.

#include <string>

namespace mat {

class AtomicFile {
public:
    /// Prepares to write `target`; the data goes to temp_path() until commit().
    /// Throws mat::Error if the target's directory does not exist.
    explicit AtomicFile(std::string target);
    /// Removes the temporary file unless commit() succeeded.
    ~AtomicFile();
    AtomicFile(const AtomicFile&) = delete;
    AtomicFile& operator=(const AtomicFile&) = delete;

    /// Where to write: a unique path in the target's directory.
    const std::string& temp_path() const { return m_temp; }
    const std::string& target() const { return m_target; }

    /// Renames the temporary over the target. Throws mat::Error on failure.
    void commit();

private:
    std::string m_target;
    std::string m_temp;
    bool m_committed = false;
};

/// Removes the temporaries that AtomicFile writers of processes no longer running left in
/// `directory` (".NAME.PID.N.tmp", from a killed run); with `name` non-empty, only those of the
/// target NAME. A temporary of a running process (another writer) stays. Returns how many were
/// removed; a missing directory has none.
int remove_stale_temporaries(const std::string& directory, const std::string& name = "");

} // namespace mat
