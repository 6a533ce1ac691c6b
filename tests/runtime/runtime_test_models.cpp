#include "tests/runtime/runtime_test_models.hpp"

#include <vector>

#include "preprocess/bake/bake_pipeline.hpp"
#include "preprocess/pd/pd_operators.hpp"

namespace mat::test {

BakeData make_grid_bake(const GridTetOptions& options)
{
    BakeData bake;
    bake.tet_mesh = make_grid_tets(options);
    const Index n = bake.tet_mesh.num_vertices();
    const TetRestData rest = compute_tet_rest_data(bake.tet_mesh.positions, bake.tet_mesh.tets);
    bake.dm_inverse = rest.dm_inverse;
    bake.rest_volumes = rest.volumes;
    bake.lumped_mass = lumped_masses(n, bake.tet_mesh.tets, rest.volumes);
    bake.laplacian = assemble_laplacian(n, bake.tet_mesh.tets, rest);
    return bake;
}

BakeData make_identity_bake(const GridTetOptions& options)
{
    BakeData bake = make_grid_bake(options);
    const Index n = bake.tet_mesh.num_vertices();
    SparseRowMatrix identity(n, n);
    identity.setIdentity();
    bake.basis = identity;
    bake.reduced_laplacian = MatX(bake.laplacian);
    bake.reduced_mass = MatX(bake.lumped_mass.asDiagonal());
    return bake;
}

BakeData bake_cube(const std::string& medial_path, const std::string& quadratic)
{
    const std::string data_dir = std::string(MAT_TEST_DATA_DIR) + "/bake/";
    BakeOptions options;
    options.surface = data_dir + "cube.obj";
    options.medial = medial_path.empty() ? data_dir + "cube.ma" : medial_path;
    options.tet_size = 0.15;
    // The solver tests on the cube were set up on its mesh without sliver perturbation (their
    // cases, e.g. one where Anderson's safeguard must refuse an iterate, depend on the mesh).
    options.perturb_slivers = false;
    options.quadratic = quadratic;
    BakeReport report;
    return run_bake(options, report);
}

const BakeData& shipped_cube_bake()
{
    static const BakeData bake = bake_cube();
    return bake;
}

} // namespace mat::test
