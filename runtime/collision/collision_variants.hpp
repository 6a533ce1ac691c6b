#pragma once
// Variants of the collision pipeline (docs/method.md, section 4) kept only to compare with it in
// tests and benchmarks: each gives the same contacts, or bounds that still enclose the surface,
// at a different cost. The production pipeline always uses the defaults; a test or benchmark
// sets others through CollisionWorld::set_variants_for_comparison.

namespace mat {

/// Comparison-only switches of the collision pipeline; the defaults are the production choices.
struct CollisionVariants {
    /// Exact primitive test on every pair instead of the spatial hash (the reference code's
    /// broad phase; phase 3).
    bool all_pairs = false;
    /// Object-level culling (phase 2); false: every body is hashed and every pair of bodies
    /// goes on (the result is the same).
    bool object_culling = true;
    /// With RadiusUpdate::bound: the exact per-vertex increments from the node positions even
    /// when the state has q (tighter and, once the pairs they save are counted, faster); false:
    /// the handle bound from q when the state has it (phase 1).
    bool bounds_from_positions = true;
};

} // namespace mat
