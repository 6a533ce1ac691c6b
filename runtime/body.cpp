#include "runtime/body.hpp"

#include "common/error.hpp"
#include "runtime/scene/pin_motion.hpp"

namespace mat {

bool update_pin_targets(Body& body, double time)
{
    const MatX3& rest = body.model->pd().rest_positions();
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

} // namespace mat
