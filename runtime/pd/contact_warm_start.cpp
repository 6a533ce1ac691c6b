// The contact stage's warm start between steps, as a checkpoint keeps it
// (runtime/pd/contact_stage.hpp, ContactWarmStart).

#include "common/error.hpp"
#include "runtime/pd/contact_stage.hpp"
#include "runtime/pd/solver.hpp"

namespace mat {

ContactWarmStart ContactStage::warm_start(int b) const
{
    const BodyData& data = m_data[static_cast<std::size_t>(b)];
    ContactWarmStart warm;
    if (!data.initialized)
        return warm;
    const Index planes = data.num_planes;
    warm.used = data.used;
    warm.forces.resize(static_cast<Index>(data.used.size()), 3);
    for (std::size_t u = 0; u < data.used.size(); ++u) {
        const auto [node, plane] = data.used[u];
        warm.forces.row(static_cast<Index>(u)) = plane >= 0
            ? data.previous_ground.row(node * planes + plane)
            : data.previous_pair.row(node);
    }
    return warm;
}

void ContactStage::set_warm_start(int b, PdSolver& solver, const ContactWarmStart& warm)
{
    MAT_CHECK(b >= 0 && b < static_cast<int>(m_data.size()), "contact stage: body {} of {}", b,
        m_data.size());
    if (warm.used.empty())
        return;
    init_body(b, solver);
    BodyData& data = m_data[static_cast<std::size_t>(b)];
    const Index planes = data.num_planes;
    const Index nodes = planes > 0 ? data.previous_ground.rows() / planes : 0;
    if (warm.forces.rows() != static_cast<Index>(warm.used.size()))
        throw_error(
            "contact warm start: {} forces for {} contacts", warm.forces.rows(), warm.used.size());
    for (std::size_t u = 0; u < warm.used.size(); ++u) {
        const auto [node, plane] = warm.used[u];
        // A contact between bodies is keyed by its surface vertex, which may exceed the nodes
        // (the stage then grows its table, as here).
        if (node < 0 || plane < -1 || plane >= planes || (plane >= 0 && node >= nodes))
            throw_error("contact warm start: node {} and plane {} out of range ({} nodes, {} "
                        "planes)",
                node, plane, nodes, planes);
        if (plane < 0)
            reach_key(data.previous_pair, node);
        if (plane >= 0)
            data.previous_ground.row(node * planes + plane)
                = warm.forces.row(static_cast<Index>(u));
        else
            data.previous_pair.row(node) = warm.forces.row(static_cast<Index>(u));
    }
    data.used = warm.used;
}

} // namespace mat
