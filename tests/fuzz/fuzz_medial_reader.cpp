// libFuzzer target for the .ma reader (built only with -DMAT_BUILD_FUZZERS=ON and clang).
// Every input must either throw mat::Error or give a valid mesh that writes and reads back
// unchanged; anything else (a crash, a sanitizer report, another exception) is a finding.

#include <cmath>
#include <cstdint>
#include <string_view>

#include "common/error.hpp"
#include "formats/medial_io.hpp"
#include "tests/fuzz/fuzz_support.hpp"

namespace {

bool same(const mat::MedialMesh& a, const mat::MedialMesh& b)
{
    return a.centers == b.centers && a.radii == b.radii && a.cones == b.cones && a.slabs == b.slabs;
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    mat::fuzz::quiet_logger();
    const auto check = [](bool condition, const char* what) {
        mat::fuzz::check(condition, "fuzz_medial_reader", what);
    };
    const std::string_view text(reinterpret_cast<const char*>(data), size);
    mat::MedialMesh mesh;
    try {
        mesh = mat::read_medial_from_string(text, "fuzz.ma");
    } catch (const mat::Error&) {
        return 0;
    }
    check(mesh.radii.size() == mesh.num_spheres(), "one radius per sphere");
    check(mesh.centers.allFinite() && mesh.radii.allFinite(), "finite values");
    check(mesh.num_spheres() == 0 || mesh.radii.minCoeff() > 0.0, "radii > 0");
    check(mesh.num_cones() == 0
            || (mesh.cones.minCoeff() >= 0 && mesh.cones.maxCoeff() < mesh.num_spheres()),
        "cone indices in range");
    check(mesh.num_slabs() == 0
            || (mesh.slabs.minCoeff() >= 0 && mesh.slabs.maxCoeff() < mesh.num_spheres()),
        "slab indices in range");
    // The paper's dialect stores cones and slabs as they are: the round trip is exact.
    const mat::MedialMesh paper = mat::read_medial_from_string(
        mat::format_medial(mesh, mat::MedialDialect::paper), "paper.ma");
    check(same(paper, mesh), "paper round trip");
    // Q-MAT keeps spheres and slabs exactly (cones on slab edges merge into the slabs).
    const mat::MedialMesh qmat = mat::read_medial_from_string(
        mat::format_medial(mesh, mat::MedialDialect::qmat), "qmat.ma");
    check(qmat.centers == mesh.centers && qmat.radii == mesh.radii && qmat.slabs == mesh.slabs,
        "Q-MAT round trip");
    check(qmat.num_cones() <= mesh.num_cones(), "Q-MAT round trip cones");
    return 0;
}
