#pragma once
// The checkpoint of a run: OUTDIR/checkpoint.h5, rewritten atomically every --checkpoint-every
// frames and at the last frame, from which `mat-run --resume` continues (docs/mat-run.md,
// "Outputs and statistics"). It holds the simulation's snapshot (runtime/simulation.hpp,
// SimulationSnapshot) after an output frame, and what the run was made from, to refuse to
// continue another scene, bake or solver.
//
// Layout (HDF5, formats/hdf5_file.hpp):
//   /                 format_name = "medial-elastics-checkpoint", format_version = 1,
//                     frame, steps (int64), scene_hash, bake_hashes (JSON array), solver
//   /bodies/<b>/      one group per object, in the scene's order (b = 0, 1, ...); attributes
//                     asleep, slow_steps, moved (int64)
//       positions, velocities       n x 3 float64
//       pin_targets, solver_pin_targets  #pinned x 3 float64
//       q                           k x 3 float64 (a dynamic body of a reduced solver)
//       warm                        #values int32: the local step's warm start, each float's
//                                   bits (exact)
//       contact_used, contact_forces  #used x 2 int32 (node, plane or -1), #used x 3 float64

#include <string>
#include <vector>

#include "runtime/scene/scene.hpp"
#include "runtime/simulation.hpp"

namespace mat {

/// What a run is made from: a resumed run must be made from the same.
struct RunIdentity {
    /// Hash of the scene's JSON (parsed and printed again) without its length (time.frames,
    /// time.duration): a run may be continued for more frames.
    std::string scene_hash;
    std::string bake_hashes; ///< JSON array of the objects' bake file hashes, in scene order
    std::string solver; ///< semi, full or hyper
};

/// The identity of a run of `scene` with `solver` (hashes the scene file and every bake).
RunIdentity run_identity(const Scene& scene, const std::string& solver);

/// Writes the checkpoint `path` atomically: `snapshot`, taken after output frame `frame`.
void write_checkpoint(const std::string& path, const RunIdentity& identity, int frame,
    const SimulationSnapshot& snapshot);

struct Checkpoint {
    int frame = 0;
    SimulationSnapshot snapshot;
};

/// Reads the checkpoint `path`. Throws mat::Error with one line if it is not a checkpoint, or
/// was made from another scene, bake or solver than `identity`.
Checkpoint read_checkpoint(const std::string& path, const RunIdentity& identity);

} // namespace mat
