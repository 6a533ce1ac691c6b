#pragma once
// The elastic term of a tet, the local step's projection: corotated (nearest rotation) + volume
// (det F clamped) + strain limits (singular values clamped), all from one SVD per tet, returned
// as their weighted sum (docs/method.md, section 3). The pin term is apart
// (runtime/pd/pin_term.hpp). Vectorized across tets: blocks of `projection_lanes`
// deformation gradients in structure-of-arrays form, branch-free within a block (selects; the
// iteration counts are per block), written as plain loops over lanes that the compiler turns into
// SIMD code.
//
// Per lane, F = U S V^T with U, V rotations and S signed (an inverted F has its smallest singular
// value negative), computed as in McAdams et al. 2011 ("Computing the SVD of 3x3 matrices with
// minimal branching and elementary floating point operations"):
//   1. Jacobi eigen-decomposition of F^T F in float with approximate Givens rotations, V kept as
//      a quaternion, started from a warm start V0 (the last projection's V in a PD solve, or the
//      identity): sweeps on V0^T F^T F V0 until every lane of the block is diagonal to 1e-5
//      (0 to 4 sweeps: none when the warm start already does, one usually suffices);
//   2. in double: V from the normalized quaternion (orthogonal to double precision), one or two
//      more Jacobi sweeps on V^T F^T F V in double (each roughly squares the float stage's
//      error; the second only if some lane is not diagonal to 1e-13 after the first; a sweep
//      whose angles are all tiny uses sin = t, cos = 1 - t^2 / 2, no square root), columns
//      sorted by singular value with conditional swaps that keep det V = +1, and a Givens QR of
//      F V -> U (a rotation) and the signed singular values.
// That is the exact decomposition. The fast one (ProjectionParams::exact false, the solvers'
// default) stops after the float stage: V from its quaternion in double, B = F V, s_i = |b_i|,
// U = B S^-1. Because F = B V^T exactly, U diag(k) V^T is then exact at rest and under rigid
// motion whatever V's error, and otherwise off by about the float stage's angle error (1e-5)
// times the singular values' spread; a block with a flat or collapsed tet (smallest singular
// value below 5% of the largest) or with U's columns farther than 2e-5 from orthogonal (the
// float stage's tolerance bounds the cosines by about sqrt(3) 1e-5; at 1e-5, 9% of the blocks
// of a PD solve fell back for nothing) takes the exact path. In a PD solve its trajectories differ
// from the exact ones by about 1e-7 of the body's size, five orders of magnitude below the reduced
// model's own error. Each stage is a sequence of loops over the lanes, so that the dependent chains
// of separate lanes overlap in the pipeline (one loop per Jacobi rotation rather than one per
// lane). Then the projections, all of the form U diag(.) V^T:
//   rotation  R = U V^T (Bouaziz et al. 2014, eq. 19; nearest rotation, det +1);
//   volume    U D V^T, D nearest to S with prod D = clamp(det F, 1 - eps, 1 + eps) (section 5.2);
//   limit     U clamp(S, min, max) V^T (strain limiting, Bouaziz et al. 2014 section 5.1).
// A block returns the weighted sum w_r R + w_v P_vol + w_l P_lim, written as
// (w_v + w_l) F + U diag(w_r + w_v (d - s) + w_l (c - s)) V^T so that inactive volume and limit
// constraints give F exactly. The double second half keeps a body at rest at rest: with V
// orthogonal to double precision the polar error scales with sigma_i - sigma_j.
// project_tet (local_step.hpp) is the exact scalar reference this kernel is tested against.

#include <limits>

namespace mat {

/// Lanes per block: 32, two AVX-512 registers of floats (four of doubles), so that the float
/// stage's dependent chains (a square root and a division per Jacobi rotation) overlap in pairs.
/// On the 50k-tet creature the local step took 13.0 ms per step at 32 lanes, 13.8 at 16, 13.2
/// at 64 (2 threads, 10 iterations).
inline constexpr int projection_lanes = 32;

/// A block of 3x3 matrices, structure of arrays: m[3 r + c][lane] = M_lane(r, c).
struct alignas(64) MatBlock {
    double m[9][projection_lanes];
};

/// A block of rotations V as unit quaternions (w, x, y, z) in float: the warm start of the
/// Jacobi stage, the right singular vectors of the last projection. Starts as the identity.
struct alignas(64) RotationBlock {
    float q[4][projection_lanes];

    RotationBlock()
    {
        for (int l = 0; l < projection_lanes; ++l) {
            q[0][l] = 1.0f;
            q[1][l] = q[2][l] = q[3][l] = 0.0f;
        }
    }
};

/// Projection settings and the weights of the three projections in the returned sum.
struct ProjectionParams {
    double volume_tolerance = 0.0; ///< eps: det is kept in [1 - eps, 1 + eps], in [0, 1)
    double limit_min = 0.0; ///< strain limits on the singular values, 0 <= min <= 1 <= max
    double limit_max = std::numeric_limits<double>::infinity();
    double rotation_weight = 1.0; ///< w_r
    double volume_weight = 0.0; ///< w_v
    double limit_weight = 0.0; ///< w_l
    /// True: the exact decomposition (double Jacobi sweeps and QR: every projection to ~1e-11).
    /// False: the fast one (float eigenvectors, singular values and U in double from them: exact
    /// at rest and under rigid motion, otherwise accurate to about 1e-5 of the singular values'
    /// spread; flat or collapsed tets still take the exact path). See project_elastic_block.
    bool exact = true;
};

/// target_lane = w_r R(F) + w_v P_vol(F) + w_l P_lim(F) for every lane of `f` (see the file
/// comment). Finite for every finite F, also flat, collapsed or inverted ones. The volume and
/// limit projections are skipped for a block none of whose lanes needs them, and the sweep and
/// Newton counts adapt per block (branches per block, never per lane: a lane's result depends
/// on its neighbours only through how many converging iterations it gets).
void project_elastic_block(const MatBlock& f, const ProjectionParams& params, MatBlock& target);

/// The same, with the Jacobi stage started from `warm` (read, then overwritten with this call's
/// V): in a PD solve, F changes little between iterations and steps, and V not at all under
/// rigid motion, so one sweep usually converges. The sweep counts adapt per block (more sweeps
/// while some lane has not converged), so the accuracy does not depend on the warm start.
/// `energy` (projection_lanes doubles, or null): each lane's constraint energy per unit volume,
/// 1/2 (w_r ||F - R||^2 + w_v ||F - P_vol||^2 + w_l ||F - P_lim||^2).
void project_elastic_block(const MatBlock& f, const ProjectionParams& params, MatBlock& target,
    RotationBlock& warm, double* energy = nullptr);

} // namespace mat
