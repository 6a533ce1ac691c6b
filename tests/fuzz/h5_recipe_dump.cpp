// Recipes (tests/fuzz/h5_recipe.hpp) from and to HDF5 files: the seeds of the structure-aware
// HDF5 fuzz targets come from real bakes and trajectories this way, and a recipe a fuzzer
// found can be turned back into the file it stands for (to read it with mat-bake inspect).
//   h5_recipe_dump IN.h5 OUT.recipe
//   h5_recipe_dump --build IN.recipe OUT.h5

#include <cstdio>
#include <fstream>
#include <iterator>
#include <string>

#include "common/error.hpp"
#include "tests/fuzz/h5_recipe.hpp"

int main(int argc, char** argv)
{
    const bool build = argc == 4 && std::string(argv[1]) == "--build";
    if (argc != 3 && !build) {
        std::fprintf(stderr, "usage: %s IN.h5 OUT.recipe | --build IN.recipe OUT.h5\n", argv[0]);
        return 2;
    }
    try {
        if (build) {
            std::ifstream in(argv[2], std::ios::binary);
            const std::vector<std::uint8_t> recipe(
                (std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
            if (!in.good() && !in.eof())
                mat::throw_error("{}: cannot read", argv[2]);
            if (!mat::fuzz::build_h5_from_recipe(recipe.data(), recipe.size(), argv[3]))
                mat::throw_error("{}: cannot write", argv[3]);
            return 0;
        }
        const std::vector<std::uint8_t> recipe = mat::fuzz::recipe_from_h5(argv[1]);
        std::ofstream out(argv[2], std::ios::binary);
        out.write(reinterpret_cast<const char*>(recipe.data()), std::streamsize(recipe.size()));
        if (!out.flush())
            mat::throw_error("{}: cannot write", argv[2]);
        std::printf("%s: %zu bytes\n", argv[2], recipe.size());
    } catch (const mat::Error& e) {
        std::fprintf(stderr, "%s\n", e.what());
        return 1;
    }
    return 0;
}
