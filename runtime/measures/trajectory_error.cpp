#include "runtime/measures/trajectory_error.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "common/error.hpp"
#include "formats/trajectory_io.hpp"

namespace mat {

namespace {

    /// The diagonal of the bounding box of every object's rest positions.
    double rest_diagonal(const TrajectoryReader& trajectory)
    {
        Box3 box;
        for (Index o = 0; o < trajectory.object_count(); ++o) {
            const MatX3 rest = trajectory.rest_positions(o);
            for (Index v = 0; v < rest.rows(); ++v)
                box.extend(rest.row(v).transpose());
        }
        return box.isEmpty() ? 0.0 : box.diagonal().norm();
    }

} // namespace

TrajectoryError trajectory_error(const TrajectoryReader& run, const TrajectoryReader& reference)
{
    const std::string& file = run.path();
    // Objects: the same names (in any order) with the same vertex counts.
    std::vector<Index> to_reference;
    for (Index o = 0; o < run.object_count(); ++o) {
        const std::string& name = run.object_names()[std::size_t(o)];
        const auto& names = reference.object_names();
        const auto found = std::find(names.begin(), names.end(), name);
        if (found == names.end())
            throw_error("{}: object '{}' is not in the reference {}", file, name, reference.path());
        const Index r = Index(found - names.begin());
        if (run.vertex_count(o) != reference.vertex_count(r))
            throw_error("{}: object '{}' has {} surface vertices, the reference {} has {}", file,
                name, run.vertex_count(o), reference.path(), reference.vertex_count(r));
        to_reference.push_back(r);
    }
    if (run.object_count() != reference.object_count()) {
        for (const std::string& name : reference.object_names())
            if (std::find(run.object_names().begin(), run.object_names().end(), name)
                == run.object_names().end())
                throw_error(
                    "{}: no object '{}' (the reference {} has it)", file, name, reference.path());
    }
    // Frames: the same count and times.
    const Index frames = run.frame_count();
    if (frames != reference.frame_count())
        throw_error("{}: {} frames, the reference {} has {}", file, frames, reference.path(),
            reference.frame_count());
    const double duration
        = frames > 0 ? std::max(std::abs(run.times()(0)), std::abs(run.times()(frames - 1))) : 0.0;
    const double tolerance = 1e-9 * std::max(duration, 1e-12);
    for (Index f = 0; f < frames; ++f)
        if (!(std::abs(run.times()(f) - reference.times()(f)) <= tolerance))
            throw_error("{}: frame {} is at time {} s, the reference {} has it at {} s", file, f,
                run.times()(f), reference.path(), reference.times()(f));

    TrajectoryError result;
    result.diagonal = rest_diagonal(reference);
    if (!(result.diagonal > 0.0) || !std::isfinite(result.diagonal))
        throw_error("{}: the rest bounding box has no extent (diagonal {})", reference.path(),
            result.diagonal);
    result.times = run.times();
    result.frame_rms_percent = VecX::Zero(frames);
    result.frame_max_percent = VecX::Zero(frames);
    Index vertices = 0;
    for (Index o = 0; o < run.object_count(); ++o)
        vertices += run.vertex_count(o);
    const double scale = 100.0 / result.diagonal;
    for (Index f = 0; f < frames; ++f) {
        double sum_squares = 0.0, largest = 0.0;
        for (Index o = 0; o < run.object_count(); ++o) {
            const MatX3 x = run.positions(o, f);
            const MatX3 x_ref = reference.positions(to_reference[std::size_t(o)], f);
            const VecX distances = (x - x_ref).rowwise().norm();
            if (!distances.allFinite())
                throw_error("{}: object '{}', frame {}: positions are not finite", file,
                    run.object_names()[std::size_t(o)], f);
            sum_squares += distances.squaredNorm();
            largest = std::max(largest, distances.size() > 0 ? distances.maxCoeff() : 0.0);
        }
        result.frame_rms_percent(f)
            = scale * (vertices > 0 ? std::sqrt(sum_squares / double(vertices)) : 0.0);
        result.frame_max_percent(f) = scale * largest;
    }
    if (frames > 0) {
        result.rms_percent = result.frame_rms_percent.maxCoeff();
        result.max_percent = result.frame_max_percent.maxCoeff();
    }
    return result;
}

void check_reference(const TrajectoryReader& reference, const std::vector<std::string>& names,
    const std::vector<Index>& vertex_counts, Index frame_count)
{
    MAT_CHECK(names.size() == vertex_counts.size(), "check_reference: {} names, {} counts",
        names.size(), vertex_counts.size());
    const std::string& file = reference.path();
    for (std::size_t o = 0; o < names.size(); ++o) {
        const auto& known = reference.object_names();
        const auto found = std::find(known.begin(), known.end(), names[o]);
        if (found == known.end())
            throw_error("{}: the reference has no object '{}'", file, names[o]);
        const Index count = reference.vertex_count(Index(found - known.begin()));
        if (count != vertex_counts[o])
            throw_error("{}: object '{}' has {} surface vertices in the reference, {} in this run "
                        "(bake both from the same surface)",
                file, names[o], count, vertex_counts[o]);
    }
    if (Index(names.size()) != reference.object_count())
        throw_error("{}: the reference has {} objects, this run {}", file, reference.object_count(),
            names.size());
    if (reference.frame_count() != frame_count)
        throw_error("{}: the reference has {} frames, this run writes {} (the initial one "
                    "included)",
            file, reference.frame_count(), frame_count);
}

TrajectoryError trajectory_error(const std::string& run_path, const std::string& reference_path)
{
    const TrajectoryReader run(run_path);
    const TrajectoryReader reference(reference_path);
    return trajectory_error(run, reference);
}

} // namespace mat
