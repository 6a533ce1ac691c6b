#pragma once
// Hyper-reduced projective dynamics (Brandt et al. 2018, "Hyper-reduced projective dynamics"):
// the semi-reduced solver with the local step on a sample of the tets only, and the right-hand
// side of the reduced global step fitted from the samples' projections: a local stage
// (SampledLocalStage) composed with the reduced global step (make_solver, solver.hpp).
//
// The semi-reduced right-hand side needs B^T r, r = sum_e vol_e G_e^T T_e^T over every tet
// (T_e = w_r R_e + w_v V_e + w_l L_e, the weighted projections; local_step.hpp). Here the
// projections are taken to lie in the deformation subspace, T_e / w ~ G_e (X + B q') with
// w = w_r + w_v + w_l (Brandt et al. 2018, section 4: constraint projections restricted to a
// subspace and fitted on sampled constraints), and q' is the least-squares fit on the samples S:
//   H q' = B^T r_S / w - B^T L_S X,   H = B^T L_S B,   L_S = sum_{e in S} vol_e G_e^T G_e.
// Then B^T r ~ w B^T L (X + B q') = w (B^T L X - K H^-1 B^T L_S X) + K H^-1 B^T r_S, K = B^T L B:
// one k x k product per iteration after the samples' local step. With every tet sampled this is
// B^T r exactly (the fit's residual is orthogonal to the subspace), so the solver then equals the
// semi-reduced one; fewer samples trade accuracy for speed. H is regularized by eps I, eps =
// 1e-8 of its mean diagonal (it is singular along translations, which K annihilates too).
//
// Samples: farthest-point sampling of the tet centroids (deterministic), by default four times as
// many as the model has reduced coordinates per axis (4k, at least 256; each tet constrains 3
// directions per axis). Too few samples make the fitted forces non-conservative: a cantilever
// with nu = 0.49 (k = 96, 2304 tets) gains energy at 2k samples, max strain 0.97 against 0.39
// semi-reduced; 4k gives 0.375, 8k 0.32.
// On the 50k-tet creature (k = 580) spinning in free fall, 20 steps: k samples put the surface
// 1.9% of the diagonal (max) off full-space PD, 2k samples 0.011%, 4k 0.0032%, semi-reduced
// 0.0027%.
// A body in contact with others or itself takes 5k by default (automatic_samples, chosen for the
// scene's bodies in runtime/scene/scene_bodies.cpp): a contact pushes at a few surface nodes,
// and tets there that the fit does not sample are strained by it. Forty hyper-reduced runs of
// creatures_collide (k = 292, 2037 tets) went from a median deepest penetration of 14.3 mm and
// strain 3.75 (largest 30.1 mm, 9.18) at 4k without the speculative stop to 1.42 mm and 2.08
// (3.03 mm, 2.76) at 5k with it (docs/method.md, "Hyper-reduced contact").
// The full positions are reconstructed only after the last iteration; the iterations read the
// samples' nodes from q.

#include <memory>
#include <vector>

#include "runtime/pd/local_step.hpp"
#include "runtime/pd/solver.hpp"

namespace mat {

/// The automatic sample count of a model with `columns` reduced coordinates per axis: 4k, or 5k
/// for a body that takes contacts from other bodies or itself (`contacts`), at least 256 (see the
/// file comment).
Index automatic_samples(Index columns, bool contacts);

/// `count` tets by farthest-point sampling of their centroids, from tet 0 (ties: the lowest
/// index), returned in ascending order. `count` is clamped to [1, #tets].
std::vector<int> farthest_point_tets(const Model& model, Index count);

/// The local step over a sample of tets, fitted to the reduced global step's right-hand side.
class SampledLocalStage final : public LocalStage {
public:
    /// `samples`: tets in the local step; 0 = automatic_samples(k, false), clamped to the number
    /// of tets. `reduced` is the global step this stage solves with (it must outlive the stage).
    SampledLocalStage(
        const Model& model, bool exact_projections, Index samples, ReducedGlobalStep& reduced);
    ~SampledLocalStage() override;

    void iterate(const Model& model, int iteration, const Eigen::Ref<const MatX3>& positions,
        const Eigen::Ref<const MatX3>& base, GlobalStep& global, SolverTimings& timings) override;
    bool reads_iterate() const override { return false; }
    Index num_tets() const override { return static_cast<Index>(m_samples.size()); }
    LocalStep& local_step() override { return *m_local; }

    const std::vector<int>& sample_tets() const { return m_samples; }

private:
    ReducedGlobalStep* m_reduced;
    std::vector<int> m_samples; ///< sampled tets, ascending
    std::vector<int> m_sample_nodes; ///< their nodes, ascending
    std::unique_ptr<LocalStep> m_local; ///< over the samples
    std::vector<int> m_row_offsets; ///< #sample nodes + 1: their basis rows (CSR)
    std::vector<int> m_row_columns;
    std::vector<double> m_row_values;
    MatX m_fit_solution; ///< Z = S^-1 K H^-1  k x k
    MatX m_fit_constant; ///< w (B^T L X - K H^-1 B^T L_S X)  k x 3
    MatX3 m_positions; ///< n x 3: rows of the sample nodes are the iterate
    MatX3 m_forces; ///< n x 3: the samples' local step (zero off the sample nodes)
    MatX m_base; ///< B^T base  k x 3, once per step
    MatX3 m_base_rows; ///< the same, row-major
    MatX3 m_q_rows; ///< q  k x 3 row-major
    MatX3 m_sample_rows; ///< y = B^T r_S  k x 3 row-major
    MatX m_sample_rhs; ///< y  k x 3
    MatX m_q_base; ///< S^-1 (B^T base + the fit constant)  k x 3, once per step
    MatX m_q; ///< k x 3
};

} // namespace mat
