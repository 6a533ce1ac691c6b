// libFuzzer target for the checkpoint reader (mat-run --resume), structure-aware: the input is
// a recipe (tests/fuzz/h5_recipe.hpp) that builds a valid HDF5 file; the seeds are recipes of
// real checkpoints (docs/building.md, Fuzzing). The run identity is taken from the file itself,
// so that mutations reach the bodies rather than stop at the identity check (which the
// checkpoint tests cover). Restoring into a simulation, which checks the bodies against the
// bakes, is not part of this target.

#include <cstdint>
#include <string>

#include "common/error.hpp"
#include "formats/hdf5_file.hpp"
#include "runtime/output/checkpoint.hpp"
#include "tests/fuzz/fuzz_support.hpp"
#include "tests/fuzz/h5_recipe.hpp"

namespace {

// The identity the file claims, or empty strings where it has none.
mat::RunIdentity claimed_identity(const std::string& path)
{
    mat::RunIdentity identity;
    const mat::H5Reader in(path);
    const auto text = [&](const char* name) {
        try {
            return in.read_string_attribute("/", name);
        } catch (const mat::Error&) {
            return std::string();
        }
    };
    identity.scene_hash = text("scene_hash");
    identity.bake_hashes = text("bake_hashes");
    identity.solver = text("solver");
    return identity;
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    mat::fuzz::quiet_logger();
    const std::string path = mat::fuzz::scratch_folder() + "/checkpoint.h5";
    if (!mat::fuzz::build_h5_from_recipe(data, size, path))
        return 0;
    mat::Checkpoint checkpoint;
    try {
        checkpoint = mat::read_checkpoint(path, claimed_identity(path));
    } catch (const mat::Error&) {
        return 0;
    }
    const auto check = [](bool condition, const char* what) {
        mat::fuzz::check(condition, "fuzz_checkpoint_structured", what);
    };
    check(checkpoint.frame >= 0 && checkpoint.snapshot.steps >= 0, "frame and steps >= 0");
    for (const mat::BodySnapshot& body : checkpoint.snapshot.bodies) {
        check(body.velocities.rows() == body.positions.rows(), "a velocity per position");
        check(body.contact.forces.rows() == mat::Index(body.contact.used.size()),
            "a contact force per contact");
    }
    return 0;
}
