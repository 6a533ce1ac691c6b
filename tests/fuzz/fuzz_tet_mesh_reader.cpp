// libFuzzer target for the tet mesh readers (built only with -DMAT_BUILD_FUZZERS=ON and clang).
// The first byte picks the format: even = Medit .mesh text; odd = TetGen, the rest split at the
// first '@' into the .node and the .ele text. Every input must either throw mat::Error or give
// a valid, positively oriented mesh; anything else is a finding.

#include <cstdint>
#include <string_view>

#include "common/error.hpp"
#include "common/tet_geometry.hpp"
#include "formats/tet_mesh_io.hpp"
#include "tests/fuzz/fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    mat::fuzz::quiet_logger();
    const auto check = [](bool condition, const char* what) {
        mat::fuzz::check(condition, "fuzz_tet_mesh_reader", what);
    };
    if (size == 0)
        return 0;
    const std::string_view text(reinterpret_cast<const char*>(data) + 1, size - 1);
    mat::TetMesh mesh;
    try {
        if (data[0] % 2 == 0) {
            mesh = mat::read_medit_from_string(text, "fuzz.mesh");
        } else {
            const std::size_t at = text.find('@');
            const std::string_view node = text.substr(0, at);
            const std::string_view ele
                = at == std::string_view::npos ? std::string_view() : text.substr(at + 1);
            mesh = mat::read_tetgen_from_strings(node, "fuzz.node", ele, "fuzz.ele");
        }
    } catch (const mat::Error&) {
        return 0;
    }
    check(mesh.positions.allFinite(), "finite positions");
    check(mesh.num_tets() == 0
            || (mesh.tets.minCoeff() >= 0 && mesh.tets.maxCoeff() < mesh.num_vertices()),
        "tet indices in range");
    for (mat::Index t = 0; t < mesh.num_tets(); ++t) {
        check(!(mat::tet_orientation(mesh, t) < 0.0), "positive orientation");
    }
    return 0;
}
