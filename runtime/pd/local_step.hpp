#pragma once
// The projective dynamics local step in full space (Bouaziz et al. 2014, section 3;
// docs/method.md, section 3): every tet's deformation gradient is projected onto the strain
// constraint (nearest rotation), the volume constraint (det F clamped) and the strain limit
// (singular values clamped), and the projections are gathered into the global step's right-hand
// side sum_e w_e G_e^T P_e^T. The step uses the vectorized kernel of elastic_term.hpp;
// project_tet is the exact scalar reference it is tested against.

#include <limits>
#include <vector>

#include "common/eigen_types.hpp"
#include "runtime/model.hpp"
#include "runtime/pd/elastic_term.hpp"

namespace mat {

/// The projections of one deformation gradient.
struct TetProjection {
    Mat3 rotation; ///< nearest rotation to F (det +1, also for inverted F)
    Mat3 volume; ///< nearest matrix to F with det in [1 - eps, 1 + eps] (F itself if inside)
    Mat3 limit; ///< U clamp(S, min, max) V^T, S signed (F itself if S is inside)
};

/// F = Ds Dm^-1 of tet `tet`. `positions`  n x 3, `tets`  T x 4, `dm_inverse`  T x 9 row-major.
Mat3 deformation_gradient(const Eigen::Ref<const MatX3>& positions,
    const Eigen::Ref<const MatX4i>& tets, const MatX& dm_inverse, Index tet);

/// Projects F (Bouaziz et al. 2014, eq. 19 for the rotation; section 5.2 for the volume):
/// F = U S V^T with U, V rotations and S signed (an inverted F gets its smallest singular value
/// negated); rotation = U V^T; volume = U D V^T, D the point nearest S with prod D = clamp(det F,
/// 1 - eps, 1 + eps) (Newton on its KKT
/// conditions from a feasible start, then made exact); limit = U clamp(S, min, max) V^T.
TetProjection project_tet(const Mat3& deformation_gradient, double volume_tolerance,
    double strain_limit_min = 0.0,
    double strain_limit_max = std::numeric_limits<double>::infinity());

/// Doubles per slot of the local step's sums: x, y, z and one unused (a corner's share is one
/// vector add).
inline constexpr std::ptrdiff_t local_slot_stride = 4;

/// The local step's sum as it stands after LocalStep::project(): row i of the right-hand side is
/// base_i + the sum of node i's slots, summed in slot order. Lets a consumer of the right-hand
/// side (the reduced step's B^T y) read it node by node without it being written out first.
struct LocalSums {
    const double* base = nullptr; ///< n x 3 row-major (null: slot_sum only)
    const double* sums = nullptr; ///< local_slot_stride doubles per slot
    const int* offsets = nullptr; ///< n + 1: node i's slots are slots[offsets[i] .. offsets[i+1])
    const int* slots = nullptr;

    /// out = the sum of node i's slots.
    void slot_sum(std::ptrdiff_t i, double (&out)[3]) const
    {
        double s0 = 0.0, s1 = 0.0, s2 = 0.0;
        for (int j = offsets[i]; j < offsets[i + 1]; ++j) {
            const double* v = sums + local_slot_stride * slots[j];
            s0 += v[0];
            s1 += v[1];
            s2 += v[2];
        }
        out[0] = s0;
        out[1] = s1;
        out[2] = s2;
    }
    /// out = row i of the right-hand side.
    void row(std::ptrdiff_t i, double (&out)[3]) const
    {
        slot_sum(i, out);
        out[0] += base[3 * i];
        out[1] += base[3 * i + 1];
        out[2] += base[3 * i + 2];
    }
};

/// Preallocated storage for the local step of one model: a step allocates nothing.
///
/// Layout: tets in blocks of projection_lanes consecutive (Morton-ordered) tets, each block with
/// its node indices, Dm^-1 and rest volumes in structure-of-arrays form. Consecutive blocks form
/// chunks (their number depends on the model only). A chunk adds its tets' contributions into
/// slots of its own, one per node it touches, and the chunks run in parallel; each node then sums
/// its slots in chunk order. The order of every addition is fixed by the model, so the result
/// does not depend on the thread count, and one step has two parallel loops, not one per color.
class LocalStep {
public:
    /// `exact`: the projections' decomposition (ProjectionParams::exact).
    explicit LocalStep(const Model& model, bool exact = true);
    /// The local step over the tets `tets` only (distinct indices, ascending for locality; the
    /// hyper-reduced solver's samples): the sums then run over them.
    LocalStep(const Model& model, bool exact, const std::vector<int>& tets);

    /// rhs = sum_e vol_e G_e^T (2 mu R_e + lambda V_e + w_limit L_e)^T  n x 3 at
    /// `positions`  n x 3 (the weighted constraint projections, Bouaziz et al. 2014 eq. 13
    /// right-hand side). `rhs` must be n x 3. Each tet's last right singular vectors are kept as
    /// the next call's warm start.
    void compute(
        const Model& model, const Eigen::Ref<const MatX3>& positions, Eigen::Ref<MatX3> rhs);
    /// The same sum written to the rows of the nodes the tets touch only (the other rows of `rhs`
    /// are left as they are): for a subset of the tets, no work per step on the other nodes.
    void compute_touched(
        const Model& model, const Eigen::Ref<const MatX3>& positions, Eigen::Ref<MatX3> rhs);
    /// The same sum added to `rhs` (n x 3) instead of replacing it.
    void accumulate(
        const Model& model, const Eigen::Ref<const MatX3>& positions, Eigen::Ref<MatX3> rhs);
    /// rhs = base + the same sum (`base`, `rhs`  n x 3, distinct): saves a copy per iteration.
    void assemble(const Model& model, const Eigen::Ref<const MatX3>& positions,
        const Eigen::Ref<const MatX3>& base, Eigen::Ref<MatX3> rhs);

    /// The projections and the chunks' slot sums only: rhs = base + the sum is then read
    /// through sums(base) (`base`  n x 3 contiguous, kept alive by the caller), the same values
    /// as assemble() writes.
    void project(const Model& model, const Eigen::Ref<const MatX3>& positions);
    LocalSums sums(const double* base) const
    {
        return { base, m_slot_sums.data(), m_node_slot_offsets.data(), m_node_slots.data() };
    }

    /// With `on`, project() also sums the elastic energy at the positions it projects (a few
    /// operations per tet): sum_e vol_e 1/2 sum_c w_c ||F_e - P_c(F_e)||^2 over its tets.
    void set_energy(bool on) { m_with_energy = on; }
    bool energy_on() const { return m_with_energy; }
    /// That energy at the last project() (only with set_energy(true)).
    double energy() const;

    /// Number of chunks (for the benchmark's report).
    int num_chunks() const { return static_cast<int>(m_chunk_blocks.size()) - 1; }

    /// The warm start of the next projections (each tet's last rotation, a unit quaternion as 4
    /// floats per lane), flattened: what a checkpoint keeps so that a resumed run projects the
    /// same way (runtime/output/checkpoint.hpp).
    std::vector<float> warm_start() const;
    /// Restores a warm_start() of a step of the same model; throws mat::Error on a size mismatch.
    void set_warm_start(const std::vector<float>& warm);

private:
    struct alignas(64) Block {
        double dm_inverse[9][projection_lanes]; ///< Dm^-1 (r, c) at [3 r + c]
        double volume[projection_lanes]; ///< rest volume, 0 on padding lanes
        int nodes[4][projection_lanes]; ///< corner nodes; padding lanes repeat lane 0
        int slots[4][projection_lanes]; ///< the corners' slots in the block's chunk
    };
    /// rhs = (base or rhs) + the sum; `base` null means rhs itself. `touched_only`: rhs = the sum
    /// on the touched nodes' rows only.
    void run(const Model& model, const Eigen::Ref<const MatX3>& positions, const double* base,
        Eigen::Ref<MatX3> rhs, bool touched_only = false);

    Index m_num_tets = 0;
    bool m_exact = true;
    std::vector<Block> m_blocks; ///< in tet order
    std::vector<int> m_chunk_blocks; ///< #chunks + 1: chunk c is blocks [c_c, c_c+1)
    std::vector<int> m_chunk_slots; ///< #chunks + 1: chunk c owns slots [s_c, s_c+1)
    std::vector<int> m_node_slot_offsets; ///< n + 1: node i's slots (CSR)
    std::vector<int> m_node_slots; ///< slots of each node, in chunk order
    std::vector<int> m_touched; ///< nodes with at least one slot, ascending
    std::vector<double> m_slot_sums; ///< 3 per slot
    bool m_with_energy = false;
    std::vector<double> m_chunk_energy; ///< #chunks: each chunk's elastic energy
    /// Per block: V of the last projection (the warm start).
    std::vector<RotationBlock> m_warm;
};

} // namespace mat
