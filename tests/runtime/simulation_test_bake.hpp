#pragma once
// A coarse bake of the capsule sample for tests that run scenes (baked once per process).

#include <string>

namespace mat::test {

/// Writes the capsule sample, baked with tets 10% of its diagonal, to `path`; returns `path`.
std::string write_capsule_bake(const std::string& path);

} // namespace mat::test
