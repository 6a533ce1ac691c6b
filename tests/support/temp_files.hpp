#pragma once
// Scratch files for tests: a fresh directory per test, removed afterwards, and whole-file reads.

#include <gtest/gtest.h>

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

namespace mat::test {

/// A gtest fixture giving each test its own empty directory
/// `<root>/mat_<suite>_<pid>_<test>` (the pid keeps concurrent runs of the same test apart; a
/// '/' of a parameterized name becomes '_'), removed with its content afterwards. Use it as the
/// fixture directly (`using MyTest = test::ScratchDirTest;`) or derive from it; a derived fixture
/// that overrides SetUp or TearDown must call these.
class ScratchDirTest : public ::testing::Test {
protected:
    explicit ScratchDirTest(std::filesystem::path root = std::filesystem::temp_directory_path());

    void SetUp() override;
    void TearDown() override;

    /// The directory of the current test.
    const std::filesystem::path& dir() const { return m_dir; }
    /// The path of `name` inside dir().
    std::string path(const std::string& name) const;
    /// Writes `text` as is (binary) to `name` inside dir(); returns its path.
    std::string write_text(const std::string& name, const std::string& text) const;
    /// Writes `bytes` to `name` inside dir(); returns its path.
    std::string write_bytes(const std::string& name, const std::vector<char>& bytes) const;
    /// How many entries dir() holds (e.g. to see that no temporary file was left behind).
    std::size_t num_entries() const;

private:
    std::filesystem::path m_root;
    std::filesystem::path m_dir;
};

/// The whole content of the file at `path`, byte for byte ("" if it cannot be opened).
std::string read_file_contents(const std::string& path);

} // namespace mat::test
