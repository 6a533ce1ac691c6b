#pragma once
// The projective dynamics global step (Bouaziz et al. 2014, eq. 13), in full space with CHOLMOD
// or reduced to the handle basis (Lan et al. 2020). Both solve the same full-space system
//   A x = b,   A = L_w + M / h^2 + P,   b = M s / h^2 + r + P p
// (r the local step's projections, P the pin weights, p their targets); the reduced one solves
// its Galerkin projection onto x = X + B q. Both also answer how a force at one node moves
// another after the solve (the compliance D of runtime/pd/contact_stage.hpp), for contact.

#include <vector>

#include "common/eigen_types.hpp"
#include "common/error.hpp"
#include "common/sparse_cholesky.hpp"
#include "runtime/model.hpp"
#include "runtime/pd/basis_products.hpp"
#include "runtime/pd/contact_response.hpp"
#include "runtime/pd/response_cache.hpp"

namespace mat {

/// Seconds spent per phase, accumulated over steps.
struct SolverTimings {
    double local = 0.0; ///< local step (projections and their gather)
    double rhs = 0.0; ///< right-hand side: inertia, pins, and B^T y for the reduced solver
    double solve = 0.0; ///< the linear solve (k x k dense or n x n CHOLMOD)
    double reconstruct = 0.0; ///< x = X + B q (reduced) or the copy out (full)
    double contact = 0.0; ///< contact detection, coupling and the contact solve
    /// The accelerated iteration: the energy's inertia and pin terms, Anderson's extrapolation
    /// (the local and global work of a refused iterate's redone iteration counts as theirs).
    double acceleration = 0.0;
    /// --device cuda: the GPU step's kernels and transfers, host wall time (its phases apart
    /// only with DeviceSemiStep::set_profiling; runtime/gpu/device_step.hpp).
    double device = 0.0;
    long steps = 0;
    long iterations = 0;
    long accelerated = 0; ///< extrapolated iterates the safeguard accepted
    long refused = 0; ///< extrapolated iterates it refused (their iteration redone plain)
};

class GlobalStep {
public:
    virtual ~GlobalStep() = default;

    /// Adds this step's iteration-independent terms to the right-hand side `base`  n x 3 (the
    /// solver fills it once per time step with the inertia and pin terms); nothing by default.
    virtual void add_constant_terms(Eigen::Ref<MatX3> base) const { }
    /// Solves with the right-hand side `rhs`  n x 3 (which may be overwritten; it includes the
    /// constant terms) and keeps the solution inside (no contact forces).
    virtual void solve(Eigen::Ref<MatX3> rhs, SolverTimings& timings) = 0;
    /// Whether solve(const LocalSums&) is available: the right-hand side read node by node from
    /// the local step's sums, never written out (a pass over the nodes less per iteration).
    virtual bool takes_local_sums() const { return false; }
    /// The same solve with the right-hand side given as `rhs` (only if takes_local_sums()).
    virtual void solve(const LocalSums& rhs, SolverTimings& timings)
    {
        throw_error("global step: this step needs the right-hand side written out");
    }
    /// How the kept solution answers a contact force (the contact stage's view of this step).
    virtual ContactResponse& contact_response() = 0;
    /// The kept reduced coordinates q  k x 3, or null for a full-space step.
    virtual const MatX* reduced_coordinates() const { return nullptr; }
    /// Replaces the kept reduced coordinates (a reduced step only).
    virtual void set_reduced_coordinates(const Eigen::Ref<const MatX>& q)
    {
        throw_error("global step: a full-space step keeps no reduced coordinates");
    }
    /// Writes the kept solution's positions  n x 3.
    virtual void positions(Eigen::Ref<MatX3> out, SolverTimings& timings) = 0;
    /// The kept solution as one flat, writable vector: q (k x 3, column-major) for a reduced
    /// step, x (n x 3, row-major) for the full one; the accelerated iteration replaces it
    /// (runtime/pd/anderson.hpp).
    virtual Eigen::Map<VecX> solution() = 0;
};

/// Reduced global step: S q = B^T (b - A X), x = X + B q with S = B^T A B prefactored in the
/// model (dense LLT). Up to dense_inverse_limit columns, the step keeps S^-1 itself and a solve
/// is one product of it with the three right-hand sides, in row blocks in parallel: triangular
/// solves are sequential, and on the sample creature (580 columns) took 6% of a step.
class ReducedGlobalStep final : public GlobalStep, public ContactResponse {
public:
    explicit ReducedGlobalStep(const Model& model);
    /// Subtracts A X (the displacement form's shift).
    void add_constant_terms(Eigen::Ref<MatX3> base) const override;
    void solve(Eigen::Ref<MatX3> rhs, SolverTimings& timings) override;
    bool takes_local_sums() const override { return true; }
    void solve(const LocalSums& rhs, SolverTimings& timings) override;
    ContactResponse& contact_response() override { return *this; }
    Index response_size() const override { return m_q.rows(); }
    void begin_contacts() override
    {
        m_cache.begin_step();
        m_nodal_cache.begin_step();
    }
    Eigen::Ref<const VecX> node_response(int node) override;
    /// B z_j, kept in its own budget.
    Eigen::Ref<const VecX> nodal_response(int node) override;
    /// With S^-1 kept, when B S^-1 (n x k) and the n x n node-space responses fit the response
    /// budget: then node_response() and nodal_response() read B S^-1.
    bool node_space() const override { return m_node_space; }
    double apply(int node, const Eigen::Ref<const VecX>& response) const override;
    void add_displacement(const Eigen::Ref<const MatX3>& displacement) override;
    const MatX* reduced_coordinates() const override { return &m_q; }
    void direction(const int* nodes, const double* weights, int count, std::vector<int>& index,
        std::vector<double>& value, Vec3& offset, std::vector<int>& slots) const override;
    Vec3 node_position(int node) const override;
    Rows solution_rows() const override { return { m_q.data(), 1, m_q.rows() }; }
    void displaced_positions(
        const Eigen::Ref<const MatX3>& displacement, Eigen::Ref<MatX3> out) override;
    void positions(Eigen::Ref<MatX3> out, SolverTimings& timings) override;
    Eigen::Map<VecX> solution() override { return Eigen::Map<VecX>(m_q.data(), m_q.size()); }
    /// Solves S q = `rhs`  k x 3 (a right-hand side already reduced, B^T b) and keeps q.
    void solve_reduced(const Eigen::Ref<const MatX>& rhs, SolverTimings& timings);
    /// Replaces the kept solution by `q`  k x 3.
    void set_reduced_coordinates(const Eigen::Ref<const MatX>& q) override;
    /// The basis products the step uses (B^T y, X + B q).
    BasisProducts& products() { return m_products; }

private:
    const Model& m_model;
    BasisProducts m_products;
    MatX3 m_rest_system; ///< A X  n x 3 (constant)
    MatX m_q; ///< k x 3
    MatX3 m_q_rows; ///< k x 3 row-major copy of m_q for the reconstruction
    MatX3 m_displaced_rows; ///< k x 3: displaced_positions()' q
    ResponseCache m_cache; ///< S^-1 b_j^T per node j asked for
    ResponseCache m_nodal_cache; ///< B S^-1 b_j^T per node j asked for (nodal_response)
    /// S^-1 when k <= dense_inverse_limit (else empty: the LLT's solves).
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> m_inverse;
    MatX m_q_columns; ///< k x 3: the right-hand sides, column-major
    /// B S^-1  n x k (node_space()), formed when first asked for; written whole at once, so in
    /// huge pages from 1 MiB up (common/huge_pages.hpp): on small pages its first writes took
    /// more time than its product.
    HugePageBlock m_basis_inverse;
    /// Its transpose, S^-1 B^T  k x n, formed with it: column j is node j's response
    /// S^-1 b_j^T, contiguous (node_response() returns it, where a row of B S^-1 would be
    /// gathered n apart).
    HugePageBlock m_inverse_basis;
    bool m_node_space = false;

    /// m_q = S^-1 m_q_rows.
    void solve_rows();
    /// B S^-1 (node_space() only), with m_inverse_basis: its row j is node j's response, and
    /// D's node-space column j its columns weighted by b_j.
    Eigen::Map<const MatX> basis_inverse();
};

/// Largest reduced system whose inverse ReducedGlobalStep keeps (1500 columns: 18 MB).
inline constexpr Index dense_inverse_limit = 1500;

/// Full-space global step with CHOLMOD (the accuracy reference and speed baseline).
class FullGlobalStep final : public GlobalStep, public ContactResponse {
public:
    /// Factors the model's full system (throws mat::Error if that fails).
    explicit FullGlobalStep(const Model& model);
    void solve(Eigen::Ref<MatX3> rhs, SolverTimings& timings) override;
    ContactResponse& contact_response() override { return *this; }
    Index response_size() const override { return m_x.rows(); }
    void begin_contacts() override { m_cache.begin_step(); }
    Eigen::Ref<const VecX> node_response(int node) override;
    Eigen::Ref<const VecX> nodal_response(int node) override { return node_response(node); }
    /// Its responses are in node space already: the directions are the nodes themselves.
    bool node_space() const override { return false; }
    double apply(int node, const Eigen::Ref<const VecX>& response) const override
    {
        return response(node);
    }
    void add_displacement(const Eigen::Ref<const MatX3>& displacement) override;
    void direction(const int* nodes, const double* weights, int count, std::vector<int>& index,
        std::vector<double>& value, Vec3& offset, std::vector<int>& slots) const override;
    Vec3 node_position(int node) const override { return m_x.row(node).transpose(); }
    Rows solution_rows() const override { return { m_x.data(), 3, 1 }; }
    void displaced_positions(
        const Eigen::Ref<const MatX3>& displacement, Eigen::Ref<MatX3> out) override
    {
        out = m_x + displacement;
    }
    void positions(Eigen::Ref<MatX3> out, SolverTimings& timings) override;
    Eigen::Map<VecX> solution() override { return Eigen::Map<VecX>(m_x.data(), m_x.size()); }

private:
    SparseCholesky m_cholesky;
    MatX3 m_x; ///< n x 3
    ResponseCache m_cache; ///< A^-1 e_j per node j asked for
};

} // namespace mat
