// Edge-edge contacts (docs/method.md, "Edge contacts"): two wedges (triangular prisms 0.6 m long
// whose ridges are single edges) meet ridge on ridge, crossed at a right angle, in zero gravity
// without friction. No vertex of either ever comes near a face of the other, so only a contact
// between the two ridges can stop them: without edge contacts the upper wedge passes through
// the lower one; with them the ridges stay apart (within 0.5% of the diagonal), the impact
// moves the lower wedge with the total momentum kept, and the energy never rises.

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "formats/bake_io.hpp"
#include "preprocess/bake/bake_pipeline.hpp"
#include "runtime/measures/body_measures.hpp"
#include "runtime/scene/scene.hpp"
#include "runtime/scene/scene_bodies.hpp"
#include "runtime/simulation.hpp"
#include "tests/support/temp_files.hpp"

namespace mat {
namespace {

    /// A wedge 0.6 m long along x, 0.2 m wide and 0.1 m high, its ridge up along y = 0.1 (one
    /// edge from x = -0.3 to 0.3), or (`down`) turned to lie along z with its ridge down at y = 0.
    std::string wedge_obj(bool down)
    {
        const std::array<std::array<double, 3>, 6> up { { { -0.3, 0.0, -0.1 }, { -0.3, 0.0, 0.1 },
            { -0.3, 0.1, 0.0 }, { 0.3, 0.0, -0.1 }, { 0.3, 0.0, 0.1 }, { 0.3, 0.1, 0.0 } } };
        std::string text;
        for (const auto& [x, y, z] : up) {
            // Half a turn about z, then a quarter about y (a rotation: the faces stay outward).
            if (down)
                text += fmt::format("v {} {} {}\n", z, 0.1 - y, x);
            else
                text += fmt::format("v {} {} {}\n", x, y, z);
        }
        text += "f 1 2 3\nf 4 6 5\nf 1 4 5\nf 1 5 2\nf 2 5 6\nf 2 6 3\nf 3 6 4\nf 3 4 1\n";
        return text;
    }

    struct EdgeParam {
        SolverKind solver;
        bool edges;
    };

    class EdgeContactTest : public test::ScratchDirTest,
                            public ::testing::WithParamInterface<EdgeParam> { };

    /// Signed distance along y of the upper ridge above the lower one where they cross (the
    /// closest points of the two lines): negative once they have crossed.
    double ridge_gap(const std::array<Vec3, 2>& lower, const std::array<Vec3, 2>& upper)
    {
        const Vec3 u = lower[1] - lower[0];
        const Vec3 v = upper[1] - upper[0];
        const Vec3 w = lower[0] - upper[0];
        const double a = u.dot(u), b = u.dot(v), c = v.dot(v), d = u.dot(w), e = v.dot(w);
        const double det = a * c - b * b;
        const Vec3 p = lower[0] + ((b * e - c * d) / det) * u;
        const Vec3 q = upper[0] + ((a * e - b * d) / det) * v;
        return q.y() - p.y();
    }

    /// The ridge's two surface vertices of a body: the highest two (`top`) or the lowest two.
    std::array<Index, 2> ridge_vertices(const MatX3& surface, bool top)
    {
        std::vector<Index> order(static_cast<std::size_t>(surface.rows()));
        for (Index i = 0; i < surface.rows(); ++i)
            order[static_cast<std::size_t>(i)] = i;
        std::sort(order.begin(), order.end(), [&](Index i, Index j) {
            return top ? surface(i, 1) > surface(j, 1) : surface(i, 1) < surface(j, 1);
        });
        return { order[0], order[1] };
    }

    TEST_P(EdgeContactTest, RidgeMeetsRidge)
    {
        const EdgeParam& p = GetParam();
        for (const bool down : { false, true }) {
            BakeOptions options;
            options.surface = write_text(down ? "upper.obj" : "lower.obj", wedge_obj(down));
            options.spheres = 8;
            options.tet_size = 0.05;
            options.perturb_slivers = false;
            BakeReport report;
            write_bake(path(down ? "upper.h5" : "lower.h5"), run_bake(options, report));
        }
        const std::string text = fmt::format(R"({{
  "time": {{ "dt": 0.0166666667, "frames": 40, "iterations": 10 }},
  "gravity": [0, 0, 0],
  "solver": {{ "collision": "bounded", "collision_friction": 0.0, "edge_contacts": "{}" }},
  "objects": [
    {{ "name": "lower", "bake": "lower.h5",
      "material": {{ "youngs_modulus": 1e5, "poisson_ratio": 0.3, "density": 1000 }} }},
    {{ "name": "upper", "bake": "upper.h5", "position": [0, 0.15, 0], "velocity": [0, -1, 0],
      "material": {{ "youngs_modulus": 1e5, "poisson_ratio": 0.3, "density": 1000 }} }}
  ]
}})",
            p.edges ? "on" : "off");
        const Scene scene = read_scene(write_text("scene.json", text));
        Simulation simulation(scene, load_bodies(scene, p.solver));
        const Body& lower = simulation.bodies()[0];
        const Body& upper = simulation.bodies()[1];
        MatX3 surface_lower(lower.model->surface().num_vertices(), 3);
        MatX3 surface_upper(upper.model->surface().num_vertices(), 3);
        const auto surfaces = [&] {
            lower.model->surface().positions(lower.state.positions, surface_lower);
            upper.model->surface().positions(upper.state.positions, surface_upper);
        };
        surfaces();
        const std::array<Index, 2> ridge_lower = ridge_vertices(surface_lower, true);
        const std::array<Index, 2> ridge_upper = ridge_vertices(surface_upper, false);
        const auto gap = [&] {
            return ridge_gap({ surface_lower.row(ridge_lower[0]).transpose(),
                                 surface_lower.row(ridge_lower[1]).transpose() },
                { surface_upper.row(ridge_upper[0]).transpose(),
                    surface_upper.row(ridge_upper[1]).transpose() });
        };
        ASSERT_NEAR(gap(), 0.05, 1e-6); // the bake stores floats
        const auto momentum = [&](const Body& body) {
            return Vec3(body.state.velocities.transpose() * body.model->pd().masses());
        };
        const auto energy = [&] {
            double sum = 0.0;
            for (const Body& body : simulation.bodies()) {
                const BodyMeasures m = measure_body(body.model->pd(), body.state, scene.gravity);
                sum += m.kinetic + m.elastic;
            }
            return sum;
        };
        const Vec3 p0 = momentum(lower) + momentum(upper);
        const double e0 = energy();
        const double diagonal
            = std::min(lower.model->rest_diagonal(), upper.model->rest_diagonal());
        double deepest = 0.0;
        int edge_steps = 0;
        for (int s = 1; s <= scene.frames * scene.steps_per_frame; ++s) {
            simulation.step();
            surfaces();
            deepest = std::min(deepest, gap());
            edge_steps += simulation.collision()->last_report().edge_contacts > 0 ? 1 : 0;
            EXPECT_LE(energy(), e0 * (1.0 + 1e-9)) << "step " << s;
        }
        const Vec3 p1 = momentum(lower) + momentum(upper);
        EXPECT_LE((p1 - p0).norm(), 0.01 * p0.norm());
        if (!p.edges) {
            // Nothing else stops it: the upper ridge passes through the lower wedge.
            EXPECT_EQ(edge_steps, 0);
            EXPECT_LT(deepest, -0.1);
            return;
        }
        EXPECT_GT(edge_steps, 0);
        EXPECT_GE(deepest, -0.005 * diagonal);
        // The lower wedge was pushed (at least a third of the momentum), and they parted.
        EXPECT_LT(momentum(lower).y(), p0.y() / 3.0);
        EXPECT_GT(gap(), 0.0);
    }

    INSTANTIATE_TEST_SUITE_P(Contact, EdgeContactTest,
        ::testing::Values(EdgeParam { SolverKind::semi_reduced, true },
            EdgeParam { SolverKind::full, true }, EdgeParam { SolverKind::hyper_reduced, true },
            EdgeParam { SolverKind::semi_reduced, false }),
        [](const ::testing::TestParamInfo<EdgeParam>& info) {
            const EdgeParam& p = info.param;
            return std::string(p.solver == SolverKind::full        ? "full"
                           : p.solver == SolverKind::hyper_reduced ? "hyper"
                                                                   : "semi")
                + (p.edges ? "_edges" : "_no_edges");
        });

} // namespace
} // namespace mat
