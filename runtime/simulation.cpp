#include "runtime/simulation.hpp"

#include <cmath>

#include "common/error.hpp"
#include "common/log.hpp"
#include "common/timer.hpp"
#include "runtime/scene/pin_motion.hpp"

namespace mat {

namespace {

    /// The collision world the scene asks for, or null: none when collision is off, or when one
    /// body cannot collide with itself. Warns about static and kinematic objects that then touch
    /// nothing.
    std::unique_ptr<CollisionWorld> make_collision_world(const Scene& scene)
    {
        if (scene_collides(scene)) {
            CollisionSettings settings;
            settings.self = scene.solver.self_collision;
            settings.bounds = scene.solver.collision == CollisionMode::lazy ? RadiusUpdate::lazy
                                                                            : RadiusUpdate::bound;
            settings.margin = scene.solver.collision_margin;
            settings.friction = scene.solver.collision_friction;
            settings.edges = scene.solver.edge_contacts;
            settings.skin = scene.solver.contact_skin;
            settings.self_skin = scene.solver.self_skin;
            return std::make_unique<CollisionWorld>(settings);
        }
        if (scene.objects.size() > 1)
            for (const ObjectSettings& object : scene.objects)
                if (object.motion != ObjectMotion::dynamic)
                    logger().warn("{}: object '{}' is {} but solver.collision is off: it touches "
                                  "nothing",
                        scene.file, object.name, motion_name(object.motion));
        return nullptr;
    }

} // namespace

Simulation::Simulation(const Scene& scene, std::vector<Body> bodies)
    : m_scene(scene)
    , m_bodies(std::move(bodies))
    , m_collision(make_collision_world(scene))
{
    MAT_CHECK(m_bodies.size() == scene.objects.size(), "simulation: {} bodies for {} objects",
        m_bodies.size(), scene.objects.size());
    if (m_collision)
        for (const Body& body : m_bodies)
            m_collision->add_body(body.model);
    m_contact_stage = std::make_unique<ContactStage>(static_cast<Index>(m_bodies.size()));
    // Speculative contacts: what a vertex may close in a step at its approach speed (a quarter
    // more for the speed it gains in the step), and what gravity adds.
    if (m_collision)
        m_collision->set_lookahead(
            1.25 * scene.time.dt, scene.time.dt * scene.time.dt * scene.gravity.norm());
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
    body.solver->sync_state(body.state);
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
        body.solver->state_written();
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
    // --device cuda leaves the states on the GPU; collision detection reads them every step.
    if (m_collision)
        sync_host();
}

void Simulation::sync_host()
{
    for (Body& body : m_bodies)
        if (body.solver)
            body.solver->sync_state(body.state);
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
    int detect_after = -1; // iterations after which the contacts are found again (-1: never)
    if (m_collision) {
        detect_after = 0;
        for (const std::size_t b : m_stepped) {
            const SolverOptions& options = m_bodies[b].solver->options();
            // Not where the step is not the CPU's plain iteration, nor with a hyper-reduced
            // body (its local stage does not read the iterate): drop_on_pile crushed with it
            // (docs/method.md, "Contacts found again during the step").
            if (!options.detect_in_step || options.device != Device::cpu
                || options.acceleration != Acceleration::none
                || !m_bodies[b].solver->local_stage().reads_iterate())
                detect_after = -1;
            else if (detect_after >= 0)
                detect_after = std::max(detect_after, options.iterations / 2);
        }
    }
    // The last iteration: the scene's count, or (time.tolerance) the one after every body's
    // iterate is estimated within the tolerance of its converged step.
    bool last = false;
    for (int iteration = 0; !last; ++iteration) {
        last = true;
        for (const std::size_t b : m_stepped)
            last = last && m_bodies[b].solver->is_last_iteration(iteration);
        for (const std::size_t b : m_stepped)
            m_bodies[b].solver->iterate(iteration);
        m_contact_stage->solve(last);
        for (const std::size_t b : m_stepped)
            m_bodies[b].solver->finish_iteration(iteration, last);
        if (!last && iteration + 1 == detect_after)
            detect_in_step(views, contacts);
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

// The states at the iterate: a stepped body's positions and q after the last iteration, the
// others' as at the step start (a kinematic body is at its end-of-step place already); no
// velocities, so no speculative reach (the iterate is the step's end as far as it is known).
void Simulation::detect_in_step(
    const std::vector<ContactBodyState>& views, const BodyContacts& start)
{
    // `start` may be the collision world's own list, which the search below replaces.
    m_start_contacts = start;
    std::vector<CollisionBodyState>& states = m_states;
    states.assign(m_bodies.size(), CollisionBodyState {});
    for (std::size_t b = 0; b < m_bodies.size(); ++b) {
        Body& body = m_bodies[b];
        const bool stepped = views[b].solver != nullptr;
        states[b].is_static = body.is_static || body.asleep;
        states[b].reuse_bounds = !stepped;
        if (stepped) {
            // The iterate's positions: step_bodies runs this only for local stages that read
            // them, so finish_iteration has written them.
            states[b].nodes = &body.next.positions;
            states[b].q = body.solver->reduced_coordinates();
        } else {
            states[b].nodes = &body.state.positions;
        }
    }
    m_step_contacts = m_collision->detect_in_step(states);
    const Index found = m_step_contacts.size();
    // A start contact that the iterate's search no longer finds stays: a vertex still on its
    // way (a speculative contact whose vertex the iterations have not yet brought within the
    // margin) would otherwise lose the contact that stops it (docs/method.md, "Contacts found
    // again during the step").
    m_step_contacts.append_missing(m_start_contacts, m_contact_ids);
    Timer timer;
    m_contact_stage->end_step();
    m_contact_stage->begin_step(views, m_step_contacts, true, found);
    const double share = timer.seconds() / static_cast<double>(m_stepped.size());
    for (const std::size_t b : m_stepped)
        m_bodies[b].solver->add_contact_seconds(share);
}

} // namespace mat
