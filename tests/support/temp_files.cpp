#include "tests/support/temp_files.hpp"

#include <algorithm>
#include <fstream>
#include <iterator>
#include <utility>

#include <fmt/format.h>
#include <unistd.h>

namespace mat::test {

namespace fs = std::filesystem;

ScratchDirTest::ScratchDirTest(fs::path root)
    : m_root(std::move(root))
{
}

void ScratchDirTest::SetUp()
{
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    std::string name
        = fmt::format("mat_{}_{}_{}", info->test_suite_name(), ::getpid(), info->name());
    std::replace(name.begin(), name.end(), '/', '_');
    m_dir = m_root / name;
    fs::remove_all(m_dir);
    fs::create_directories(m_dir);
}

void ScratchDirTest::TearDown()
{
    fs::remove_all(m_dir);
}

std::string ScratchDirTest::path(const std::string& name) const
{
    return (m_dir / name).string();
}

std::string ScratchDirTest::write_text(const std::string& name, const std::string& text) const
{
    const std::string p = path(name);
    std::ofstream(p, std::ios::binary) << text;
    return p;
}

std::string ScratchDirTest::write_bytes(
    const std::string& name, const std::vector<char>& bytes) const
{
    const std::string p = path(name);
    std::ofstream(p, std::ios::binary)
        .write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    return p;
}

std::size_t ScratchDirTest::num_entries() const
{
    return static_cast<std::size_t>(
        std::distance(fs::directory_iterator(m_dir), fs::directory_iterator()));
}

std::string read_file_contents(const std::string& path)
{
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
}

} // namespace mat::test
