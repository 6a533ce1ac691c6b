#pragma once
// What the HDF5 fuzz targets do with a file (docs/building.md, Fuzzing): read it as the tools
// do and check what the reader promises. mat::Error is the expected outcome for bad input;
// anything else (a crash, a sanitizer report, another exception, a broken promise) aborts.

#include <string>

namespace mat::fuzz {

/// read_bake(), then: every shape agrees with the others, every index is in range, every
/// number is finite, volumes, masses and radii are positive.
void read_and_check_bake(const std::string& path, const char* target);

/// TrajectoryReader as mat-run --reference uses it: the options, every object's faces and rest
/// positions, and every frame's positions and velocities (at most the first 64 frames).
void read_and_check_trajectory(const std::string& path, const char* target);

} // namespace mat::fuzz
