#include "tests/support/sample_bake.hpp"

#include <map>
#include <memory>
#include <mutex>
#include <utility>

#include "preprocess/bake/bake_pipeline.hpp"

namespace mat::test {

const BakeData& sample_bake(const std::string& name, double tet_size)
{
    static std::mutex mutex;
    static std::map<std::pair<std::string, double>, std::unique_ptr<BakeData>> bakes;
    const std::lock_guard<std::mutex> lock(mutex);
    std::unique_ptr<BakeData>& bake = bakes[{ name, tet_size }];
    if (!bake) {
        BakeOptions options;
        options.surface = std::string(MAT_SAMPLES_DIR) + "/" + name + "/" + name + ".obj";
        options.medial = std::string(MAT_SAMPLES_DIR) + "/" + name + "/" + name + ".ma";
        options.tet_size = tet_size;
        BakeReport report;
        bake = std::make_unique<BakeData>(run_bake(options, report));
    }
    return *bake;
}

} // namespace mat::test
