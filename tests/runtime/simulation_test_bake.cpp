#include "tests/runtime/simulation_test_bake.hpp"

#include "formats/bake_io.hpp"
#include "tests/support/sample_bake.hpp"

namespace mat::test {

std::string write_capsule_bake(const std::string& path)
{
    const BakeData& bake = sample_bake("capsule", 0.1);
    write_bake(path, bake);
    return path;
}

} // namespace mat::test
