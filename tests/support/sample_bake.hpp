#pragma once
// Bakes of the committed samples for tests, made once per (sample, tet size) and kept: the bake
// of samples/NAME/NAME.obj with samples/NAME/NAME.ma. Compile tests/support/sample_bake.cpp into
// the test executable (it needs MAT_SAMPLES_DIR, which mat_add_test defines, and
// mat_preprocess).

#include <string>

#include "common/bake_data.hpp"

namespace mat::test {

/// The bake of sample `name` at tet size `tet_size` (fraction of the diagonal, as --tet-size).
const BakeData& sample_bake(const std::string& name, double tet_size);

} // namespace mat::test
