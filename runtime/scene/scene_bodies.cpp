#include "runtime/scene/scene_bodies.hpp"

#include <map>

#include "common/error.hpp"
#include "common/log.hpp"
#include "formats/bake_io.hpp"
#include "runtime/pd/hyper_reduced.hpp"
#include "runtime/scene/pin_motion.hpp"

namespace mat {

namespace {

    Material material_of(const MaterialSettings& settings)
    {
        Material material;
        material.youngs_modulus = settings.youngs_modulus;
        material.poisson_ratio = settings.poisson_ratio;
        material.density = settings.density;
        if (settings.strain_limits) {
            material.strain_limit_min = (*settings.strain_limits)(0);
            material.strain_limit_max = (*settings.strain_limits)(1);
        }
        return material;
    }

    /// The nodes of `region` (bake coordinates), increasing. Throws naming `key` if none.
    std::vector<int> region_nodes(const PinRegion& region, const MatX3& rest,
        const std::string& scene_file, const std::string& key)
    {
        std::vector<int> nodes;
        const Index n = rest.rows();
        switch (region.kind) {
        case PinKind::box:
            for (Index i = 0; i < n; ++i) {
                const Vec3 x = rest.row(i).transpose();
                if ((x.array() >= region.box.min.array()).all()
                    && (x.array() <= region.box.max.array()).all())
                    nodes.push_back(static_cast<int>(i));
            }
            break;
        case PinKind::sphere:
            for (Index i = 0; i < n; ++i)
                if ((rest.row(i).transpose() - region.sphere.center).norm() <= region.sphere.radius)
                    nodes.push_back(static_cast<int>(i));
            break;
        case PinKind::nodes:
            for (const int i : region.nodes) {
                if (i < 0 || i >= n)
                    throw_error("{}: {}.nodes: node {} is out of range [0, {}) for this bake",
                        scene_file, key, i, n);
                nodes.push_back(i);
            }
            break;
        }
        if (nodes.empty())
            throw_error("{}: {}: the region contains no node of the bake's tet mesh (regions are "
                        "in the bake's coordinates)",
                scene_file, key);
        return nodes;
    }

    /// The body's pin groups (each node in the first region that selects it) and the model
    /// options that pin them at their placed rest positions.
    ModelOptions pin_body(Body& body, const Scene& scene, std::size_t index,
        const ObjectSettings& object, const MatX3& rest, SolverKind solver_kind)
    {
        const std::string key = fmt::format("objects[{}]", index);
        ModelOptions options;
        options.time_step = scene.time.dt;
        options.volume_tolerance = scene.solver.volume_tolerance;
        // Reduced bodies pin softly (solver.reduced_pin_stiffness): stiff pins on every pinned node
        // freeze each handle whose weights reach into the pinned region (locking). Full-space
        // bodies pin stiffly (solver.full_pin_stiffness); a soft value there measures what the
        // soft pin alone costs (docs/benchmarks.md, "What limits the error").
        options.pin_weight_scale = solver_kind == SolverKind::full
            ? scene.solver.full_pin_stiffness
            : scene.solver.reduced_pin_stiffness;
        std::vector<char> taken(rest.rows(), 0);
        for (std::size_t p = 0; p < object.pins.size(); ++p) {
            PinGroup group;
            group.region = &object.pins[p];
            for (const int i : region_nodes(
                     object.pins[p], rest, scene.file, fmt::format("{}.pins[{}]", key, p))) {
                if (taken[i])
                    continue;
                taken[i] = 1;
                group.nodes.push_back(i);
                group.slots.push_back(static_cast<int>(options.pinned_nodes.size()));
                options.pinned_nodes.push_back(i);
                group.centroid += rest.row(i).transpose();
            }
            if (!group.nodes.empty())
                group.centroid /= static_cast<double>(group.nodes.size());
            body.pins.push_back(std::move(group));
        }
        options.pin_targets.resize(static_cast<Index>(options.pinned_nodes.size()), 3);
        for (Index p = 0; p < options.pin_targets.rows(); ++p)
            options.pin_targets.row(p)
                = (body.rotation * rest.row(options.pinned_nodes[p]).transpose() + body.translation)
                      .transpose();
        return options;
    }

    std::unique_ptr<PdSolver> make_solver(
        const Model& model, const Scene& scene, SolverKind solver_kind)
    {
        SolverOptions options;
        options.iterations = scene.time.iterations;
        options.tolerance = scene.time.tolerance;
        options.gravity = scene.gravity;
        options.damping = scene.solver.damping;
        options.exact_projections = scene.solver.projections == ProjectionMode::exact;
        options.acceleration = scene.solver.acceleration == AccelerationMode::anderson
            ? Acceleration::anderson
            : Acceleration::none;
        options.anderson_window = scene.solver.anderson_window;
        options.angular_momentum = scene.solver.angular_momentum == AngularMomentumMode::keep
            ? AngularMomentum::keep
            : scene.solver.angular_momentum == AngularMomentumMode::free
            ? AngularMomentum::free
            : AngularMomentum::integrator;
        options.device = scene.solver.device == DeviceMode::cuda ? Device::cuda : Device::cpu;
        options.contact_margin = scene.solver.contact_margin;
        // Only full-space bodies take the preload: hyper-reduced ones crushed with it, and
        // semi-reduced ones, whose skin keeps their contacts from resting inside, crushed with it
        // beside the self skin (docs/method.md, "Compliance", "Preload in full space only").
        options.compliance_preload
            = scene.solver.compliance_preload && solver_kind == SolverKind::full;
        // Full-space bodies hold their contacts' planes for the step, keep the skin and find
        // their contacts again halfway through it: with planes that turn they kept intersecting
        // triangles at rest, and their self contacts raised a resting pile's energy
        // (docs/method.md, "Full space holds its planes", "Self contacts hold their planes").
        const bool full = solver_kind == SolverKind::full;
        options.planes_follow_iterate = scene.solver.contact_normals == ModeChoice::automatic
            ? !full
            : scene.solver.contact_normals == ModeChoice::enabled;
        // Self contacts hold their face's plane for the step but on hyper-reduced bodies: with
        // planes that turn, a full-space pile's energy rose, and a semi-reduced run raised to 30
        // iterations or more crushed with its energy rising (docs/method.md, "Self contacts hold
        // their planes"); hyper-reduced bodies kept intersecting triangles at rest with them held.
        options.self_planes_follow_iterate = solver_kind == SolverKind::hyper_reduced;
        options.detect_in_step = scene.solver.detect_in_step == ModeChoice::automatic
            ? full
            : scene.solver.detect_in_step == ModeChoice::enabled;
        options.contact_skin = true;
        options.compliance_cap = scene.solver.compliance_cap;
        // Full-space bodies push a vertex that starts behind its own face out at a quarter of the
        // speed: at the full speed beside the self skin a pile's energy rose (docs/method.md,
        // "Self collision on by default").
        options.self_push_speed
            = scene.solver.self_push_speed * (solver_kind == SolverKind::full ? 0.25 : 1.0);
        options.contact.subspace_every = scene.solver.contact_subspace ? 4 : 0;
        for (const ColliderSettings& collider : scene.colliders)
            options.planes.push_back(
                PlaneCollider { collider.point, collider.normal, collider.friction });
        // A hyper-reduced body that takes contacts from other bodies samples more tets by
        // default (runtime/pd/hyper_reduced.hpp).
        Index samples = scene.solver.hyper_samples;
        if (samples == 0 && solver_kind == SolverKind::hyper_reduced && scene_collides(scene))
            samples = automatic_samples(model.num_columns(), true);
        return make_solver(solver_kind, model, options, samples);
    }

    /// Initial state: placed rest positions, v + w x (x - centre of mass); pinned nodes, static
    /// bodies at rest; a kinematic body at its motion's start.
    void place_body(Body& body, const ObjectSettings& object)
    {
        const MatX3& rest = body.model->pd().rest_positions();
        const Index n = rest.rows();
        body.state.positions.resize(n, 3);
        for (Index i = 0; i < n; ++i)
            body.state.positions.row(i)
                = (body.rotation * rest.row(i).transpose() + body.translation).transpose();
        const VecX& masses = body.model->pd().masses();
        const Vec3 centre
            = (body.state.positions.transpose() * masses) / std::max(masses.sum(), 1e-300);
        body.state.velocities.resize(n, 3);
        for (Index i = 0; i < n; ++i)
            body.state.velocities.row(i) = (object.velocity
                + object.angular_velocity.cross(body.state.positions.row(i).transpose() - centre))
                                               .transpose();
        for (const PinGroup& group : body.pins)
            for (const int i : group.nodes)
                body.state.velocities.row(i).setZero();
        body.placed_centre = centre;
        if (body.is_kinematic) {
            // Its keyframes may not start at the placement; velocities as given (constant
            // motion) or zero (keyframes: the first step's finite difference follows).
            body.placed_rest = body.state.positions;
            if (!object.keyframes.empty()) {
                body.state.positions = apply_pin_transform(
                    kinematic_motion_at(object, 0.0, centre), body.placed_rest);
                body.state.velocities.setZero();
            }
        } else if (body.is_static) {
            body.state.velocities.setZero();
        }
    }

    Body build_body(
        const Scene& scene, std::size_t index, const BakeData& bake, SolverKind solver_kind)
    {
        const ObjectSettings& object = scene.objects[index];
        Body body;
        body.name = object.name;
        body.object = &object;
        body.rotation = rotation_from_euler_degrees(object.rotation_degrees);
        body.translation = object.position;
        body.is_static = object.motion != ObjectMotion::dynamic;
        body.is_kinematic = object.motion == ObjectMotion::kinematic;
        const MatX3& rest = bake.tet_mesh.positions;
        const ModelOptions options = pin_body(body, scene, index, object, rest, solver_kind);
        body.model = std::make_shared<const BodyModel>(bake, material_of(object.material), options);
        body.solver = make_solver(body.model->pd(), scene, solver_kind);
        place_body(body, object);
        body.pin_targets = options.pin_targets;
        update_pin_targets(body, 0.0);
        if (!body.is_static)
            body.sleep_speed = scene.solver.sleep_speed * body.model->rest_diagonal();
        logger().info("{}: {} nodes, {} tets, {} handles, {} columns, {} pinned nodes", body.name,
            rest.rows(), body.model->pd().num_tets(), body.model->num_handles(),
            body.model->pd().num_columns(), options.pinned_nodes.size());
        return body;
    }

} // namespace

std::vector<Body> load_bodies(const Scene& scene, SolverKind solver_kind)
{
    // Each bake file is read once, kept only while its objects are built.
    std::map<std::string, BakeData> bakes;
    for (const ObjectSettings& object : scene.objects)
        if (bakes.find(object.bake) == bakes.end())
            bakes.emplace(object.bake, read_bake(object.bake));
    std::vector<Body> bodies;
    bodies.reserve(scene.objects.size());
    for (std::size_t o = 0; o < scene.objects.size(); ++o)
        bodies.push_back(build_body(scene, o, bakes.at(scene.objects[o].bake), solver_kind));
    return bodies;
}

} // namespace mat
