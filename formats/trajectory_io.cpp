#include "formats/trajectory_io.hpp"

#include <algorithm>
#include <cmath>
#include <set>

#include "common/error.hpp"
#include "common/version.hpp"

namespace mat {

namespace {

    void check_object(const std::string& path, std::size_t i, const TrajectoryObject& object,
        std::set<std::string>& names)
    {
        const std::string& name = object.name;
        if (name.empty() || name == "." || name == ".." || name.find('/') != std::string::npos)
            throw_error("{}: cannot write trajectory: object {} has the name '{}', expected a "
                        "non-empty name without '/' (and not '.' or '..')",
                path, i, name);
        if (!names.insert(name).second)
            throw_error("{}: cannot write trajectory: two objects are named '{}'", path, name);
        const Index num_vertices = object.rest_positions.rows();
        if (num_vertices < 1)
            throw_error("{}: cannot write trajectory: object '{}' has no vertex", path, name);
        if (!object.rest_positions.allFinite())
            throw_error("{}: cannot write trajectory: object '{}' has non-finite rest positions",
                path, name);
        for (Index f = 0; f < object.faces.rows(); ++f)
            for (int k = 0; k < 3; ++k)
                if (object.faces(f, k) < 0 || object.faces(f, k) >= num_vertices)
                    throw_error("{}: cannot write trajectory: object '{}': face {} has vertex "
                                "index {}, expected 0 to {}",
                        path, name, f, object.faces(f, k), num_vertices - 1);
    }

    // `path`, once the objects are checked (before any file is created).
    std::string checked_path(std::string path, const std::vector<TrajectoryObject>& objects)
    {
        std::set<std::string> names;
        for (std::size_t i = 0; i < objects.size(); ++i)
            check_object(path, i, objects[i], names);
        return path;
    }

} // namespace

TrajectoryWriter::TrajectoryWriter(std::string path, const std::vector<TrajectoryObject>& objects,
    const std::string& options_json, H5WriterOptions options, TrajectoryLayout layout)
    : m_writer(checked_path(std::move(path), objects), options)
    , m_layout(layout)
{
    if (layout.capacity < 0)
        throw_error("{}: cannot write trajectory: capacity {}", m_writer.target(), layout.capacity);
    const Index capacity = layout.capacity;
    m_writer.stamp_format(trajectory_format_name, trajectory_format_version);
    m_writer.set_attribute("/", "created_by", std::string("medial elastics ") + version_string);
    m_writer.set_attribute("/", "frame_count", std::int64_t(0));
    m_writer.write_string("options", options_json);
    m_writer.create_series("time", {}, capacity);
    m_writer.create_group("objects");
    for (std::size_t i = 0; i < objects.size(); ++i) {
        const TrajectoryObject& object = objects[i];
        Object written { "/objects/" + object.name, object.rest_positions.rows() };
        m_writer.create_group(written.group);
        m_writer.set_attribute(written.group, "index", std::int64_t(i));
        m_writer.write_matrix(written.group + "/faces", object.faces);
        m_writer.write_matrix(written.group + "/rest_positions", object.rest_positions);
        m_writer.create_series(written.group + "/positions", { written.num_vertices, 3 }, capacity);
        if (capacity > 0 && layout.velocities)
            m_writer.create_series(
                written.group + "/velocities", { written.num_vertices, 3 }, capacity);
        m_objects.push_back(std::move(written));
    }
    m_velocities = capacity > 0 && layout.velocities;
}

void TrajectoryWriter::publish()
{
    if (m_layout.capacity == 0)
        throw_error("{}: cannot publish a growing trajectory before commit()", path());
    m_writer.publish();
}

void TrajectoryWriter::check_frame(const std::vector<MatX3>& values, const char* what) const
{
    if (values.size() != m_objects.size())
        throw_error("{}: cannot append frame {}: {} arrays of {}, expected one per object ({})",
            path(), m_frames, values.size(), what, m_objects.size());
    for (std::size_t i = 0; i < values.size(); ++i) {
        const Object& object = m_objects[i];
        if (values[i].rows() != object.num_vertices)
            throw_error("{}: cannot append frame {}: {} of '{}' has {} rows, expected {}", path(),
                m_frames, what, object.group, values[i].rows(), object.num_vertices);
        for (Index v = 0; v < values[i].rows(); ++v)
            if (!values[i].row(v).allFinite())
                throw_error("{}: cannot append frame {}: {} of '{}' is not finite at vertex {}",
                    path(), m_frames, what, object.group, v);
    }
}

void TrajectoryWriter::append(
    double time, const std::vector<MatX3>& positions, const std::vector<MatX3>* velocities)
{
    if (m_failed)
        throw_error("{}: cannot append frame {}: an earlier append failed", path(), m_frames);
    if (!std::isfinite(time) || (m_frames > 0 && !(time > m_last_time)))
        throw_error("{}: cannot append frame {}: time {} {}", path(), m_frames, time,
            std::isfinite(time) ? fmt::format("is not after the previous frame's ({})", m_last_time)
                                : std::string("is not finite"));
    check_frame(positions, "positions");
    if (velocities)
        check_frame(*velocities, "velocities");
    if ((m_frames > 0 || m_layout.capacity > 0) && (velocities != nullptr) != m_velocities)
        throw_error("{}: cannot append frame {}: {}", path(), m_frames,
            m_velocities ? "no velocities given, but the earlier frames have them"
                         : "velocities given, but the earlier frames have none");
    try {
        if (m_layout.capacity > 0 && m_frames >= m_layout.capacity)
            throw_error("{}: cannot append frame {}: {} frames were reserved", path(), m_frames,
                m_layout.capacity);
        if (m_frames == 0 && velocities && m_layout.capacity == 0) {
            for (const Object& object : m_objects)
                m_writer.create_series(object.group + "/velocities", { object.num_vertices, 3 });
            m_velocities = true;
        }
        m_writer.append("time", time);
        for (std::size_t i = 0; i < m_objects.size(); ++i) {
            m_writer.append(m_objects[i].group + "/positions", positions[i]);
            if (velocities)
                m_writer.append(m_objects[i].group + "/velocities", (*velocities)[i]);
        }
        if (m_layout.capacity > 0) {
            // The frame's data reaches the file before the count that includes it.
            m_writer.flush();
            m_writer.update_attribute("/", "frame_count", std::int64_t(m_frames + 1));
            m_writer.flush();
        }
    } catch (...) {
        m_failed = true; // the series may now differ in length
        throw;
    }
    m_last_time = time;
    ++m_frames;
}

void TrajectoryWriter::commit()
{
    if (m_failed)
        throw_error("{}: cannot commit: an earlier append failed", path());
    m_writer.update_attribute("/", "frame_count", std::int64_t(m_frames));
    m_writer.commit();
}

TrajectoryReader::TrajectoryReader(std::string path)
    : m_reader(std::move(path))
{
    m_version = m_reader.require_format(trajectory_format_name, trajectory_format_version);
    const VecX rows = m_reader.read_vector("time");
    Index frames = rows.size();
    if (m_version >= 2 || m_reader.has_attribute("/", "frame_count")) {
        const std::int64_t count = m_reader.read_int_attribute("/", "frame_count");
        if (count < 0 || count > rows.size() || (m_version < 2 && count != rows.size()))
            throw_error("{}: attribute 'frame_count' is {}, expected 0 to the {} rows of '/time'",
                m_reader.path(), count, rows.size());
        frames = Index(count);
    }
    const Index row_count = rows.size();
    m_times = rows.head(frames);
    for (Index i = 0; i < frames; ++i)
        if (!std::isfinite(m_times[i]) || (i > 0 && !(m_times[i] > m_times[i - 1])))
            throw_error("{}: dataset '/time': frame {} has time {}, expected finite and "
                        "increasing times",
                m_reader.path(), i, m_times[i]);

    // Objects, ordered by their `index` attribute (HDF5 lists them by name).
    std::vector<std::pair<std::int64_t, std::string>> indexed;
    for (const std::string& name : m_reader.list("objects"))
        indexed.emplace_back(m_reader.read_int_attribute("/objects/" + name, "index"), name);
    std::sort(indexed.begin(), indexed.end());
    for (std::size_t i = 0; i < indexed.size(); ++i)
        if (indexed[i].first != std::int64_t(i))
            throw_error("{}: group '/objects/{}' has index {}, expected the objects' indices to "
                        "be 0 to {}",
                m_reader.path(), indexed[i].second, indexed[i].first, indexed.size() - 1);

    for (std::size_t i = 0; i < indexed.size(); ++i) {
        const std::string& name = indexed[i].second;
        const std::string group = "/objects/" + name;
        const std::vector<Index> rest_shape = m_reader.shape(group + "/rest_positions");
        if (rest_shape.size() != 2 || rest_shape[1] != 3 || rest_shape[0] < 1)
            throw_error("{}: dataset '{}/rest_positions' has shape {}, expected #V x 3",
                m_reader.path(), group, fmt::join(rest_shape, " x "));
        const Index num_vertices = rest_shape[0];
        const MatX3i object_faces = m_reader.read<MatX3i>(group + "/faces");
        for (Index f = 0; f < object_faces.rows(); ++f)
            for (int k = 0; k < 3; ++k)
                if (object_faces(f, k) < 0 || object_faces(f, k) >= num_vertices)
                    throw_error("{}: dataset '{}/faces': face {} has vertex index {}, expected 0 "
                                "to {}",
                        m_reader.path(), group, f, object_faces(f, k), num_vertices - 1);
        const bool object_velocities = m_reader.has(group + "/velocities");
        if (i > 0 && object_velocities != m_velocities)
            throw_error("{}: '{}' {} velocities, unlike the objects before it", m_reader.path(),
                group, object_velocities ? "has" : "has no");
        m_velocities = object_velocities;
        for (const char* series : { "positions", "velocities" }) {
            const std::string dataset = group + "/" + series;
            if (!m_reader.has(dataset))
                continue;
            const std::vector<Index> expected { row_count, num_vertices, 3 };
            if (m_reader.shape(dataset) != expected)
                throw_error("{}: dataset '{}' has shape {}, expected {} x {} x 3 (rows of "
                            "'/time' x vertices x 3)",
                    m_reader.path(), dataset, fmt::join(m_reader.shape(dataset), " x "), row_count,
                    num_vertices);
        }
        if (!m_reader.has(group + "/positions"))
            throw_error("{}: no dataset '{}/positions'", m_reader.path(), group);
        m_names.push_back(name);
        m_vertex_counts.push_back(num_vertices);
    }
}

std::string TrajectoryReader::options() const
{
    return m_reader.read_string("options");
}

Index TrajectoryReader::object_index(const std::string& name) const
{
    const auto found = std::find(m_names.begin(), m_names.end(), name);
    if (found == m_names.end())
        throw_error("{}: no object '{}' (the file has {})", m_reader.path(), name,
            m_names.empty() ? std::string("none") : fmt::format("{}", fmt::join(m_names, ", ")));
    return Index(found - m_names.begin());
}

std::string TrajectoryReader::group(Index object) const
{
    if (object < 0 || object >= object_count())
        throw_error("{}: object {} does not exist (the file has {} objects)", m_reader.path(),
            object, object_count());
    return "/objects/" + m_names[std::size_t(object)];
}

void TrajectoryReader::check_index(Index object, Index frame) const
{
    group(object);
    if (frame < 0 || frame >= frame_count())
        throw_error("{}: frame {} does not exist (the file has {} frames)", m_reader.path(), frame,
            frame_count());
}

Index TrajectoryReader::vertex_count(Index object) const
{
    group(object);
    return m_vertex_counts[std::size_t(object)];
}

MatX3i TrajectoryReader::faces(Index object) const
{
    return m_reader.read<MatX3i>(group(object) + "/faces");
}

MatX3 TrajectoryReader::rest_positions(Index object) const
{
    return m_reader.read<MatX3>(group(object) + "/rest_positions", vertex_count(object));
}

MatX3 TrajectoryReader::positions(Index object, Index frame) const
{
    check_index(object, frame);
    return m_reader.read_series_item(group(object) + "/positions", frame, vertex_count(object), 3);
}

MatX3 TrajectoryReader::velocities(Index object, Index frame) const
{
    check_index(object, frame);
    if (!m_velocities)
        throw_error("{}: the trajectory holds no velocities", m_reader.path());
    return m_reader.read_series_item(group(object) + "/velocities", frame, vertex_count(object), 3);
}

void copy_frames(const TrajectoryReader& from, TrajectoryWriter& to, Index count)
{
    // The writer checks the objects' count and vertex counts on append (names: the caller's).
    if (count > from.frame_count())
        throw_error("{}: holds {} frames, {} are needed", from.path(), from.frame_count(), count);
    std::vector<MatX3> positions(std::size_t(from.object_count()));
    std::vector<MatX3> velocities(positions.size());
    for (Index f = 0; f < count; ++f) {
        for (Index o = 0; o < from.object_count(); ++o) {
            positions[std::size_t(o)] = from.positions(o, f);
            if (from.has_velocities())
                velocities[std::size_t(o)] = from.velocities(o, f);
        }
        to.append(from.times()(f), positions, from.has_velocities() ? &velocities : nullptr);
    }
}

} // namespace mat
