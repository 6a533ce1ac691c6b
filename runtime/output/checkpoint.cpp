#include "runtime/output/checkpoint.hpp"

#include <cstdint>
#include <limits>

#include <cstring>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "common/error.hpp"
#include "formats/bake_io.hpp"
#include "formats/hdf5_file.hpp"
#include "formats/text_io.hpp"

namespace mat {

namespace {

    constexpr const char* checkpoint_format_name = "medial-elastics-checkpoint";
    constexpr int checkpoint_format_version = 1;

    std::string body_group(std::size_t b)
    {
        return fmt::format("/bodies/{}", b);
    }

    void write_body(H5Writer& out, const std::string& group, const BodySnapshot& body)
    {
        out.create_group(group);
        out.set_attribute(group, "asleep", std::int64_t(body.asleep ? 1 : 0));
        out.set_attribute(group, "slow_steps", std::int64_t(body.slow_steps));
        out.set_attribute(group, "moved", std::int64_t(body.moved ? 1 : 0));
        out.write_matrix(group + "/positions", body.positions);
        out.write_matrix(group + "/velocities", body.velocities);
        out.write_matrix(group + "/pin_targets", body.pin_targets);
        out.write_matrix(group + "/solver_pin_targets", body.solver_pin_targets);
        if (body.q.size() > 0)
            out.write_matrix(group + "/q", body.q);
        Eigen::VectorXi warm(static_cast<Index>(body.warm.size()));
        static_assert(sizeof(float) == sizeof(int));
        if (!body.warm.empty())
            std::memcpy(warm.data(), body.warm.data(), body.warm.size() * sizeof(float));
        out.write_vector(group + "/warm", warm);
        RowMatXi used(static_cast<Index>(body.contact.used.size()), 2);
        for (Index u = 0; u < used.rows(); ++u)
            for (int k = 0; k < 2; ++k)
                used(u, k) = body.contact.used[static_cast<std::size_t>(u)][std::size_t(k)];
        out.write_matrix(group + "/contact_used", used);
        out.write_matrix(group + "/contact_forces", body.contact.forces);
    }

    BodySnapshot read_body(const H5Reader& in, const std::string& path, const std::string& group)
    {
        BodySnapshot body;
        body.asleep = in.read_int_attribute(group, "asleep") != 0;
        const std::int64_t slow_steps = in.read_int_attribute(group, "slow_steps");
        if (slow_steps < 0 || slow_steps > std::numeric_limits<int>::max())
            throw_error("{}: {}: slow_steps {} out of range [0, {}]", path, group, slow_steps,
                std::numeric_limits<int>::max());
        body.slow_steps = static_cast<int>(slow_steps);
        body.moved = in.read_int_attribute(group, "moved") != 0;
        body.positions = in.read<MatX3>(group + "/positions");
        body.velocities = in.read<MatX3>(group + "/velocities", body.positions.rows());
        body.pin_targets = in.read<MatX3>(group + "/pin_targets");
        body.solver_pin_targets = in.read<MatX3>(group + "/solver_pin_targets");
        if (in.has(group + "/q"))
            body.q = in.read_matrix(group + "/q", H5Reader::any, 3);
        const Eigen::VectorXi warm = in.read<Eigen::VectorXi>(group + "/warm");
        body.warm.resize(static_cast<std::size_t>(warm.size()));
        if (warm.size() > 0)
            std::memcpy(body.warm.data(), warm.data(), body.warm.size() * sizeof(float));
        const RowMatXi used = in.read_matrix_int(group + "/contact_used", H5Reader::any, 2);
        for (Index u = 0; u < used.rows(); ++u)
            body.contact.used.push_back({ used(u, 0), used(u, 1) });
        body.contact.forces = in.read<MatX3>(group + "/contact_forces", used.rows());
        return body;
    }

} // namespace

RunIdentity run_identity(const Scene& scene, const std::string& solver)
{
    nlohmann::json json;
    try {
        json = nlohmann::json::parse(text_io::read_file(scene.file));
    } catch (const nlohmann::json::exception& e) {
        throw_error("{}: cannot read the scene again: {}", scene.file, e.what());
    }
    if (json.contains("time") && json["time"].is_object()) {
        json["time"].erase("frames");
        json["time"].erase("duration");
    }
    RunIdentity identity;
    identity.scene_hash = hash_text(json.dump());
    nlohmann::json bakes = nlohmann::json::array();
    for (const ObjectSettings& object : scene.objects)
        bakes.push_back(hash_file(object.bake));
    identity.bake_hashes = bakes.dump();
    identity.solver = solver;
    return identity;
}

void write_checkpoint(const std::string& path, const RunIdentity& identity, int frame,
    const SimulationSnapshot& snapshot)
{
    H5Writer out(path);
    out.stamp_format(checkpoint_format_name, checkpoint_format_version);
    out.set_attribute("/", "frame", std::int64_t(frame));
    out.set_attribute("/", "steps", std::int64_t(snapshot.steps));
    out.set_attribute("/", "scene_hash", identity.scene_hash);
    out.set_attribute("/", "bake_hashes", identity.bake_hashes);
    out.set_attribute("/", "solver", identity.solver);
    out.create_group("bodies");
    for (std::size_t b = 0; b < snapshot.bodies.size(); ++b)
        write_body(out, body_group(b), snapshot.bodies[b]);
    out.commit();
}

Checkpoint read_checkpoint(const std::string& path, const RunIdentity& identity)
{
    const H5Reader in(path);
    in.require_format(checkpoint_format_name, checkpoint_format_version, "mat-run --resume");
    const auto refuse = [&](const char* what, const std::string& was, const std::string& now) {
        throw_error("{}: made from another {} ({}; this run: {}): run without --resume to "
                    "start over",
            path, what, was, now);
    };
    const std::string solver = in.read_string_attribute("/", "solver");
    if (solver != identity.solver)
        refuse("solver", solver, identity.solver);
    const std::string scene = in.read_string_attribute("/", "scene_hash");
    if (scene != identity.scene_hash)
        refuse("scene", "scene hash " + scene, identity.scene_hash);
    const std::string bakes = in.read_string_attribute("/", "bake_hashes");
    if (bakes != identity.bake_hashes)
        refuse("bake", "bake hashes " + bakes, identity.bake_hashes);
    Checkpoint checkpoint;
    const std::int64_t frame = in.read_int_attribute("/", "frame");
    checkpoint.snapshot.steps = static_cast<long>(in.read_int_attribute("/", "steps"));
    if (frame < 0 || frame > std::numeric_limits<int>::max() || checkpoint.snapshot.steps < 0)
        throw_error("{}: frame {} and steps {} must lie in [0, {}] and be non-negative", path,
            frame, checkpoint.snapshot.steps, std::numeric_limits<int>::max());
    checkpoint.frame = static_cast<int>(frame);
    const std::vector<std::string> bodies = in.list("bodies");
    for (std::size_t b = 0; b < bodies.size(); ++b) {
        if (!in.has(body_group(b)))
            throw_error("{}: no group '{}' ({} bodies)", path, body_group(b), bodies.size());
        checkpoint.snapshot.bodies.push_back(read_body(in, path, body_group(b)));
    }
    return checkpoint;
}

} // namespace mat
