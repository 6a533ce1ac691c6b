// libFuzzer target for the bake reader on raw bytes: the input is the file itself (the seeds
// are real bake files), written to a scratch path and read as the tools read it. This mostly
// exercises HDF5's own parsing of a damaged container, which Debian's libhdf5 does without
// instrumentation (docs/building.md, Fuzzing).

#include <cstdint>

#include "tests/fuzz/fuzz_support.hpp"
#include "tests/fuzz/hdf5_checks.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    mat::fuzz::quiet_logger();
    const std::string path = mat::fuzz::write_scratch("bake.h5", mat::fuzz::as_text(data, size));
    mat::fuzz::read_and_check_bake(path, "fuzz_bake_raw");
    return 0;
}
