// Simulation::snapshot and restore: what a checkpoint keeps (runtime/simulation.hpp,
// BodySnapshot). The collision world keeps nothing a step needs from the last one but the
// bounds of bodies that did not move, which it recomputes from the same positions after a
// restore.

#include "common/error.hpp"
#include "runtime/simulation.hpp"

namespace mat {

namespace {

    void check_rows(const std::string& body, const char* what, Index rows, Index expected)
    {
        if (rows != expected)
            throw_error(
                "checkpoint: body '{}': {} has {} rows, expected {}", body, what, rows, expected);
    }

} // namespace

SimulationSnapshot Simulation::snapshot()
{
    sync_host();
    SimulationSnapshot snapshot;
    snapshot.steps = m_steps;
    for (std::size_t b = 0; b < m_bodies.size(); ++b) {
        const Body& body = m_bodies[b];
        BodySnapshot s;
        s.positions = body.state.positions;
        s.velocities = body.state.velocities;
        s.pin_targets = body.pin_targets;
        s.asleep = body.asleep;
        s.slow_steps = body.slow_steps;
        s.moved = body.moved;
        if (!body.is_static) {
            s.solver_pin_targets = body.solver->pin_targets();
            if (const MatX* q = body.solver->reduced_coordinates())
                s.q = *q;
            s.warm = body.solver->local_stage().local_step().warm_start();
            s.contact = m_contact_stage->warm_start(static_cast<int>(b));
        }
        snapshot.bodies.push_back(std::move(s));
    }
    return snapshot;
}

void Simulation::restore(const SimulationSnapshot& snapshot)
{
    MAT_CHECK(m_steps == 0, "simulation: restore after {} steps", m_steps);
    if (snapshot.bodies.size() != m_bodies.size())
        throw_error(
            "checkpoint: {} bodies, the scene has {}", snapshot.bodies.size(), m_bodies.size());
    for (std::size_t b = 0; b < m_bodies.size(); ++b) {
        Body& body = m_bodies[b];
        const BodySnapshot& s = snapshot.bodies[b];
        const Index n = body.state.positions.rows();
        check_rows(body.name, "positions", s.positions.rows(), n);
        check_rows(body.name, "velocities", s.velocities.rows(), n);
        check_rows(body.name, "pin targets", s.pin_targets.rows(), body.pin_targets.rows());
        body.state.positions = s.positions;
        body.state.velocities = s.velocities;
        if (body.solver)
            body.solver->state_written();
        body.pin_targets = s.pin_targets;
        body.asleep = s.asleep;
        body.slow_steps = s.slow_steps;
        body.moved = s.moved;
        if (body.is_static)
            continue;
        body.solver->set_pin_targets(s.solver_pin_targets);
        if (body.solver->reduced_coordinates() != nullptr)
            body.solver->set_reduced_coordinates(s.q);
        else if (s.q.size() > 0)
            throw_error(
                "checkpoint: body '{}' has reduced coordinates, this solver has none", body.name);
        body.solver->local_stage().local_step().set_warm_start(s.warm);
        m_contact_stage->set_warm_start(static_cast<int>(b), *body.solver, s.contact);
    }
    m_steps = snapshot.steps;
}

} // namespace mat
