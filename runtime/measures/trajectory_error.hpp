#pragma once
// How far a run's trajectory is from a reference run of the same scene: per saved frame, the
// root-mean-square and the largest distance |x - x_ref| over every surface vertex of every
// object, as a percentage of the reference's rest bounding-box diagonal (all objects together).
// Both runs are trajectory caches (formats/trajectory_io.hpp, mat-run output format "h5"); they
// must hold the same objects (by name) with the same vertex counts, and the same frame times.

#include <string>
#include <vector>

#include "common/eigen_types.hpp"

namespace mat {

class TrajectoryReader;

struct TrajectoryError {
    double rms_percent = 0.0; ///< max over frames of the per-frame RMS distance, %
    double max_percent = 0.0; ///< max over frames of the per-frame max distance, %
    double diagonal = 0.0; ///< the reference's rest bounding-box diagonal, m
    VecX times; ///< #frames frame times, s
    VecX frame_rms_percent; ///< #frames per-frame RMS distance, %
    VecX frame_max_percent; ///< #frames per-frame max distance, %
};

/// Compares `run` with `reference` frame by frame (one frame of each in memory at a time).
/// Throws mat::Error with one line naming the run's file and the object or frame if the objects,
/// their vertex counts or the frame times differ (times agree to 1e-9 of the run's duration),
/// or if the reference's rest bounding box is a single point.
TrajectoryError trajectory_error(const TrajectoryReader& run, const TrajectoryReader& reference);

/// Checks, before a run, that `reference` can be compared with it: the run's objects `names`
/// with `vertex_counts` surface vertices each (same order), `frame_count` frames (the initial
/// one included). Throws mat::Error with one line naming the reference file otherwise.
void check_reference(const TrajectoryReader& reference, const std::vector<std::string>& names,
    const std::vector<Index>& vertex_counts, Index frame_count);

/// The same on two files.
TrajectoryError trajectory_error(const std::string& run_path, const std::string& reference_path);

} // namespace mat
