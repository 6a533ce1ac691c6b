#include "tests/runtime/simulation_test_bake.hpp"

#include "formats/bake_io.hpp"
#include "preprocess/bake/bake_pipeline.hpp"

namespace mat::test {

std::string write_capsule_bake(const std::string& path)
{
    static const BakeData bake = [] {
        BakeOptions options;
        options.surface = std::string(MAT_SAMPLES_DIR) + "/capsule/capsule.obj";
        options.medial = std::string(MAT_SAMPLES_DIR) + "/capsule/capsule.ma";
        options.tet_size = 0.1;
        BakeReport report;
        return run_bake(options, report);
    }();
    write_bake(path, bake);
    return path;
}

} // namespace mat::test
