#include "preprocess/bake/bake_pipeline.hpp"

#include <random>
#include <sstream>

#include <nlohmann/json.hpp>

#include "common/error.hpp"
#include "common/log.hpp"
#include "common/progress.hpp"
#include "formats/bake_io.hpp"
#include "formats/medial_io.hpp"
#include "formats/surface_io.hpp"
#include "preprocess/bake/bake_inputs.hpp"
#include "preprocess/basis/handle_basis.hpp"
#include "preprocess/collision/bound_data.hpp"
#include "preprocess/embedding/tet_embedding.hpp"
#include "preprocess/medial/medial_fit.hpp"
#include "preprocess/meshing/cgal_mesh3.hpp"
#include "preprocess/meshing/tet_quality.hpp"
#include "preprocess/pd/pd_operators.hpp"
#include "preprocess/pd/reduced_operators.hpp"
#include "preprocess/weights/handle_regions.hpp"
#include "preprocess/weights/harmonic_weights.hpp"

namespace mat {

Eigen::Matrix<bool, Eigen::Dynamic, 1> parse_quadratic(const std::string& text, Index num_handles)
{
    Eigen::Matrix<bool, Eigen::Dynamic, 1> flags
        = Eigen::Matrix<bool, Eigen::Dynamic, 1>::Constant(num_handles, text == "all");
    if (text == "all" || text == "none")
        return flags;
    std::stringstream stream(text);
    std::string item;
    while (std::getline(stream, item, ',')) {
        std::size_t used = 0;
        long value = -1;
        try {
            value = std::stol(item, &used);
        } catch (const std::exception&) {
            used = 0;
        }
        if (used != item.size() || item.empty())
            throw_error("--quadratic: '{}' is not a handle index (expected all, none or a list "
                        "like 0,4,7)",
                item);
        if (value < 0 || value >= num_handles)
            throw_error("--quadratic: handle {} does not exist (the medial mesh has {} spheres)",
                value, num_handles);
        flags(value) = true;
    }
    return flags;
}

namespace {

    // A stage: a progress line on a terminal (and every 15 s in logs), a log line, and a row of
    // the report.
    template <typename Body> void stage(BakeReport& report, const char* name, Body&& body)
    {
        Timer timer;
        const ProgressHeartbeat heartbeat(name);
        ProgressBar bar(name, 1);
        body();
        bar.advance();
        bar.finish();
        report.stages.add(name, timer.seconds());
        logger().debug("{}: {:.3f} s", name, timer.seconds());
    }

    // Largest relative error of B reproducing random affine fields at every node.
    double linear_precision_error(const HandleBasis& basis, const Eigen::Ref<const MatX3>& nodes)
    {
        std::mt19937 rng(12345);
        std::uniform_real_distribution<double> uniform(-1.0, 1.0);
        double worst = 0.0;
        for (int trial = 0; trial < 3; ++trial) {
            Mat3 a;
            Vec3 t;
            for (int i = 0; i < 3; ++i) {
                t(i) = uniform(rng);
                for (int j = 0; j < 3; ++j)
                    a(i, j) = uniform(rng);
            }
            const MatX3 q = affine_coefficients(basis, a, t);
            const MatX3 u = basis.basis * q;
            const MatX3 expected = (nodes * a.transpose()).rowwise() + t.transpose();
            worst = std::max(worst,
                (u - expected).cwiseAbs().maxCoeff()
                    / std::max(1e-300, expected.cwiseAbs().maxCoeff()));
        }
        return worst;
    }

    // Largest relative error of B reproducing a random quadratic field, over the nodes whose every
    // weighted handle is quadratic (-1 if there is none). Expanding x = c_j + s_j y, handle j's
    // coefficients of u_d(x) = x^T H_d x + (A x)_d + t_d are: constant c^T H_d c + (A c)_d + t_d,
    // linear s (2 H_d c + A_d), and s^2 times (H_d,11, H_d,22, H_d,33, 2 H_d,12, 2 H_d,23, 2
    // H_d,13).
    double quadratic_precision_error(const HandleBasis& basis, const SparseRowMatrix& weights,
        const Eigen::Ref<const MatX3>& nodes)
    {
        std::mt19937 rng(777);
        std::uniform_real_distribution<double> uniform(-1.0, 1.0);
        std::array<Mat3, 3> h;
        for (Mat3& m : h) {
            for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j)
                    m(i, j) = uniform(rng);
            m = (0.5 * (m + m.transpose())).eval();
        }
        const Mat3 a = 0.3 * Mat3::Identity();
        const Vec3 t(0.1, -0.2, 0.3);
        MatX3 q = MatX3::Zero(basis.num_columns(), 3);
        for (Index j = 0; j < basis.num_handles(); ++j) {
            const Vec3 c = basis.centers.row(j).transpose();
            const double sj = basis.scales(j);
            const Index o = basis.handle_offset(j);
            for (int d = 0; d < 3; ++d) {
                const Mat3& hd = h[static_cast<size_t>(d)];
                q(o, d) = c.dot(hd * c) + a.row(d).dot(c) + t(d);
                const Vec3 linear = sj * (2.0 * hd * c + a.row(d).transpose());
                for (int i = 0; i < 3; ++i)
                    q(o + 1 + i, d) = linear(i);
                if (basis.quadratic(j)) {
                    const double s2 = sj * sj;
                    q(o + 4, d) = s2 * hd(0, 0);
                    q(o + 5, d) = s2 * hd(1, 1);
                    q(o + 6, d) = s2 * hd(2, 2);
                    q(o + 7, d) = 2 * s2 * hd(0, 1);
                    q(o + 8, d) = 2 * s2 * hd(1, 2);
                    q(o + 9, d) = 2 * s2 * hd(0, 2);
                }
            }
        }
        const MatX3 u = basis.basis * q;
        double worst = 0.0, scale = 1e-300;
        bool any = false;
        for (Index i = 0; i < weights.rows(); ++i) {
            bool all = true;
            for (SparseRowMatrix::InnerIterator it(weights, i); it; ++it)
                all = all && basis.quadratic(it.col());
            if (!all)
                continue;
            any = true;
            const Vec3 x = nodes.row(i).transpose();
            Vec3 expected;
            for (int d = 0; d < 3; ++d)
                expected(d) = x.dot(h[static_cast<size_t>(d)] * x) + a.row(d).dot(x) + t(d);
            worst = std::max(worst, (u.row(i).transpose() - expected).cwiseAbs().maxCoeff());
            scale = std::max(scale, expected.cwiseAbs().maxCoeff());
        }
        return any ? worst / scale : -1.0;
    }

    /// Units per metre where that is a whole number (dividing by it rounds once), else 0.
    double units_per_metre(const std::string& unit)
    {
        if (unit == "mm")
            return 1000.0;
        if (unit == "cm")
            return 100.0;
        if (unit == "m")
            return 1.0;
        return 0.0;
    }

    template <typename Matrix> void scale_lengths(Matrix& lengths, const std::string& unit)
    {
        const double per_metre = units_per_metre(unit);
        if (per_metre > 0.0)
            lengths /= per_metre;
        else
            lengths *= unit_scale(unit);
    }

    // Rejects option values no bake can use, before any work.
    void check_options(const BakeOptions& options)
    {
        unit_scale(options.unit);
        if (!(options.tet_size > 0 && options.tet_size < 1))
            throw_error("--tet-size must be in (0, 1) (a fraction of the bbox diagonal), got {}",
                options.tet_size);
        if (options.max_tet_vertices < 1)
            throw_error("--max-tet-vertices must be >= 1, got {}", options.max_tet_vertices);
        if (options.weights_per_node < 1)
            throw_error("--weights-per-node must be >= 1, got {}", options.weights_per_node);
        if (options.spheres > 0 && !options.medial.empty())
            throw_error("--spheres and --medial exclude each other: generate the medial mesh or "
                        "read it, not both");
    }

    // Step 1: reads and checks the surface, and the medial mesh unless it is to be generated,
    // with the checks of `mat-bake check` (bake_inputs.hpp), then moves them to metres.
    void read_inputs(
        const BakeOptions& options, BakeData& bake, BakeReport& report, MedialMesh& input_medial)
    {
        stage(report, "read inputs", [&] {
            CheckedSurface checked = inspect_surface(options.surface);
            require_bake_surface(checked, options.surface, options.checks);
            if (!report.medial_generated) {
                input_medial = read_medial(options.medial);
                require_bake_medial(input_medial, options.medial, checked.surface, options.surface);
                scale_to_metres(input_medial, options.unit);
                bake.medial_hash = hash_file(options.medial);
            }
            bake.surface = std::move(checked.surface);
            scale_to_metres(bake.surface, options.unit);
            bake.surface_hash = hash_file(options.surface);
            const MatX3& x = bake.surface.positions;
            report.bbox_diagonal = (x.colwise().maxCoeff() - x.colwise().minCoeff()).norm();
        });
    }

    // Generates the medial mesh of the surface (or takes `generated`, already made from it).
    void generate_medial(const BakeOptions& options, const MedialMesh* generated, BakeData& bake,
        BakeReport& report, MedialMesh& input_medial)
    {
        stage(report, "generate medial", [&] {
            MedialGeneratorOptions generator = options.generator;
            generator.spheres = options.spheres;
            generator.surface_name = options.surface;
            input_medial = generated
                ? *generated
                : generate_medial_mesh(bake.surface, generator, &report.medial_quality);
            bake.medial_file = fmt::format("(generated: {} spheres)", options.spheres);
            bake.medial_hash = hash_text(format_medial(input_medial));
        });
    }

    // Inflates the radii by the least uniform amount whose envelope covers every surface vertex.
    void cover_surface(const MedialMesh& input_medial, BakeData& bake, BakeReport& report)
    {
        stage(report, "medial coverage", [&] {
            MedialCoverage coverage = measure_coverage(input_medial, bake.surface);
            bake.medial = inflate_to_cover(input_medial, coverage);
            bake.medial_input_radii = input_medial.radii;
            bake.medial_inflation = coverage.inflation;
            report.uncovered_vertices = coverage.uncovered;
            report.max_outside = coverage.max_outside;
            report.inflation = coverage.inflation;
        });
    }

    // Step 2: meshes the surface's interior into tets and records their quality.
    void tetrahedralize_interior(const BakeOptions& options, BakeData& bake, BakeReport& report)
    {
        stage(report, "tetrahedralize", [&] {
            TetrahedralizeOptions tet_options
                = tetrahedralize_options_for(report.bbox_diagonal, options.tet_size);
            tet_options.max_vertices = options.max_tet_vertices;
            tet_options.perturb = options.perturb_slivers;
            bake.tet_mesh = tetrahedralize(bake.surface, tet_options);
            const TetQuality quality = tet_quality(bake.tet_mesh);
            report.tets = quality.num_tets;
            report.nodes = quality.num_vertices;
            report.min_dihedral_degrees = quality.min_dihedral_degrees;
        });
    }

    // Step 3: embeds the surface vertices and the sphere centers in the tets.
    void embed_surface_and_centers(BakeData& bake, BakeReport& report)
    {
        stage(report, "embed", [&] {
            const TetEmbedding surface = embed_points(bake.tet_mesh, bake.surface.positions);
            bake.surface_tet = surface.tet;
            bake.surface_barycentric = surface.barycentric;
            bake.surface_outside_count = surface.outside_count;
            report.surface_outside_tets = surface.outside_count;
            const TetEmbedding medial = embed_points(bake.tet_mesh, bake.medial.centers);
            bake.medial_tet = medial.tet;
            bake.medial_barycentric = medial.barycentric;
            report.medial_outside_tets = medial.outside_count;
            report.medial_max_outside_distance = medial.max_outside_distance;
        });
    }

    // What steps 4-6 share across their passes: the tets' rest data, the Laplacian and B.
    struct OperatorInputs {
        Eigen::SparseMatrix<double> laplacian;
        TetRestData rest;
        HandleBasis basis;
    };

    // Step 4: harmonic weights over the handle regions, each widened to a tet if `widen` (the
    // first pass also computes the rest data and the Laplacian that both passes use).
    void compute_weights(const BakeOptions& options, const MedialMesh& input_medial, bool widen,
        OperatorInputs& inputs, BakeData& bake, BakeReport& report)
    {
        stage(report, "harmonic weights", [&] {
            if (!widen) { // the tets' rest data and the Laplacian serve both passes
                inputs.rest = compute_tet_rest_data(bake.tet_mesh.positions, bake.tet_mesh.tets);
                inputs.laplacian = assemble_laplacian(
                    bake.tet_mesh.num_vertices(), bake.tet_mesh.tets, inputs.rest);
            }
            WholeTetRegions regions;
            regions.owner = assign_handle_regions(bake.tet_mesh.positions, input_medial.centers,
                input_medial.radii, options.region_alpha);
            if (widen) {
                regions = give_every_region_a_tet(regions.owner, bake.tet_mesh.positions,
                    bake.tet_mesh.tets, input_medial.centers);
                logger().info("handle regions: {} of {} handles had a region that does not span "
                              "3D and were given the nearest free tet",
                    regions.handles_given_tets, input_medial.num_spheres());
            }
            report.handles_given_tets = regions.handles_given_tets;
            HarmonicWeightOptions weight_options;
            weight_options.max_handles_per_node = options.weights_per_node;
            HarmonicWeights weights = compute_harmonic_weights(
                inputs.laplacian, regions.owner, input_medial.num_spheres(), weight_options);
            bake.weights = std::move(weights.weights);
            report.weight_partition_error = weights.diagnostics.max_partition_error;
            report.weight_min = weights.diagnostics.min_weight;
            report.weight_max = weights.diagnostics.max_weight;
            report.weight_sparsify_change = weights.diagnostics.max_sparsify_change;
        });
    }

    // Step 5: the handle basis B, checked to reproduce affine fields.
    void compute_basis(const MedialMesh& input_medial,
        const Eigen::Matrix<bool, Eigen::Dynamic, 1>& quadratic, OperatorInputs& inputs,
        BakeData& bake, BakeReport& report)
    {
        stage(report, "handle basis", [&] {
            const VecX scales = handle_support_scales(
                bake.tet_mesh.positions, bake.weights, input_medial.centers);
            inputs.basis = build_handle_basis(
                bake.tet_mesh.positions, bake.weights, input_medial.centers, scales, quadratic);
            const HandleBasis& basis = inputs.basis;
            report.linear_precision_error = linear_precision_error(basis, bake.tet_mesh.positions);
            report.quadratic_precision_error
                = quadratic_precision_error(basis, bake.weights, bake.tet_mesh.positions);
            if (!(report.linear_precision_error < 1e-9))
                throw_error("internal: the basis does not reproduce affine fields (error {:.3g})",
                    report.linear_precision_error);
            bake.handle_centers = basis.centers;
            bake.handle_scales = basis.scales;
            bake.handle_quadratic = basis.quadratic.cast<int>();
            bake.handle_column_offsets = basis.handle_offset;
            bake.basis = basis.basis;
        });
        report.handles = inputs.basis.num_handles();
        report.quadratic_handles = quadratic.count();
        report.columns = inputs.basis.num_columns();
    }

    // Step 6: the PD operators (masses, Laplacian, their reductions), checked SPD.
    void compute_pd_operators(const OperatorInputs& inputs, BakeData& bake, BakeReport& report)
    {
        stage(report, "pd operators", [&] {
            bake.dm_inverse = inputs.rest.dm_inverse;
            bake.rest_volumes = inputs.rest.volumes;
            bake.lumped_mass = lumped_masses(
                bake.tet_mesh.num_vertices(), bake.tet_mesh.tets, inputs.rest.volumes);
            bake.laplacian = inputs.laplacian;
            const ReducedOperators reduced
                = reduce_operators(bake.basis, inputs.laplacian, bake.lumped_mass);
            // A representative system (E ~ 1e5 Pa, 1000 kg/m^3, dt = 1/30 s) must be SPD.
            const ReducedSystemCheck check = check_reduced_system(reduced, 1e5, 1000.0, 1.0 / 30.0);
            report.reduced_reciprocal_condition = check.reciprocal_condition;
            bake.reduced_laplacian = reduced.laplacian;
            bake.reduced_mass = reduced.mass;
        });
    }

    // Steps 4-6: harmonic weights, handle basis, PD operators. When the basis comes out
    // rank-deficient (many spheres: a handle whose small region is hemmed in by its neighbours'
    // keeps its weight on a node or two), once more with every such region widened to a tet
    // (step 4 of handle_regions.hpp). Bakes whose basis is fine are not changed.
    void compute_weights_basis_operators(const BakeOptions& options, const MedialMesh& input_medial,
        const Eigen::Matrix<bool, Eigen::Dynamic, 1>& quadratic, BakeData& bake, BakeReport& report)
    {
        OperatorInputs inputs;
        const auto weights_basis_operators = [&](bool widen) {
            compute_weights(options, input_medial, widen, inputs, bake, report);
            compute_basis(input_medial, quadratic, inputs, bake, report);
            compute_pd_operators(inputs, bake, report);
        };
        try {
            weights_basis_operators(false);
        } catch (const Error& error) {
            if (!reports_rank_deficient_basis(error))
                throw;
            logger().info("{}: widening the regions that do not span 3D, then again", error.what());
            weights_basis_operators(true);
        }
    }

    // Step 7: the collision-bound data, from B interpolated at the surface vertices and centers.
    void compute_collision_data(BakeData& bake, BakeReport& report)
    {
        stage(report, "collision data", [&] {
            const SparseRowMatrix surface_basis = interpolate_rows(
                bake.basis, bake.tet_mesh.tets, bake.surface_tet, bake.surface_barycentric);
            bake.medial_basis = interpolate_rows(
                bake.basis, bake.tet_mesh.tets, bake.medial_tet, bake.medial_barycentric);
            bake.collision = build_collision_data(bake.medial, bake.surface, surface_basis,
                bake.medial_basis, bake.handle_column_offsets);
        });
    }

    // The options the bake depends on, as the JSON text stored in the bake.
    std::string options_json(const BakeOptions& options, bool medial_generated)
    {
        nlohmann::json json;
        json["tet_size"] = options.tet_size;
        if (!options.perturb_slivers)
            json["sliver_perturbation"] = "off";
        json["quadratic"] = options.quadratic;
        json["weights_per_node"] = options.weights_per_node;
        json["region_alpha"] = options.region_alpha;
        json["unit"] = options.unit;
        json["unit_scale"] = unit_scale(options.unit);
        if (medial_generated) {
            json["spheres"] = options.spheres;
            json["medial_samples"] = options.generator.samples;
        }
        return json.dump();
    }

} // namespace

double unit_scale(const std::string& unit)
{
    if (unit == "in")
        return 0.0254;
    const double per_metre = units_per_metre(unit);
    if (per_metre == 0.0)
        throw_error("--unit {}: unknown length unit (mm, cm, m or in)", unit);
    return 1.0 / per_metre;
}

void scale_to_metres(SurfaceMesh& surface, const std::string& unit)
{
    scale_lengths(surface.positions, unit);
}

void scale_to_metres(MedialMesh& medial, const std::string& unit)
{
    scale_lengths(medial.centers, unit);
    scale_lengths(medial.radii, unit);
}

BakeData run_bake(const BakeOptions& options, BakeReport& report)
{
    return run_bake(options, report, nullptr);
}

BakeData run_bake(const BakeOptions& options, BakeReport& report, const MedialMesh* generated)
{
    check_options(options);
    BakeData bake;
    bake.surface_file = options.surface;
    bake.medial_file = options.medial;
    report.medial_generated = options.spheres > 0;

    // 1. Inputs.
    MedialMesh input_medial;
    read_inputs(options, bake, report, input_medial);
    if (report.medial_generated)
        generate_medial(options, generated, bake, report, input_medial);
    report.surface_vertices = bake.surface.num_vertices();
    report.surface_faces = bake.surface.num_faces();
    report.medial_spheres = input_medial.num_spheres();
    report.medial_cones = input_medial.num_cones();
    report.medial_slabs = input_medial.num_slabs();
    const Eigen::Matrix<bool, Eigen::Dynamic, 1> quadratic
        = parse_quadratic(options.quadratic, input_medial.num_spheres());
    cover_surface(input_medial, bake, report);

    // 2-7. Tets, embedding, weights, basis, PD operators, collision data.
    tetrahedralize_interior(options, bake, report);
    embed_surface_and_centers(bake, report);
    compute_weights_basis_operators(options, input_medial, quadratic, bake, report);
    compute_collision_data(bake, report);
    bake.options_json = options_json(options, report.medial_generated);
    return bake;
}

std::string BakeReport::summary() const
{
    std::string out;
    out += fmt::format("surface: {} vertices, {} faces, bbox diagonal {:.6g}\n", surface_vertices,
        surface_faces, bbox_diagonal);
    out += fmt::format("medial mesh: {} spheres, {} cones, {} slabs\n", medial_spheres,
        medial_cones, medial_slabs);
    if (medial_generated)
        out += fmt::format("generated medial mesh: {}\n", medial_quality.summary());
    out += fmt::format("coverage: {} of {} surface vertices outside the envelope, max {:.4g} "
                       "({:.3f}% of the diagonal); radii inflated by {:.4g}\n",
        uncovered_vertices, surface_vertices, max_outside,
        100.0 * max_outside / std::max(bbox_diagonal, 1e-300), inflation);
    out += fmt::format("tets: {} tets, {} nodes, min dihedral angle {:.2f} deg\n", tets, nodes,
        min_dihedral_degrees);
    out += fmt::format("embedding: {} surface vertices and {} sphere centers outside every tet "
                       "(the least extrapolated tet near each; farthest center {:.3g} away)\n",
        surface_outside_tets, medial_outside_tets, medial_max_outside_distance);
    out += fmt::format("handles: {} ({} quadratic), {} basis columns, {} reduced DOF; {} regions "
                       "widened to a tet\n",
        handles, quadratic_handles, columns, 3 * columns, handles_given_tets);
    out += fmt::format("weights: partition of unity error {:.2g}, raw range [{:.3g}, {:.3g}], "
                       "largest change from sparsification {:.3g}\n",
        weight_partition_error, weight_min, weight_max, weight_sparsify_change);
    out += fmt::format("basis: linear precision error {:.2g}", linear_precision_error);
    if (quadratic_precision_error >= 0)
        out += fmt::format(", quadratic precision error {:.2g}", quadratic_precision_error);
    out += fmt::format("\nreduced system: reciprocal condition {:.3g} (E 1e5 Pa, 1000 kg/m^3, "
                       "dt 1/30 s)\n",
        reduced_reciprocal_condition);
    return out;
}

} // namespace mat
