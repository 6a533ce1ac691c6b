// Ground-plane contact inside the projective dynamics solve: the Signorini-Coulomb solve on small
// closed-form cases, then whole bodies dropped, resting, sliding and lifting off, for both
// solvers.

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "common/error.hpp"
#include "runtime/model.hpp"
#include "runtime/pd/contact.hpp"
#include "runtime/pd/contact_stage.hpp"
#include "runtime/pd/solver.hpp"
#include "runtime/state.hpp"
#include "tests/runtime/runtime_test_models.hpp"

namespace mat {
namespace {

    constexpr double dt = 1.0 / 60.0;

    /// The contact solve with every coupling column given up front.
    ContactSolveResult solve_dense(const MatX& coupling, const std::vector<PlaneCollider>& planes,
        const std::vector<ContactPair>& pairs, const MatX3& free, const MatX3& start, MatX3& forces,
        MatX3& positions, const ContactSettings& settings = {})
    {
        DenseContactCoupling dense(coupling);
        return solve_plane_contacts(dense, planes, pairs, free, start, forces, positions, settings);
    }

    TEST(PlaneContact, BoundaryNodesOfAGrid)
    {
        test::GridTetOptions grid;
        grid.nx = grid.ny = grid.nz = 3;
        const BakeData bake = test::make_grid_bake(grid);
        const std::vector<int> nodes
            = boundary_nodes(bake.tet_mesh.tets, bake.tet_mesh.num_vertices());
        // 4^3 nodes, 2^3 of them interior.
        EXPECT_EQ(nodes.size(), 64u - 8u);
        for (const int i : nodes) {
            const auto p = bake.tet_mesh.positions.row(i);
            EXPECT_TRUE((p.array() < 1e-12).any() || (p.array() > 1.0 - 1e-12).any()) << i;
        }
    }

    TEST(PlaneContact, CompliantContactStopsShortByItsCompliance)
    {
        // Compliance k: the conditions hold at x + k D f, so f = -gap / (D (1 + k)) and the node
        // stays gap k / (1 + k) behind the plane.
        PlaneCollider plane { Vec3::Zero(), Vec3::UnitY(), 0.0 };
        plane.compliance = 0.1;
        const std::vector<PlaneCollider> planes { plane };
        const std::vector<ContactPair> pairs { ContactPair { 0, 0 } };
        MatX coupling(1, 1);
        coupling << 0.5;
        MatX3 free(1, 3), start(1, 3), forces = MatX3::Zero(1, 3), positions(1, 3);
        free << 0.3, -0.2, 0.1;
        start << 0.0, 0.1, 0.0;
        solve_dense(coupling, planes, pairs, free, start, forces, positions);
        EXPECT_NEAR(forces(0, 1), 0.2 / (0.5 * 1.1), 1e-12);
        EXPECT_NEAR(positions(0, 1), -0.2 * 0.1 / 1.1, 1e-12);
        EXPECT_NEAR(positions(0, 0), 0.3, 1e-15);
    }

    TEST(PlaneContact, CappedComplianceGivesNoMoreThanItsCap)
    {
        // The case above gives 0.2 k / (1 + k) = 18.2 mm behind the plane. Capped at 10 mm, the
        // contact is hard past the cap: the node rests exactly 10 mm behind, f = (0.2 - 0.01) /
        // D. Capped at 30 mm, the cap does not bind and the force is the compliant one.
        PlaneCollider plane { Vec3::Zero(), Vec3::UnitY(), 0.0 };
        plane.compliance = 0.1;
        MatX coupling(1, 1);
        coupling << 0.5;
        const std::vector<ContactPair> pairs { ContactPair { 0, 0 } };
        MatX3 free(1, 3), start(1, 3), positions(1, 3);
        free << 0.3, -0.2, 0.1;
        start << 0.0, 0.1, 0.0;
        for (const double cap : { 0.01, 0.03 }) {
            plane.compliance_cap = cap;
            const std::vector<PlaneCollider> planes { plane };
            MatX3 forces = MatX3::Zero(1, 3);
            solve_dense(coupling, planes, pairs, free, start, forces, positions);
            const double compliant = 0.2 / (0.5 * 1.1);
            if (cap < 0.2 * 0.1 / 1.1) {
                EXPECT_NEAR(positions(0, 1), -cap, 1e-12);
                EXPECT_NEAR(forces(0, 1), (0.2 - cap) / 0.5, 1e-12);
                EXPECT_GT(forces(0, 1), compliant);
            } else {
                EXPECT_NEAR(forces(0, 1), compliant, 1e-12);
                EXPECT_NEAR(positions(0, 1), -0.2 * 0.1 / 1.1, 1e-12);
            }
        }
    }

    TEST(PlaneContact, CapsBindOnlyWhereTheSolveLetsThem)
    {
        // The contact stage lets the caps bind in a step's last solve only
        // (ContactSettings::compliance_caps): without them the 10 mm cap above is ignored and
        // the node rests 18.2 mm behind, at the compliant force.
        PlaneCollider plane { Vec3::Zero(), Vec3::UnitY(), 0.0 };
        plane.compliance = 0.1;
        plane.compliance_cap = 0.01;
        const std::vector<PlaneCollider> planes { plane };
        const std::vector<ContactPair> pairs { ContactPair { 0, 0 } };
        MatX coupling(1, 1);
        coupling << 0.5;
        MatX3 free(1, 3), start(1, 3), positions(1, 3);
        free << 0.3, -0.2, 0.1;
        start << 0.0, 0.1, 0.0;
        for (const bool caps : { false, true }) {
            ContactSettings settings;
            settings.compliance_caps = caps;
            MatX3 forces = MatX3::Zero(1, 3);
            solve_dense(coupling, planes, pairs, free, start, forces, positions, settings);
            EXPECT_NEAR(positions(0, 1), caps ? -0.01 : -0.2 * 0.1 / 1.1, 1e-12) << caps;
            EXPECT_NEAR(forces(0, 1), caps ? (0.2 - 0.01) / 0.5 : 0.2 / (0.5 * 1.1), 1e-12) << caps;
        }
    }

    TEST(PlaneContact, SingleNodeIsPushedOntoThePlane)
    {
        const std::vector<PlaneCollider> planes { PlaneCollider {
            Vec3::Zero(), Vec3::UnitY(), 0.0 } };
        const std::vector<ContactPair> pairs { ContactPair { 0, 0 } };
        MatX coupling(1, 1);
        coupling << 0.5;
        MatX3 free(1, 3), start(1, 3), forces = MatX3::Zero(1, 3), positions(1, 3);
        free << 0.3, -0.2, 0.1;
        start << 0.0, 0.1, 0.0;
        solve_dense(coupling, planes, pairs, free, start, forces, positions);
        // Frictionless: only the normal component changes, to exactly 0; f = gap / D.
        EXPECT_NEAR(positions(0, 1), 0.0, 1e-15);
        EXPECT_NEAR(positions(0, 0), 0.3, 1e-15);
        EXPECT_NEAR(positions(0, 2), 0.1, 1e-15);
        EXPECT_NEAR(forces(0, 1), 0.4, 1e-15);

        // Above the plane: no force.
        free << 0.3, 0.2, 0.1;
        forces.setZero();
        solve_dense(coupling, planes, pairs, free, start, forces, positions);
        EXPECT_EQ(forces.norm(), 0.0);
        EXPECT_EQ((positions - free).norm(), 0.0);
    }

    TEST(PlaneContact, FrictionSticksInsideTheConeAndSlipsOutside)
    {
        MatX coupling(1, 1);
        coupling << 1.0;
        const std::vector<ContactPair> pairs { ContactPair { 0, 0 } };
        MatX3 start = MatX3::Zero(1, 3), free(1, 3), forces(1, 3), positions(1, 3);
        // The free position is 0.1 below the plane (normal force 0.1) and 0.04 along x.
        free << 0.04, -0.1, 0.0;
        // mu = 0.5: the friction limit 0.05 exceeds the 0.04 needed to stick.
        std::vector<PlaneCollider> planes { PlaneCollider { Vec3::Zero(), Vec3::UnitY(), 0.5 } };
        forces.setZero();
        solve_dense(coupling, planes, pairs, free, start, forces, positions);
        EXPECT_NEAR(positions(0, 0), 0.0, 1e-12);
        EXPECT_NEAR(positions(0, 1), 0.0, 1e-12);
        // mu = 0.1: limit 0.01, the node slides 0.04 - 0.01.
        planes[0].friction = 0.1;
        forces.setZero();
        solve_dense(coupling, planes, pairs, free, start, forces, positions);
        EXPECT_NEAR(positions(0, 0), 0.03, 1e-12);
        EXPECT_NEAR(forces(0, 0), -0.01, 1e-12);
        EXPECT_NEAR(positions(0, 1), 0.0, 1e-12);
    }

    TEST(PlaneContact, CoupledNodesShareTheLoad)
    {
        // Two nodes coupled like a rigid bar (D = [1 1; 1 1] + 0.01 I), both 0.1 below: the
        // solve must lift both without overshoot, total force ~0.1 / (2 + 0.01) * 2.
        MatX coupling(2, 2);
        coupling << 1.01, 1.0, 1.0, 1.01;
        const std::vector<PlaneCollider> planes { PlaneCollider {
            Vec3::Zero(), Vec3::UnitY(), 0.0 } };
        const std::vector<ContactPair> pairs { ContactPair { 0, 0 }, ContactPair { 1, 0 } };
        MatX3 free(2, 3), start = MatX3::Zero(2, 3), forces = MatX3::Zero(2, 3), positions(2, 3);
        free << 0.0, -0.1, 0.0, 1.0, -0.1, 0.0;
        ContactSettings settings;
        settings.max_sweeps = 2000;
        settings.tolerance = 1e-14;
        solve_dense(coupling, planes, pairs, free, start, forces, positions, settings);
        EXPECT_NEAR(positions(0, 1), 0.0, 1e-10);
        EXPECT_NEAR(positions(1, 1), 0.0, 1e-10);
        EXPECT_NEAR(forces(0, 1), 0.1 / 2.01, 1e-9);
        EXPECT_NEAR(forces(1, 1), 0.1 / 2.01, 1e-9);
    }

    /// A coupling that hands out D only as the solve asks for it, with NaN wherever the solve
    /// has not asked: a read of an entry it did not cover shows in the result.
    class LazyCoupling final : public ContactCoupling {
    public:
        explicit LazyCoupling(const MatX& full)
            : m_full(full)
            , m_diagonal(full.diagonal())
            , m_row_of(static_cast<std::size_t>(full.rows()), -1)
            , m_columns(MatX::Constant(full.rows(), full.rows(), std::nan("")))
        {
        }
        const VecX& diagonal() const override { return m_diagonal; }
        int cover(Index c) override
        {
            int& row = m_row_of[static_cast<std::size_t>(c)];
            if (row < 0) {
                row = static_cast<int>(m_rows.size());
                m_rows.push_back(c);
                for (std::size_t p = 0; p < m_cols.size(); ++p)
                    m_columns(row, static_cast<Index>(p)) = m_full(c, m_cols[p]);
            }
            return row;
        }
        const double* column(Index d) override
        {
            for (std::size_t p = 0; p < m_cols.size(); ++p)
                if (m_cols[p] == d)
                    return m_columns.col(static_cast<Index>(p)).data();
            const Index p = static_cast<Index>(m_cols.size());
            m_cols.push_back(d);
            for (std::size_t r = 0; r < m_rows.size(); ++r)
                m_columns(static_cast<Index>(r), p) = m_full(m_rows[r], d);
            return m_columns.col(p).data();
        }
        void displace(const Eigen::Ref<const MatX3>& free, const Eigen::Ref<const MatX3>& forces,
            const std::vector<char>* keep, Eigen::Ref<MatX3> positions) override
        {
            for (Index c = 0; c < m_full.rows(); ++c)
                if (keep == nullptr || !(*keep)[static_cast<std::size_t>(c)])
                    positions.row(c) = free.row(c) + m_full.row(c) * forces;
        }
        std::size_t columns() const { return m_cols.size(); }

    private:
        MatX m_full;
        VecX m_diagonal;
        std::vector<int> m_row_of;
        std::vector<Index> m_rows, m_cols;
        MatX m_columns;
    };

    /// 12 nodes of a bar-like body (D = 1 + 0.05 I + a little decay with distance) along x,
    /// under a tilted plane: some start behind it, some in front, and pushing the ones behind
    /// lifts the others.
    struct TiltedBar {
        static constexpr Index m = 12;
        MatX coupling { m, m };
        PlaneCollider plane { Vec3::Zero(), Vec3(0.1, 1.0, 0.0).normalized(), 0.3 };
        std::vector<PlaneCollider> planes;
        std::vector<ContactPair> pairs;
        MatX3 free { m, 3 }, start { m, 3 };
        TiltedBar()
        {
            for (Index i = 0; i < m; ++i)
                for (Index j = 0; j < m; ++j)
                    coupling(i, j) = 1.0 / (1.0 + 0.1 * std::abs(static_cast<double>(i - j)))
                        + (i == j ? 0.05 : 0.0);
            plane.compliance = 0.1;
            planes.push_back(plane);
            for (Index i = 0; i < m; ++i) {
                pairs.push_back(ContactPair { static_cast<int>(i), 0 });
                const double x = 0.1 * static_cast<double>(i);
                free.row(i) << x + 0.01, 0.02 * std::sin(3.0 * x) - 0.005, 0.0;
                start.row(i) << x, 0.01, 0.0;
            }
        }
        /// The solve on `coupling` (the dense one if null).
        ContactSolveResult solve(const ContactSettings& settings, MatX3& forces, MatX3& positions,
            ContactCoupling* lazy = nullptr) const
        {
            DenseContactCoupling dense(coupling);
            return solve_plane_contacts(lazy != nullptr ? *lazy : dense, planes, pairs, free, start,
                forces, positions, settings);
        }
    };

    TEST(PlaneContact, SolveReadsOnlyTheCouplingItAsksFor)
    {
        // The solve that gets D column by column must equal the dense one and ask only for the
        // columns of contacts that push.
        const TiltedBar bar;
        const Index m = TiltedBar::m;
        ContactSettings settings;
        settings.max_sweeps = 500;
        settings.tolerance = 1e-13;
        MatX3 dense_forces = MatX3::Zero(m, 3), dense_positions(m, 3);
        bar.solve(settings, dense_forces, dense_positions);
        LazyCoupling lazy(bar.coupling);
        MatX3 forces = MatX3::Zero(m, 3), positions(m, 3);
        bar.solve(settings, forces, positions, &lazy);
        ASSERT_TRUE(forces.allFinite() && positions.allFinite());
        EXPECT_LT((forces - dense_forces).cwiseAbs().maxCoeff(), 1e-12);
        EXPECT_LT((positions - dense_positions).cwiseAbs().maxCoeff(), 1e-12);
        Index pushing = 0;
        for (Index i = 0; i < m; ++i)
            pushing += forces.row(i).squaredNorm() > 0.0 ? 1 : 0;
        EXPECT_GT(pushing, 0);
        EXPECT_LT(pushing, m);
        EXPECT_LE(lazy.columns(), static_cast<std::size_t>(m - 1));
        // Every contact ends on or in front of its plane (up to its compliance).
        for (Index i = 0; i < m; ++i)
            EXPECT_GT(bar.plane.normal.dot(positions.row(i).transpose()), -0.1 * 0.005) << i;
    }

    TEST(PlaneContact, SubspaceStepsReachTheSameConditionsInFewerSweeps)
    {
        // 16 points of a stiff body (D nearly all alike: 1 + 0.02 I + a slow decay), pressed
        // into the ground and drawn along it by different amounts, so that some stick and some
        // slip: the subspace steps (docs/method.md, "Subspace steps") must give the forces
        // the plain sweeps give, meet the Signorini-Coulomb conditions, and take far fewer
        // sweeps.
        constexpr Index m = 16;
        MatX coupling(m, m);
        for (Index i = 0; i < m; ++i)
            for (Index j = 0; j < m; ++j)
                coupling(i, j) = 1.0 / (1.0 + 0.02 * std::abs(static_cast<double>(i - j)))
                    + (i == j ? 0.02 : 0.0);
        PlaneCollider plane { Vec3::Zero(), Vec3::UnitY(), 0.5 };
        plane.compliance = 0.1;
        const std::vector<PlaneCollider> planes { plane };
        std::vector<ContactPair> pairs;
        MatX3 free(m, 3), start(m, 3);
        for (Index i = 0; i < m; ++i) {
            pairs.push_back(ContactPair { static_cast<int>(i), 0 });
            const double x = 0.1 * static_cast<double>(i);
            start.row(i) << x, 0.0, 0.0;
            free.row(i) << x + 0.00004 * static_cast<double>(i * i), -0.01 - 0.002 * std::cos(x),
                0.0;
        }
        ContactSettings settings;
        settings.max_sweeps = 100000;
        settings.tolerance = 1e-13;
        settings.subspace_every = 0;
        MatX3 plain_forces = MatX3::Zero(m, 3), plain_positions(m, 3);
        const ContactSolveResult plain = solve_dense(
            coupling, planes, pairs, free, start, plain_forces, plain_positions, settings);
        settings.subspace_every = 4;
        MatX3 forces = MatX3::Zero(m, 3), positions(m, 3);
        const ContactSolveResult stepped
            = solve_dense(coupling, planes, pairs, free, start, forces, positions, settings);
        ASSERT_LE(plain.last_change, settings.tolerance);
        ASSERT_LE(stepped.last_change, settings.tolerance);
        const double scale = plain_forces.cwiseAbs().maxCoeff();
        ASSERT_GT(scale, 0.0);
        EXPECT_LT((forces - plain_forces).cwiseAbs().maxCoeff(), 1e-9 * scale);
        EXPECT_LT(stepped.sweeps * 4, plain.sweeps)
            << stepped.sweeps << " against " << plain.sweeps;
        int sticking = 0;
        int slipping = 0;
        int clear = 0;
        for (Index i = 0; i < m; ++i) {
            const Vec3 f = forces.row(i).transpose();
            const double eps = plane.compliance * coupling(i, i);
            const Vec3 at = positions.row(i).transpose() + eps * f; // where the conditions hold
            const double f_n = f.y();
            const double f_t = std::hypot(f.x(), f.z());
            EXPECT_GE(f_n, 0.0) << i;
            if (f_n == 0.0) { // clear of the plane, no force
                EXPECT_GE(at.y(), 0.0) << i;
                EXPECT_EQ(f.squaredNorm(), 0.0) << i;
                ++clear;
                continue;
            }
            EXPECT_NEAR(at.y(), 0.0, 1e-10) << i; // pressed: on the plane
            EXPECT_LE(f_t, 0.5 * f_n * (1.0 + 1e-9)) << i;
            const double moved = std::hypot(at.x() - start(i, 0), at.z() - start(i, 2));
            if (f_t < 0.5 * f_n * (1.0 - 1e-6)) {
                ++sticking;
                EXPECT_LT(moved, 1e-10) << i; // it sticks where it started
            } else {
                ++slipping;
                EXPECT_GT(moved, 1e-10) << i; // it slides, against its force
                EXPECT_LT(f.x() * (at.x() - start(i, 0)) + f.z() * (at.z() - start(i, 2)), 0.0)
                    << i;
            }
        }
        EXPECT_GT(sticking, 0);
        EXPECT_GT(slipping, 0);
        EXPECT_LT(clear, m / 4); // most are pressed (2 of the 16 lift off)
    }

    TEST(PlaneContact, CappedSolveWithoutOutsidePositionsKeepsItsForces)
    {
        // The tilted bar, its sweeps cut to 1 so that they run out: without the last
        // pass over the contacts outside the working set the forces and the working set's
        // positions must be those of the solve with it, bit for bit, and the others keep the
        // positions of the solve's start (x_free + D f for the warm start, here no force).
        const TiltedBar bar;
        const Index m = TiltedBar::m;
        ContactSettings settings;
        settings.max_sweeps = 1;
        settings.tolerance = 1e-13;
        MatX3 all_forces = MatX3::Zero(m, 3), all_positions(m, 3);
        const ContactSolveResult all = bar.solve(settings, all_forces, all_positions);
        ASSERT_GT(all.last_change, settings.tolerance); // the sweeps ran out
        settings.outside_positions = false;
        MatX3 forces = MatX3::Zero(m, 3), positions = MatX3::Constant(m, 3, 7.0);
        bar.solve(settings, forces, positions);
        EXPECT_EQ(forces, all_forces);
        Index working = 0;
        for (Index i = 0; i < m; ++i) {
            const bool in_set = forces.row(i).squaredNorm() > 0.0
                || !(bar.plane.normal.dot(bar.free.row(i).transpose()) > 0.0);
            if (in_set) {
                ++working;
                EXPECT_EQ(positions.row(i), all_positions.row(i)) << i;
            } else {
                EXPECT_EQ(positions.row(i), bar.free.row(i)) << i;
            }
        }
        EXPECT_GT(working, 0);
        EXPECT_LT(working, m);
    }

    /// A 0.3 m grid cube, the identity basis, stiff enough to stay nearly rigid.
    struct Cube {
        BakeData bake;
        Model model;
        explicit Cube(double youngs_modulus = 1e6)
            : bake(test::make_identity_bake(grid()))
            , model(bake, material(youngs_modulus), options())
        {
        }
        static test::GridTetOptions grid()
        {
            test::GridTetOptions g;
            g.nx = g.ny = g.nz = 3;
            g.max_corner = Vec3(0.3, 0.3, 0.3);
            return g;
        }
        static Material material(double e)
        {
            Material m;
            m.youngs_modulus = e;
            m.poisson_ratio = 0.3;
            return m;
        }
        static ModelOptions options()
        {
            ModelOptions o;
            o.time_step = dt;
            return o;
        }
    };

    /// Mass-weighted mean of column `axis` of positions - rest (the centre of mass shift).
    double centre_shift(const Model& model, const MatX3& positions, int axis)
    {
        const VecX& m = model.masses();
        return m.dot(positions.col(axis) - model.rest_positions().col(axis)) / m.sum();
    }

    State run(PdSolver& solver, const Model& model, State state, int steps, double* deepest)
    {
        State next;
        for (int s = 0; s < steps; ++s) {
            solver.step(state, next);
            std::swap(state, next);
            if (deepest)
                *deepest = std::max(*deepest, solver.last_report().max_penetration);
        }
        return state;
    }

    TEST(PlaneContact, DroppedCubeComesToRestOnTheGround)
    {
        const Cube cube;
        SolverOptions options;
        options.planes = { PlaneCollider { Vec3(0.0, -0.05, 0.0), Vec3::UnitY(), 0.5 } };
        PdSolver reduced = semi_reduced_solver(cube.model, options);
        PdSolver full = full_solver(cube.model, options);
        for (PdSolver* solver :
            { static_cast<PdSolver*>(&reduced), static_cast<PdSolver*>(&full) }) {
            double deepest = 0.0;
            const State end = run(*solver, cube.model, State::at_rest(cube.model), 90, &deepest);
            // It fell 0.05 m and lies on the plane: lowest node on it, nothing moving.
            const double lowest = end.positions.col(1).minCoeff();
            EXPECT_NEAR(lowest, -0.05, 1e-6);
            EXPECT_LT(deepest, 1e-6);
            EXPECT_LT(end.velocities.cwiseAbs().maxCoeff(), 1e-3);
            EXPECT_GT(solver->last_report().active_contacts, 0);
            // Next to no horizontal drift of the centre of mass: friction holds the base while
            // the sides bulge (the structured grid's tets are not symmetric, so the bulge is
            // not either: 1.5e-5 m measured on the 0.3 m cube).
            EXPECT_LT(std::abs(centre_shift(cube.model, end.positions, 0)), 1e-4);
            EXPECT_LT(std::abs(centre_shift(cube.model, end.positions, 2)), 1e-4);
        }
    }

    /// One step of `solver` with the contact stage and `contacts` (body 0 is the solver's).
    void step_with_contacts(PdSolver& solver, ContactStage& stage, const State& in, State& out,
        const BodyContacts& contacts)
    {
        solver.begin_step(in, out);
        const std::vector<ContactBodyState> views { { &solver, &in.positions, &in.positions } };
        stage.begin_step(views, contacts);
        bool last = false;
        for (int i = 0; !last; ++i) {
            last = solver.is_last_iteration(i);
            solver.iterate(i);
            stage.solve();
            solver.finish_iteration(i, last);
        }
        stage.end_step();
        solver.end_step();
    }

    TEST(PlaneContact, NodeContactsActLikeTheGround)
    {
        // The same ground given to the contact stage as one contact per boundary node (a term
        // of weight 1, the plane's point), set before every step as the collision pipeline
        // does, gives the same fall and rest as the ground plane.
        const Cube cube;
        const PlaneCollider ground { Vec3(0.0, -0.05, 0.0), Vec3::UnitY(), 0.5 };
        // Angular momentum as the integrator gives it: the default keeps it for a body without
        // contact candidates, which the plane solver is until it nears the ground and the node
        // solver, given its contacts in every step, never is.
        SolverOptions with_plane;
        with_plane.planes = { ground };
        with_plane.angular_momentum = AngularMomentum::integrator;
        PdSolver plane_solver = semi_reduced_solver(cube.model, with_plane);
        SolverOptions hard; // the same hard contact as the plane
        hard.node_contact_compliance = 0.0;
        hard.angular_momentum = AngularMomentum::integrator;
        PdSolver node_solver = semi_reduced_solver(cube.model, hard);
        const std::vector<int> boundary = boundary_nodes(cube.model.tets(), cube.model.num_nodes());
        State a = State::at_rest(cube.model), b = a, next;
        ContactStage stage(1);
        BodyContacts contacts;
        for (const int node : boundary) {
            contacts.terms.push_back(ContactTerm { 0, node, 1.0 });
            contacts.close(ground);
        }
        double deepest = 0.0;
        for (int s = 0; s < 60; ++s) {
            plane_solver.step(a, next);
            std::swap(a, next);
            step_with_contacts(node_solver, stage, b, next, contacts);
            std::swap(b, next);
            deepest = std::max(deepest, node_solver.last_report().max_penetration);
        }
        EXPECT_LT((a.positions - b.positions).cwiseAbs().maxCoeff(), 1e-6);
        EXPECT_NEAR(b.positions.col(1).minCoeff(), -0.05, 1e-6);
        EXPECT_LT(deepest, 1e-6);
        EXPECT_GT(node_solver.last_report().active_contacts, 0);
        // Contacts hold for one step: without new ones the cube falls through.
        step_with_contacts(node_solver, stage, b, next, BodyContacts {});
        EXPECT_EQ(node_solver.last_report().contacts, 0);
        BodyContacts bad;
        bad.terms.push_back(ContactTerm { 1, 0, 1.0 }); // no body 1
        bad.close(ground);
        EXPECT_THROW(step_with_contacts(node_solver, stage, b, next, bad), Error);
    }

    TEST(PlaneContact, NodeSpaceResponsesMatchTheReducedSolves)
    {
        // A reduced body's node-space responses (read from B S^-1) against the triangular solves
        // of its reduced system: z_j = S^-1 b_j^T, node i's motion b_i z_j, and the node
        // positions at a displaced solution. A full-space body's are its responses themselves.
        const BakeData& bake = test::shipped_cube_bake();
        const Model model(bake, Material {}, ModelOptions {});
        const SparseRowMatrix& basis = model.basis();
        PdSolver solver = semi_reduced_solver(model);
        ContactResponse& response = solver.contact_response();
        ASSERT_TRUE(response.node_space());
        response.begin_contacts();
        const Index n = model.num_nodes(), k = model.num_columns();
        double scale = 0.0; // the largest |z_j| entry, for the tolerances
        for (Index j = 0; j < n; ++j) {
            VecX expected = VecX::Zero(k);
            for (SparseRowMatrix::InnerIterator it(basis, j); it; ++it)
                expected(it.index()) = it.value();
            model.reduced_system().solveInPlace(expected);
            scale = std::max(scale, expected.cwiseAbs().maxCoeff());
            const VecX z = response.node_response(static_cast<int>(j));
            EXPECT_LT((z - expected).cwiseAbs().maxCoeff(), 1e-9 * scale) << "node " << j;
            const VecX moved = response.nodal_response(static_cast<int>(j));
            ASSERT_EQ(moved.size(), n);
            for (Index i = 0; i < n; ++i) {
                ASSERT_NEAR(moved(i), response.apply(static_cast<int>(i), expected), 1e-9 * scale)
                    << "node " << i << " by node " << j;
            }
            // D is symmetric: node j moves node i as node i moves node j.
            if (j > 0) {
                EXPECT_NEAR(moved(0), response.nodal_response(0)(j), 1e-9 * scale);
            }
        }
        MatX3 displacement(k, 3);
        for (Index r = 0; r < k; ++r)
            displacement.row(r) = Eigen::RowVector3d(0.01 * r, -0.02, 0.005 * (r % 3));
        MatX3 displaced(n, 3);
        response.displaced_positions(displacement, displaced);
        for (Index i = 0; i < n; ++i) {
            Vec3 expected = response.node_position(static_cast<int>(i));
            for (int c = 0; c < 3; ++c)
                expected(c) += response.apply(static_cast<int>(i), displacement.col(c));
            EXPECT_LT((displaced.row(i).transpose() - expected).norm(), 1e-12) << "node " << i;
        }
        PdSolver full = full_solver(model);
        ContactResponse& full_response = full.contact_response();
        EXPECT_FALSE(full_response.node_space());
        full_response.begin_contacts();
        const VecX z = full_response.node_response(3);
        EXPECT_EQ((full_response.nodal_response(3) - z).cwiseAbs().maxCoeff(), 0.0);
    }

    TEST(PlaneContact, SelfContactsOfReducedBodiesAreNeverStifferThanTheFullDiagonal)
    {
        // A self contact pulls two nodes on opposite sides of the baked cube 1 cm towards each
        // other. A reduced body moves them apart only through its few handles, so its own
        // coupling W_cc is small and would take a large force; the stage's compliance floor, the
        // full-space system's diagonal bound sum_t w_t^2 / A_tt, caps the force at 1 cm over that
        // bound. A full-space body has the local compliance in W already: no floor there.
        const BakeData& bake = test::shipped_cube_bake();
        const Model model(bake, Material {}, ModelOptions {});
        const MatX3& rest = model.rest_positions();
        Index low = 0, high = 0;
        for (Index i = 0; i < model.num_nodes(); ++i) {
            low = rest(i, 0) < rest(low, 0) ? i : low;
            high = rest(i, 0) > rest(high, 0) ? i : high;
        }
        const double depth = 0.01;
        const Eigen::SparseMatrix<double>& system = model.full_system();
        const double floor = 1.0 / system.coeff(high, high) + 1.0 / system.coeff(low, low);
        SolverOptions options;
        options.gravity = Vec3::Zero();
        for (const SolverKind kind : { SolverKind::semi_reduced, SolverKind::full }) {
            double pull[2] = {};
            for (const bool is_self : { false, true }) {
                // r = x_high - x_low along x, held at most its rest length less 1 cm.
                BodyContacts contacts;
                contacts.terms.push_back(ContactTerm { 0, static_cast<int>(high), 1.0 });
                contacts.terms.push_back(ContactTerm { 0, static_cast<int>(low), -1.0 });
                PlaneCollider plane;
                plane.normal = -Vec3::UnitX();
                plane.point = (rest.row(high) - rest.row(low)).transpose() + depth * plane.normal;
                plane.friction = 0.0;
                contacts.close(plane, -1, is_self);
                auto solver = make_solver(kind, model, options);
                ContactStage stage(1);
                State out;
                step_with_contacts(*solver, stage, State::at_rest(model), out, contacts);
                pull[is_self ? 1 : 0] = -stage.forces()(0, 0);
            }
            const std::string name = kind == SolverKind::full ? "full" : "semi";
            EXPECT_GT(pull[0], 0.0) << name;
            if (kind == SolverKind::full) {
                EXPECT_EQ(pull[1], pull[0]); // no floor in full space
            } else {
                EXPECT_LE(pull[1] * floor, depth * (1.0 + 1e-9)) << name;
                EXPECT_LT(pull[1], 0.5 * pull[0]) << name; // the floor acts
            }
        }
    }

    TEST(PlaneContact, SlidingCubeDeceleratesByCoulombFriction)
    {
        // A cube resting on the plane, pushed along x at 1 m/s: Coulomb friction decelerates it
        // at mu g, so it stops after v0 / (mu g) s having slid v0^2 / (2 mu g) (rigid body).
        const Cube cube;
        const double mu = 0.4, v0 = 1.0, g = 9.81;
        SolverOptions options;
        options.planes = { PlaneCollider { Vec3::Zero(), Vec3::UnitY(), mu } };
        for (const bool frictionless : { false, true }) {
            options.planes[0].friction = frictionless ? 0.0 : mu;
            PdSolver solver = semi_reduced_solver(cube.model, options);
            State start = State::at_rest(cube.model);
            start.velocities.col(0).setConstant(v0);
            const int steps = 30; // 0.5 s, after the stop at 0.255 s
            double deepest = 0.0;
            const State end = run(solver, cube.model, start, steps, &deepest);
            const double slid = centre_shift(cube.model, end.positions, 0);
            if (frictionless) {
                EXPECT_NEAR(slid, v0 * steps * dt, 1e-6);
            } else {
                const double expected = v0 * v0 / (2.0 * mu * g);
                EXPECT_NEAR(slid, expected, 0.1 * expected);
                EXPECT_LT(end.velocities.col(0).cwiseAbs().maxCoeff(), 1e-3);
            }
            EXPECT_LT(deepest, 1e-6);
        }
    }

    TEST(PlaneContact, BodyLiftsOffTheGround)
    {
        // Resting on the plane with an upward velocity: contact must not hold it (no adhesion).
        const Cube cube;
        SolverOptions options;
        options.planes = { PlaneCollider { Vec3::Zero(), Vec3::UnitY(), 0.8 } };
        for (const bool reduced_solver : { true, false }) {
            std::unique_ptr<PdSolver> solver;
            if (reduced_solver)
                solver = make_solver(SolverKind::semi_reduced, cube.model, options);
            else
                solver = make_solver(SolverKind::full, cube.model, options);
            State start = State::at_rest(cube.model);
            start.velocities.col(1).setConstant(2.0);
            const State end = run(*solver, cube.model, start, 6, nullptr);
            // Ballistic implicit Euler: y shift = h sum_{i=1..6} (v0 - i h g).
            double expected = 0.0;
            for (int i = 1; i <= 6; ++i)
                expected += dt * (2.0 - i * dt * 9.81);
            const double lifted
                = (end.positions.col(1) - cube.model.rest_positions().col(1)).minCoeff();
            EXPECT_NEAR(lifted, expected, 1e-6) << (reduced_solver ? "reduced" : "full");
        }
    }

} // namespace
} // namespace mat
