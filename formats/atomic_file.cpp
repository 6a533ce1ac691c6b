#include "formats/atomic_file.hpp"

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
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

} // namespace mat
