#include "preprocess/model_size/model_size_search.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <optional>

#include <nlohmann/json.hpp>

#include "common/error.hpp"
#include "common/log.hpp"
#include "common/surface_embedding.hpp"
#include "common/timer.hpp"
#include "formats/surface_validation.hpp"
#include "preprocess/medial/medial_generator.hpp"
#include "preprocess/pd/reduced_operators.hpp"

namespace mat {

double parse_error_percent(const std::string& text)
{
    std::string number = text;
    if (!number.empty() && number.back() == '%')
        number.pop_back();
    std::size_t used = 0;
    double value = std::nan("");
    try {
        value = std::stod(number, &used);
    } catch (const std::exception&) {
        used = 0;
    }
    if (number.empty() || used != number.size() || !std::isfinite(value))
        throw_error("--error: '{}' is not a number (expected a percentage of the bounding-box "
                    "diagonal, e.g. 2 or 2%)",
            text);
    if (!(value > 0.0 && value < 100.0))
        throw_error(
            "--error: {} must be in (0, 100) (a percentage of the bounding-box diagonal)", text);
    return value;
}

namespace {

    // The quadratic handles as --quadratic takes them.
    std::string handle_list(const std::vector<Index>& handles)
    {
        if (handles.empty())
            return "none";
        std::string out;
        for (const Index h : handles)
            out += (out.empty() ? "" : ",") + std::to_string(h);
        return out;
    }

    // What evaluating one candidate gives besides its row.
    struct Evaluation {
        ModelCandidate row;
        VecX residuals; ///< per handle, summed over the load cases (reduced candidates)
    };

    class Search {
    public:
        explicit Search(const ModelSizeOptions& options)
            : m_options(options)
            , m_generated(options.bake.medial.empty())
        {
            // Refused before any medial mesh is generated, as the bake would refuse it.
            CheckedSurface checked = inspect_surface(options.bake.surface);
            require_bake_surface(checked, options.bake.surface, options.bake.checks);
            m_surface = std::move(checked.surface);
            scale_to_metres(m_surface, options.bake.unit);
            m_box = validate_surface(m_surface).bbox;
            m_diagonal = m_box.diagonal().norm();
            m_cases = standard_load_cases(m_box);
        }

        ModelSizeResult run();

    private:
        const MedialMesh& medial(Index spheres);
        Evaluation evaluate(const std::string& stage, Index spheres, double tet_size,
            bool full_space, const std::vector<Index>& quadratic);
        void reference();
        double choose_tet_size();
        Index choose_spheres();
        bool try_quadratic(Index spheres, const VecX& residuals, Index low, Index high);

        bool within(const SurfaceError& error, double budget) const
        {
            return error.max_percent <= budget;
        }

        const ModelSizeOptions& m_options;
        bool m_generated;
        SurfaceMesh m_surface;
        Box3 m_box;
        double m_diagonal = 0.0;
        std::vector<LoadCase> m_cases;
        std::vector<MatX3> m_reference; ///< per case, surface positions  #Vs x 3
        std::map<Index, std::pair<MedialMesh, MedialQuality>> m_medial; ///< by requested count
        std::map<Index, VecX> m_failed; ///< linear reduced candidates over E: residuals
        double m_tet_size = 0.0;
        Index m_first = 0; ///< the sphere count of the reference and the tet-size candidates
        ModelSizeResult m_result;
        bool m_have_choice = false;
        double m_closest = 0.0; ///< the largest linear count's error, when none is within E
    };

    const MedialMesh& Search::medial(Index spheres)
    {
        auto found = m_medial.find(spheres);
        if (found != m_medial.end())
            return found->second.first;
        MedialGeneratorOptions generator = m_options.bake.generator;
        generator.spheres = spheres;
        generator.surface_name = m_options.bake.surface;
        MedialQuality quality;
        MedialMesh mesh = generate_medial_mesh(m_surface, generator, &quality);
        return m_medial.emplace(spheres, std::make_pair(std::move(mesh), quality))
            .first->second.first;
    }

    Evaluation Search::evaluate(const std::string& stage, Index spheres, double tet_size,
        bool full_space, const std::vector<Index>& quadratic)
    {
        Timer timer;
        BakeOptions bake_options = m_options.bake;
        bake_options.quadratic = handle_list(quadratic);
        bake_options.spheres = m_generated ? spheres : 0;
        BakeReport report;
        BakeData bake;
        // The medial mesh first: its failures are errors, not a reason to refine the tets.
        const MedialMesh* generated = m_generated ? &medial(spheres) : nullptr;
        for (;;) {
            bake_options.tet_size = tet_size;
            try {
                bake = run_bake(bake_options, report, generated);
                if (m_generated)
                    report.medial_quality = m_medial.at(spheres).second;
                break;
            } catch (const Error& error) {
                // Too few nodes for the handles (a rank-deficient basis): refine the tet size
                // for this and every later reduced candidate.
                const double finer
                    = std::max(m_options.bake.tet_size, tet_size / m_options.tet_growth);
                if (full_space || !(finer < tet_size) || !reports_rank_deficient_basis(error))
                    throw;
                logger().info("{} spheres at tet size {:.4g}: {}; tet size {:.4g} from now on",
                    spheres, tet_size, error.what(), finer);
                tet_size = m_tet_size = finer;
            }
        }
        if (m_reference.empty())
            calibrate_gravity(bake, m_box, m_cases, m_options.deflection, m_options.solve);

        Evaluation result;
        ModelCandidate& row = result.row;
        row.stage = stage;
        row.full_space = full_space;
        row.spheres = bake.num_handles();
        row.quadratic = static_cast<Index>(quadratic.size());
        row.tet_size = tet_size;
        row.tets = bake.tet_mesh.num_tets();
        row.dof = 3 * (full_space ? bake.tet_mesh.num_vertices() : bake.num_columns());
        result.residuals = VecX::Zero(bake.num_handles());
        const bool is_reference = m_reference.empty();
        const SurfaceEmbedding embedding(bake);
        for (std::size_t c = 0; c < m_cases.size(); ++c) {
            const StaticSolution solution
                = solve_static(bake, m_box, m_cases[c], full_space, m_options.solve);
            MatX3 surface(embedding.num_vertices(), 3);
            embedding.positions(solution.positions, surface);
            if (is_reference) {
                m_reference.push_back(surface);
                logger().info("load case {}: largest surface displacement {:.3g}% of the "
                              "diagonal ({} steps)",
                    m_cases[c].name,
                    100.0 * (surface - m_surface.positions).rowwise().norm().maxCoeff()
                        / m_diagonal,
                    solution.steps);
                continue;
            }
            const SurfaceError error = surface_error(surface, m_reference[c], m_diagonal);
            logger().debug("  {}: rms {:.3f}%, max {:.3f}% ({} steps, last change {:.2e})",
                m_cases[c].name, error.rms_percent, error.max_percent, solution.steps,
                solution.last_change);
            row.error.max_percent = std::max(row.error.max_percent, error.max_percent);
            row.error.rms_percent = std::max(row.error.rms_percent, error.rms_percent);
            if (!full_space)
                result.residuals += handle_residuals(bake, solution.positions);
        }
        const double budget = full_space ? m_options.tet_error_share * m_options.error_percent
                                         : m_options.error_percent;
        row.within = within(row.error, budget);
        row.seconds = timer.seconds();
        logger().info("{}: {} spheres, {} quadratic, tet size {:.4g} ({} tets), {} DOF{}: error "
                      "rms {:.3f}%, max {:.3f}% ({}) in {:.1f} s",
            stage, row.spheres, row.quadratic, tet_size, row.tets, row.dof,
            full_space ? " (full space)" : "", row.error.rms_percent, row.error.max_percent,
            row.within ? "within" : "over", row.seconds);
        m_result.tried.push_back(row);

        // The smallest model so far: fewest reduced DOF, then fewest tets.
        const bool smaller = !m_have_choice || row.dof < m_result.chosen.dof
            || (row.dof == m_result.chosen.dof && row.tets < m_result.chosen.tets);
        if (!full_space && row.within && smaller) {
            m_have_choice = true;
            m_result.chosen = row;
            m_result.bake = std::move(bake);
            m_result.report = report;
            m_result.quadratic = bake_options.quadratic;
        }
        return result;
    }

    double Search::choose_tet_size()
    {
        double size = m_options.bake.tet_size;
        while (size * m_options.tet_growth <= m_options.max_tet_size) {
            const double coarser = size * m_options.tet_growth;
            if (!evaluate("tet size", m_first, coarser, true, {}).row.within)
                break;
            size = coarser;
        }
        return size;
    }

    Index Search::choose_spheres()
    {
        const Index largest
            = m_options.bake.spheres > 0 ? m_options.bake.spheres : m_options.max_spheres;
        Index low = 0, high = 0;
        for (Index n = std::min(m_options.first_spheres, largest);; n = std::min(2 * n, largest)) {
            const Evaluation e = evaluate("spheres", n, m_tet_size, false, {});
            if (e.row.within) {
                high = n;
                break;
            }
            m_failed[n] = e.residuals;
            low = n;
            if (n == largest) {
                m_closest = e.row.error.max_percent;
                return 0; // no linear answer
            }
        }
        // Bisection down to a step of about 1/8 of the count.
        while (low > 0 && high - low > std::max<Index>(1, low / 8)) {
            const Index middle = (low + high) / 2;
            const Evaluation e = evaluate("spheres", middle, m_tet_size, false, {});
            if (e.row.within) {
                high = middle;
            } else {
                m_failed[middle] = e.residuals;
                low = middle;
            }
        }
        return high;
    }

    // Tries `spheres` with its `high` handles of largest residual quadratic, and if that is within
    // E, bisects down to the fewest (`low` of them are known to be over E). Returns whether `high`
    // was within E.
    bool Search::try_quadratic(Index spheres, const VecX& residuals, Index low, Index high)
    {
        std::vector<Index> order(static_cast<std::size_t>(residuals.size()));
        std::iota(order.begin(), order.end(), Index(0));
        std::stable_sort(order.begin(), order.end(),
            [&](Index a, Index b) { return residuals(a) > residuals(b); });
        high = std::min<Index>(high, residuals.size());
        const auto top = [&](Index count) {
            std::vector<Index> handles(order.begin(), order.begin() + count);
            std::sort(handles.begin(), handles.end());
            return handles;
        };
        if (high <= low || !evaluate("quadratic", spheres, m_tet_size, false, top(high)).row.within)
            return false;
        while (high - low > 1) {
            const Index middle = (low + high) / 2;
            if (evaluate("quadratic", spheres, m_tet_size, false, top(middle)).row.within)
                high = middle;
            else
                low = middle;
        }
        return true;
    }

    ModelSizeResult Search::run()
    {
        if (!(m_options.error_percent > 0.0 && std::isfinite(m_options.error_percent)))
            throw_error("--error: {} must be a positive percentage of the bounding-box diagonal",
                m_options.error_percent);
        m_first = m_generated ? m_options.first_spheres : 0;
        // The reference: full space at the finest tet size.
        evaluate("reference", m_first, m_options.bake.tet_size, true, {});
        m_tet_size = choose_tet_size();
        logger().info("tet size {:.4g} of the diagonal", m_tet_size);

        if (m_generated) {
            const Index linear = choose_spheres();
            // No linear answer up to the largest count: quadratic handles there, as many as needed.
            if (linear == 0) {
                const auto largest = m_failed.rbegin();
                const Index m = largest->second.size();
                Index count = 1;
                while (
                    !try_quadratic(largest->first, largest->second, count / 2, count) && count < m)
                    count = std::min(2 * count, m);
                if (!m_have_choice)
                    throw_error(
                        "{}: no model within {}% of the diagonal up to {} spheres, also with "
                        "quadratic handles (the closest linear: {:.3f}%); allow a larger "
                        "--error or more --spheres",
                        m_options.bake.surface, m_options.error_percent, largest->first, m_closest);
            }
            const Index linear_columns = m_result.chosen.dof / 3;
            // At the largest failed counts, quadratic handles instead of more spheres: a linear
            // handle has 4 basis columns, a quadratic one 10.
            int tried = 0;
            for (auto it = m_failed.rbegin(); it != m_failed.rend() && tried < 3; ++it, ++tried) {
                const Index columns = 4 * it->second.size();
                const Index max_quadratic = (linear_columns - columns - 1) / 6;
                try_quadratic(it->first, it->second, 0, max_quadratic);
            }
            logger().debug("linear answer: {} spheres", linear);
        } else {
            const Evaluation linear = evaluate("spheres", 0, m_tet_size, false, {});
            if (!linear.row.within) {
                const Index m = linear.residuals.size();
                Index count = 1;
                while (!try_quadratic(0, linear.residuals, count / 2, count) && count < m)
                    count = std::min(2 * count, m);
            }
            if (!m_have_choice)
                throw_error("{}: no model within {}% of the diagonal with the {} spheres of {}; "
                            "allow a larger --error or use more spheres",
                    m_options.bake.surface, m_options.error_percent, linear.residuals.size(),
                    m_options.bake.medial);
        }
        m_result.cases = m_cases;
        nlohmann::json json = nlohmann::json::parse(m_result.bake.options_json);
        json["model_size"] = { { "error_percent", m_options.error_percent },
            { "measured_max_percent", m_result.chosen.error.max_percent },
            { "measured_rms_percent", m_result.chosen.error.rms_percent } };
        m_result.bake.options_json = json.dump();
        return std::move(m_result);
    }

} // namespace

ModelSizeResult choose_model_size(const ModelSizeOptions& options)
{
    Search search(options);
    return search.run();
}

std::string ModelSizeResult::table() const
{
    std::string out = fmt::format("{:<10} {:>7} {:>9} {:>8} {:>7} {:>7} {:>9} {:>9} {:>7} {:>8}\n",
        "stage", "spheres", "quadratic", "tet size", "tets", "DOF", "rms %", "max %", "within",
        "time (s)");
    const auto line = [&](const ModelCandidate& c) {
        return fmt::format("{:<10} {:>7} {:>9} {:>8.4g} {:>7} {:>7}{} {:>9.3f} {:>9.3f} {:>7} "
                           "{:>8.2f}\n",
            c.stage, c.spheres, c.quadratic, c.tet_size, c.tets, c.dof, c.full_space ? "f" : " ",
            c.error.rms_percent, c.error.max_percent, c.within ? "yes" : "no", c.seconds);
    };
    for (const ModelCandidate& c : tried)
        out += line(c);
    out += "chosen:\n" + line(chosen);
    out += fmt::format("(DOF marked f: full space, 3 x nodes; errors: largest over the {} load "
                       "cases of the surface-vertex distance to the reference, % of the bbox "
                       "diagonal)\n",
        cases.size());
    return out;
}

} // namespace mat
