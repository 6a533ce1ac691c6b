#pragma once
// Anderson acceleration of a fixed-point iteration u <- G(u) (Walker and Ni 2011; applied to
// projective dynamics by Peng et al. 2018, "Anderson acceleration for geometry optimization and
// physics simulation"; docs/method.md, "Accelerated iterations"). With the residuals
// f_i = G(u_i) - u_i and the last m differences dF = [f_{j+1} - f_j], dG = [G(u_{j+1}) - G(u_j)],
// the next iterate is
//   u_{i+1} = G(u_i) - dG theta,   theta = argmin ||f_i - dF theta||^2,
// theta from the m x m normal equations (regularized by 1e-10 of their largest diagonal entry),
// the norm weighted by a positive weight per entry (the solver's: the masses, see
// PdSolver::begin_acceleration).
// The vector is flat (the solver's q  k x 3 or x  n x 3); every pass over it runs in blocks of
// a fixed size, and the dot products sum their blocks' partial sums in block order, so the result
// does not depend on the thread count. No allocation after configure().

#include <vector>

#include "common/eigen_types.hpp"

namespace mat {

/// Largest history window (anderson_window).
inline constexpr int anderson_max_window = 16;

class AndersonAcceleration {
public:
    /// Vectors of `size` doubles, a history of `window` differences (1 .. anderson_max_window),
    /// the least squares weighted by `weights` (size() positive doubles).
    void configure(Index size, int window, const Eigen::Ref<const VecX>& weights);
    Index size() const { return m_size; }
    int window() const { return m_window; }

    /// Starts a new sequence at the iterate `u` (size() doubles): no history.
    void start(const double* u);
    bool started() const { return m_started; }
    /// `g` holds G(u) of the current iterate u; it is overwritten with the next iterate. Returns
    /// true if that is an extrapolation (false: the plain iterate G(u), no history yet).
    bool advance(double* g);
    /// Replaces the current iterate by the last plain iterate G(u_prev) (written to `out`) and
    /// clears the history: the safeguard's fallback.
    void fall_back(double* out);
    /// History length in use (0 .. window).
    int history() const { return m_count; }
    /// |g - u|_W for the current iterate u (the weighted norm of the least squares).
    double residual_norm(const double* g);

private:
    Index m_size = 0;
    int m_window = 0;
    bool m_started = false;
    bool m_has_previous = false; ///< m_f_previous, m_g_previous hold the last residual and G
    int m_count = 0; ///< columns in use
    int m_head = 0; ///< the column the next difference goes to
    VecX m_weights; ///< the norm's weight per entry
    VecX m_u; ///< the current iterate
    VecX m_f; ///< its residual
    VecX m_f_previous;
    VecX m_g_previous;
    MatX m_df; ///< size x window: residual differences (ring)
    MatX m_dg; ///< size x window: G differences (ring)
    MatX m_gram; ///< window x window: dF^T dF
    MatX m_partial; ///< 2 window x blocks: the blocks' partial dot products
    VecX m_rhs; ///< dF^T f
    VecX m_theta;
};

} // namespace mat
