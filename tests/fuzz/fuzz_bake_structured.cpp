// libFuzzer target for the bake reader, structure-aware: the input is a recipe
// (tests/fuzz/h5_recipe.hpp) that always builds a valid HDF5 file, so that the mutations reach
// our checks of the content rather than HDF5's parsing of the container (docs/building.md,
// Fuzzing). The seeds are the recipes of real bake files.

#include <cstdint>

#include "tests/fuzz/fuzz_support.hpp"
#include "tests/fuzz/h5_recipe.hpp"
#include "tests/fuzz/hdf5_checks.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    mat::fuzz::quiet_logger();
    const std::string path = mat::fuzz::scratch_folder() + "/bake.h5";
    if (mat::fuzz::build_h5_from_recipe(data, size, path))
        mat::fuzz::read_and_check_bake(path, "fuzz_bake_structured");
    return 0;
}
