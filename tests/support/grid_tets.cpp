#include "tests/support/grid_tets.hpp"

#include <algorithm>
#include <array>
#include <random>
#include <utility>

#include "common/error.hpp"
#include "common/tet_geometry.hpp"

namespace mat::test {

int grid_node(const GridTetOptions& options, int i, int j, int k)
{
    return i + (options.nx + 1) * (j + (options.ny + 1) * k);
}

VecX signed_tet_volumes(const TetMesh& mesh)
{
    VecX volumes(mesh.num_tets());
    for (Index t = 0; t < mesh.num_tets(); ++t)
        volumes[t] = tet_orientation(mesh, t) / 6.0;
    return volumes;
}

TetMesh make_grid_tets(const GridTetOptions& options)
{
    MAT_CHECK(options.nx > 0 && options.ny > 0 && options.nz > 0, "grid needs >= 1 cell per axis");
    MAT_CHECK(options.jitter >= 0.0 && options.jitter <= 0.2, "jitter {} not in [0, 0.2]",
        options.jitter);
    const std::array<int, 3> cells { options.nx, options.ny, options.nz };
    const Vec3 size = options.max_corner - options.min_corner;
    const Vec3 cell = size.cwiseQuotient(Vec3(cells[0], cells[1], cells[2]));

    TetMesh mesh;
    mesh.positions.resize(Index(cells[0] + 1) * (cells[1] + 1) * (cells[2] + 1), 3);
    std::mt19937 rng(options.seed);
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    for (int k = 0; k <= cells[2]; ++k)
        for (int j = 0; j <= cells[1]; ++j)
            for (int i = 0; i <= cells[0]; ++i) {
                const std::array<int, 3> ijk { i, j, k };
                Vec3 x;
                for (int a = 0; a < 3; ++a)
                    x[a] = options.min_corner[a] + size[a] * double(ijk[a]) / cells[a];
                const bool interior
                    = i > 0 && j > 0 && k > 0 && i < cells[0] && j < cells[1] && k < cells[2];
                if (options.jitter > 0.0 && interior)
                    for (int a = 0; a < 3; ++a)
                        x[a] += options.jitter * cell[a] * unit(rng);
                mesh.positions.row(grid_node(options, i, j, k)) = x;
            }

    // Kuhn split: one tet per permutation (a, b, c) of the axes, walking from corner 0 to
    // corner 7 one axis at a time. Corner bit 0 = +x, bit 1 = +y, bit 2 = +z.
    const std::array<std::array<int, 3>, 6> permutations { { { 0, 1, 2 }, { 0, 2, 1 }, { 1, 0, 2 },
        { 1, 2, 0 }, { 2, 0, 1 }, { 2, 1, 0 } } };
    mesh.tets.resize(Index(6) * cells[0] * cells[1] * cells[2], 4);
    Index t = 0;
    for (int k = 0; k < cells[2]; ++k)
        for (int j = 0; j < cells[1]; ++j)
            for (int i = 0; i < cells[0]; ++i) {
                auto corner = [&](int bits) {
                    return grid_node(
                        options, i + (bits & 1), j + ((bits >> 1) & 1), k + ((bits >> 2) & 1));
                };
                for (const auto& p : permutations) {
                    const int b1 = 1 << p[0];
                    const int b2 = b1 | (1 << p[1]);
                    std::array<int, 4> tet { corner(0), corner(b1), corner(b2), corner(7) };
                    // Odd permutations give a negatively oriented tet: swap two vertices.
                    const bool odd = (p[0] == 0 && p[1] == 2) || (p[0] == 1 && p[1] == 0)
                        || (p[0] == 2 && p[1] == 1);
                    if (odd)
                        std::swap(tet[1], tet[2]);
                    for (int c = 0; c < 4; ++c)
                        mesh.tets(t, c) = tet[c];
                    ++t;
                }
            }

    const VecX volumes = signed_tet_volumes(mesh);
    for (Index e = 0; e < volumes.size(); ++e)
        MAT_CHECK(volumes[e] > 0.0, "grid tet {} has volume {} (jitter too large?)", e, volumes[e]);
    return mesh;
}

} // namespace mat::test
