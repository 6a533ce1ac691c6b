#pragma once
// The one threading model: TBB. set_threads() is the one place that limits it; every parallel
// loop in the project goes through TBB, and its results must not depend on the thread count.
// The OpenBLAS under CHOLMOD keeps its own threads (one per core, or OPENBLAS_NUM_THREADS):
// limiting it here too would make the factorizations' last bits depend on --threads (measured:
// HarmonicWeights.ResultDoesNotDependOnThreadCount fails), so it is left to the environment.

namespace mat {

/// Limits TBB to n worker threads for the rest of the process (n >= 1). 0 means all cores.
void set_threads(int n);

/// The thread count currently allowed.
int thread_count();

} // namespace mat
