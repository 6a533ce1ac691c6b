#include "formats/atomic_file.hpp"

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <signal.h>
#include <unistd.h>

#include "common/error.hpp"

namespace mat {

namespace fs = std::filesystem;

AtomicFile::AtomicFile(std::string target)
    : m_target(std::move(target))
{
    static std::atomic<unsigned> counter { 0 };
    const fs::path path(m_target);
    const fs::path dir = path.has_parent_path() ? path.parent_path() : fs::path(".");
    std::error_code ec;
    if (!fs::is_directory(dir, ec))
        throw_error("{}: cannot write: directory '{}' does not exist", m_target, dir.string());
    if (fs::is_directory(path, ec))
        throw_error("{}: cannot write: it is a directory", m_target);
    m_temp = (dir
        / fmt::format(".{}.{}.{}.tmp", path.filename().string(), getpid(), counter.fetch_add(1)))
                 .string();
}

AtomicFile::~AtomicFile()
{
    if (!m_committed)
        std::remove(m_temp.c_str());
}

void AtomicFile::commit()
{
    if (std::rename(m_temp.c_str(), m_target.c_str()) != 0)
        throw_error(
            "{}: cannot write: rename from temporary failed: {}", m_target, std::strerror(errno));
    m_committed = true;
}

namespace {
    /// The writer's process id in ".NAME.PID.N.tmp" (NAME matching `name` unless empty), or -1.
    long temporary_owner(const std::string& file, const std::string& name)
    {
        const std::string suffix = ".tmp";
        if (file.size() < 8 || file[0] != '.'
            || file.compare(file.size() - suffix.size(), suffix.size(), suffix) != 0)
            return -1;
        const std::string body = file.substr(1, file.size() - 1 - suffix.size()); // NAME.PID.N
        const std::size_t counter_dot = body.rfind('.');
        if (counter_dot == std::string::npos || counter_dot == 0)
            return -1;
        const std::size_t pid_dot = body.rfind('.', counter_dot - 1);
        if (pid_dot == std::string::npos || pid_dot == 0)
            return -1;
        const std::string pid = body.substr(pid_dot + 1, counter_dot - pid_dot - 1);
        const std::string counter = body.substr(counter_dot + 1);
        const auto digits = [](const std::string& text) {
            return !text.empty() && text.size() < 12
                && text.find_first_not_of("0123456789") == std::string::npos;
        };
        if (!digits(pid) || !digits(counter) || (!name.empty() && body.substr(0, pid_dot) != name))
            return -1;
        return std::stol(pid);
    }
} // namespace

int remove_stale_temporaries(const std::string& directory, const std::string& name)
{
    std::error_code ec;
    int removed = 0;
    for (fs::directory_iterator it(directory, ec), end; !ec && it != end; it.increment(ec)) {
        const long pid = temporary_owner(it->path().filename().string(), name);
        if (pid < 0)
            continue;
        // A running process (this one included) may be writing it.
        const bool running = pid == long(getpid()) || kill(pid_t(pid), 0) == 0 || errno == EPERM;
        std::error_code remove_error;
        if (!running && fs::remove(it->path(), remove_error))
            ++removed;
    }
    return removed;
}

} // namespace mat
