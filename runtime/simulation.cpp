#include "runtime/simulation.hpp"

#include <cmath>

#include "common/error.hpp"
#include "common/log.hpp"
#include "common/timer.hpp"
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

} // namespace

SolverKind parse_solver_kind(const std::string& name)
{
    if (name == "semi")
        return SolverKind::semi_reduced;
    if (name == "full")
        return SolverKind::full;
    if (name == "hyper")
        return SolverKind::hyper_reduced;
    throw_error("--solver: '{}' is not a solver (expected semi, full or hyper)", name);
}

Simulation::Simulation(const Scene& scene, SolverKind solver_kind)
    : m_scene(scene)
    , m_solver_kind(solver_kind)
{
    const bool self = scene.solver.self_collision == "on";
    if (scene.solver.collision != "off" && (scene.objects.size() > 1 || self)) {
        CollisionSettings settings;
        settings.self = self;
        settings.bounds
            = scene.solver.collision == "lazy" ? RadiusUpdate::lazy : RadiusUpdate::bound;
        settings.margin = scene.solver.collision_margin;
        settings.friction = scene.solver.collision_friction;
        m_collision = std::make_unique<CollisionWorld>(settings);
    } else if (scene.objects.size() > 1) {
        for (const ObjectSettings& object : scene.objects)
            if (object.motion != "dynamic") {
                logger().warn("{}: object '{}' is {} but solver.collision is off: it touches "
                              "nothing",
                    scene.file, object.name, object.motion);
            }
    }
    m_bodies.reserve(scene.objects.size());
    for (std::size_t o = 0; o < scene.objects.size(); ++o) {
        const ObjectSettings& object = scene.objects[o];
        const std::string key = fmt::format("objects[{}]", o);
        Body body;
        body.name = object.name;
        body.rotation = rotation_from_euler_degrees(object.rotation_degrees);
        body.translation = object.position;

        BakeData bake = read_bake(object.bake);
        const MatX3& rest = bake.tet_mesh.positions;
        const Index n = rest.rows();

        // Pins: each node belongs to the first region that selects it.
        ModelOptions options;
        options.time_step = scene.time.dt;
        options.volume_tolerance = scene.solver.volume_tolerance;
        // Reduced bodies pin softly (solver.reduced_pin_stiffness): stiff pins on every pinned node
        // freeze each handle whose weights reach into the pinned region (locking).
        if (solver_kind != SolverKind::full)
            options.pin_weight_scale = scene.solver.reduced_pin_stiffness;
        std::vector<char> taken(n, 0);
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

        body.model = std::make_unique<Model>(bake, material_of(object.material), options);
        body.surface = std::make_unique<SurfaceView>(bake);
        body.is_static = object.motion == "static" || object.motion == "kinematic";
        body.is_kinematic = object.motion == "kinematic";
        body.object = &object;
        body.surface_primitive = bake.collision.vertex_primitive;
        body.primitive_spheres = bake.collision.primitive_spheres;
        if (m_collision)
            m_collision->add_body(bake);
        body.num_handles = bake.num_handles();

        SolverOptions solver_options;
        solver_options.iterations = scene.time.iterations;
        solver_options.gravity = scene.gravity;
        solver_options.damping = scene.solver.damping;
        solver_options.exact_projections = scene.solver.projections == "exact";
        solver_options.contact_margin = scene.solver.contact_margin;
        for (const ColliderSettings& collider : scene.colliders)
            solver_options.planes.push_back(
                PlaneCollider { collider.point, collider.normal, collider.friction });
        if (solver_kind == SolverKind::full)
            body.solver = std::make_unique<FullSolver>(*body.model, solver_options);
        else if (solver_kind == SolverKind::hyper_reduced)
            body.solver = std::make_unique<HyperReducedSolver>(
                *body.model, solver_options, scene.solver.hyper_samples);
        else
            body.solver = std::make_unique<SemiReducedSolver>(*body.model, solver_options);

        // Initial state: placed rest positions, v + w x (x - centre of mass).
        body.state.positions.resize(n, 3);
        for (Index i = 0; i < n; ++i)
            body.state.positions.row(i)
                = (body.rotation * rest.row(i).transpose() + body.translation).transpose();
        const VecX& masses = body.model->masses();
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
        body.pin_targets = options.pin_targets;
        update_pin_targets(body, 0.0);
        if (!body.is_static)
            body.sleep_speed = scene.solver.sleep_speed
                * (rest.colwise().maxCoeff() - rest.colwise().minCoeff()).norm();
        logger().info("{}: {} nodes, {} tets, {} handles, {} columns, {} pinned nodes", body.name,
            n, body.model->num_tets(), body.num_handles, body.model->num_columns(),
            options.pinned_nodes.size());
        m_bodies.push_back(std::move(body));
    }
    m_contact_stage = std::make_unique<ContactStage>(static_cast<Index>(m_bodies.size()));
    // Speculative contacts: what a vertex may close in a step at its approach speed (a quarter
    // more for the speed it gains in the step), and what gravity adds.
    if (m_collision)
        m_collision->set_lookahead(
            1.25 * scene.time.dt, scene.time.dt * scene.time.dt * scene.gravity.norm());
}

bool Simulation::update_pin_targets(Body& body, double time)
{
    const MatX3& rest = body.model->rest_positions();
    bool moving = false;
    bool moved_pins = false;
    for (const PinGroup& group : body.pins) {
        if (group.region->motion.empty())
            continue;
        moving = true;
        const PinTransform motion = pin_motion_at(*group.region, time, group.centroid);
        for (std::size_t a = 0; a < group.nodes.size(); ++a) {
            const Vec3 moved = motion.apply(rest.row(group.nodes[a]).transpose());
            const Eigen::RowVector3d target
                = (body.rotation * moved + body.translation).transpose();
            moved_pins = moved_pins || target != body.pin_targets.row(group.slots[a]);
            body.pin_targets.row(group.slots[a]) = target;
        }
    }
    if (moving)
        body.solver->set_pin_targets(body.pin_targets);
    return moved_pins;
}

void Simulation::move_kinematic(Body& body, double time)
{
    body.next.positions = apply_pin_transform(
        kinematic_motion_at(*body.object, time, body.placed_centre), body.placed_rest);
    body.next.velocities = (body.next.positions - body.state.positions) / m_scene.time.dt;
    std::swap(body.state, body.next);
}

int Simulation::num_sleeping() const
{
    int count = 0;
    for (const Body& body : m_bodies)
        count += body.asleep ? 1 : 0;
    return count;
}

void Simulation::wake_touched(std::vector<CollisionBodyState>& states)
{
    // The movers are fixed before any body wakes: a body woken now wakes others only once it
    // has moved, so the result does not depend on the order of the bodies.
    // A kinematic body moves if its prescribed motion displaced it this step (a stopped one wakes
    // nothing); an awake dynamic body if its last step was not slow.
    std::vector<std::size_t>& movers = m_movers;
    movers.clear();
    for (std::size_t b = 0; b < m_bodies.size(); ++b) {
        const Body& body = m_bodies[b];
        const bool moving = body.is_kinematic
            ? body.state.velocities.cwiseAbs().maxCoeff() > 0.0
            : !body.is_static && !body.asleep && body.slow_steps == 0;
        if (moving)
            movers.push_back(b);
    }
    for (std::size_t b = 0; b < m_bodies.size(); ++b) {
        Body& body = m_bodies[b];
        if (!body.asleep)
            continue;
        const Box3& box = m_collision->body_box(static_cast<Index>(b));
        for (const std::size_t m : movers)
            if (box.intersects(m_collision->body_box(static_cast<Index>(m)))) {
                logger().debug(
                    "{} wakes at step {}: {} touches it", body.name, m_steps + 1, m_bodies[m].name);
                body.asleep = false;
                body.slow_steps = 0;
                states[b].is_static = false;
                break;
            }
    }
}

void Simulation::update_sleep(Body& body, bool pins_moved)
{
    if (body.sleep_speed <= 0.0)
        return;
    const double speed_squared = body.state.velocities.rowwise().squaredNorm().maxCoeff();
    logger().trace("{}: step {}, fastest node {:.3g} m/s (sleeps below {:.3g})", body.name,
        m_steps + 1, std::sqrt(speed_squared), body.sleep_speed);
    body.slow_steps = speed_squared < body.sleep_speed * body.sleep_speed && !pins_moved
        ? body.slow_steps + 1
        : 0;
    if (body.slow_steps >= m_scene.solver.sleep_steps) {
        logger().debug("{} falls asleep at step {}", body.name, m_steps + 1);
        body.asleep = true;
        body.state.velocities.setZero();
    }
}

void Simulation::step()
{
    const double dt = m_scene.time.dt;
    const double next_time = (m_steps + 1) * dt;
    // Kinematic bodies go first, to where they are at the end of the step: the others' contacts
    // of this step are with them there.
    for (Body& body : m_bodies)
        if (body.is_kinematic) {
            move_kinematic(body, next_time);
            body.moved = true;
        }
    // Pin targets at the end of the step; a sleeping body whose pins move wakes.
    std::vector<char>& pins_moved = m_pins_moved;
    pins_moved.assign(m_bodies.size(), 0);
    for (std::size_t b = 0; b < m_bodies.size(); ++b) {
        Body& body = m_bodies[b];
        if (body.is_static)
            continue;
        pins_moved[b] = update_pin_targets(body, next_time) ? 1 : 0;
        if (pins_moved[b] && body.asleep) {
            body.asleep = false;
            body.slow_steps = 0;
        }
    }
    const BodyContacts* contacts = &m_no_contacts;
    if (m_collision)
        contacts = &detect_contacts();
    step_bodies(*contacts, pins_moved);
    ++m_steps;
}

// How far a node of an awake dynamic body may move in the coming step: h |v| at its fastest
// node, a quarter more for the velocity it gains in the step, and h^2 |g|.
double Simulation::motion_bound(const Body& body) const
{
    const double h = m_scene.time.dt;
    const double speed = std::sqrt(body.state.velocities.rowwise().squaredNorm().maxCoeff());
    return 1.25 * h * speed + h * h * m_scene.gravity.norm();
}

const BodyContacts& Simulation::detect_contacts()
{
    // Before the first step q does not hold the placement yet: bounds from positions.
    std::vector<CollisionBodyState>& states = m_states;
    states.assign(m_bodies.size(), CollisionBodyState {});
    for (std::size_t b = 0; b < m_bodies.size(); ++b) {
        const Body& body = m_bodies[b];
        states[b].nodes = &body.state.positions;
        states[b].is_static = body.is_static || body.asleep;
        states[b].reuse_bounds = !body.moved;
        if (m_steps > 0 && !body.is_static)
            states[b].q = body.solver->reduced_coordinates();
        states[b].velocities = &body.state.velocities;
        if (!states[b].is_static)
            states[b].motion = motion_bound(body);
    }
    m_collision->update_bounds(states);
    for (Body& body : m_bodies)
        body.moved = false;
    wake_touched(states);
    return m_collision->find_contacts(states);
}

// The bodies' PD steps in stages, with one contact stage over all of them between each
// iteration's global solves and positions (runtime/pd/contact_stage.hpp).
void Simulation::step_bodies(const BodyContacts& contacts, const std::vector<char>& pins_moved)
{
    std::vector<ContactBodyState>& views = m_contact_views;
    views.assign(m_bodies.size(), ContactBodyState {});
    m_stepped.clear();
    for (std::size_t b = 0; b < m_bodies.size(); ++b) {
        Body& body = m_bodies[b];
        // A kinematic body has moved already: it started the step where `next` holds now.
        views[b].start = body.is_kinematic ? &body.next.positions : &body.state.positions;
        views[b].now = &body.state.positions;
        if (body.is_static || body.asleep)
            continue;
        body.solver->begin_step(body.state, body.next);
        views[b].solver = body.solver.get();
        m_stepped.push_back(b);
    }
    if (m_stepped.empty())
        return;
    Timer timer;
    m_contact_stage->begin_step(views, contacts);
    const double share = timer.seconds() / static_cast<double>(m_stepped.size());
    const int iterations = m_scene.time.iterations;
    for (int iteration = 0; iteration < iterations; ++iteration) {
        for (const std::size_t b : m_stepped)
            m_bodies[b].solver->iterate(iteration);
        m_contact_stage->solve(iteration + 1 == iterations);
        for (const std::size_t b : m_stepped)
            m_bodies[b].solver->finish_iteration(iteration);
    }
    m_contact_stage->end_step();
    for (const std::size_t b : m_stepped) {
        Body& body = m_bodies[b];
        body.solver->add_contact_seconds(share);
        body.solver->end_step();
        std::swap(body.state, body.next);
        body.moved = true;
        update_sleep(body, pins_moved[b] != 0);
    }
}

} // namespace mat
