#pragma once
// Polishing a mesh of a level set: Newton steps that move each vertex onto the zero set of an
// implicit function.

#include <functional>

#include "common/eigen_types.hpp"

namespace mat {

/// Moves each point onto the zero set of f with up to `steps` Newton steps along a central
/// finite-difference gradient, x <- x - f(x) grad f / |grad f|^2. A step is clamped to
/// `max_step` and kept only if it reduces |f|, so points never jump to another sheet.
/// points  #P x 3; returns #P x 3. Runs in parallel (TBB); the result does not depend on the
/// thread count; f must be safe to call concurrently.
MatX3 project_onto_zero_set(const Eigen::Ref<const MatX3>& points,
    const std::function<double(const Vec3&)>& f, int steps, double max_step);

} // namespace mat
