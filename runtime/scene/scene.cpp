#include "runtime/scene/scene.hpp"

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "common/error.hpp"
#include "common/log.hpp"
#include "runtime/scene/scene_json.hpp"
#include "runtime/scene/scene_schema.hpp"

namespace mat {

namespace {

    using namespace scene_schema;
    namespace fs = std::filesystem;

    /// What a JSON value is, for "expected X, got Y" messages.
    std::string describe(const Json& value)
    {
        switch (value.type()) {
        case Json::value_t::null:
            return "null";
        case Json::value_t::boolean:
            return "the boolean " + short_json(value);
        case Json::value_t::string:
            return "the string " + short_json(value);
        case Json::value_t::array:
            return fmt::format(
                "a list of {} element{}", value.size(), value.size() == 1 ? "" : "s");
        case Json::value_t::object:
            return "a section (JSON object)";
        default:
            return "the number " + short_json(value);
        }
    }

    /// Walks a scene's JSON along the key table.
    class Parser {
    public:
        Parser(const std::string& file, const SceneOptions& options)
            : m_file(file)
            , m_options(options)
        {
            const fs::path parent = fs::path(file).parent_path();
            m_base_dir = parent.empty() ? fs::path(".") : parent;
        }

        Scene parse(const Json& root)
        {
            Scene scene;
            scene.file = m_file;
            if (!root.is_object())
                throw_error(
                    "{}: expected a JSON object at the top level, got {}", m_file, describe(root));
            parse_section(Section::root, root, "", &scene, 0);
            return scene;
        }

    private:
        template <typename... Args>
        [[noreturn]] void fail(
            const std::string& path, fmt::format_string<Args...> format, Args&&... args) const
        {
            throw_error(
                "{}: {}: {}", m_file, path, fmt::format(format, std::forward<Args>(args)...));
        }

        bool given(const std::string& path) const { return m_given.count(path) > 0; }

        /// Fills `target` from `object` by the keys of `section`; `index` is the element's index
        /// when the section is an element of a list.
        void parse_section(Section section, const Json& object, const std::string& path,
            Target target, std::size_t index)
        {
            for (const auto& item : object.items()) {
                bool known = false;
                for (const KeySpec& key : key_table())
                    known = known || (key.section == section && key.name == item.key());
                if (!known)
                    fail(join_key(path, item.key()), "unknown key (expected {})",
                        key_names(section));
            }
            for (const KeySpec& key : key_table()) {
                if (key.section != section)
                    continue;
                const std::string key_path = join_key(path, key.name);
                const auto found = object.find(key.name);
                if (found != object.end()) {
                    m_given.insert(key_path);
                    read_value(key, *found, key_path, target);
                } else if (key.required) {
                    fail(key_path, "missing required key");
                } else if (!key.default_value.is_null()) {
                    read_value(key, key.default_value, key_path, target);
                }
            }
            finish(section, path, target, index);
        }

        std::string key_names(Section section) const
        {
            std::string names;
            for (const KeySpec& key : key_table())
                if (key.section == section)
                    names += (names.empty() ? "" : ", ") + key.name;
            return names;
        }

        void read_value(
            const KeySpec& key, const Json& value, const std::string& path, Target target)
        {
            if (key.type == Type::section) {
                if (!value.is_object())
                    fail(path, "expected a section (JSON object), got {}", describe(value));
                parse_section(key.child, value, path, key.open(target), 0);
                return;
            }
            if (key.type == Type::section_array) {
                if (!value.is_array())
                    fail(path, "expected a list of sections, got {}", describe(value));
                check_count(key, value, path);
                for (std::size_t i = 0; i < value.size(); ++i) {
                    const std::string item_path = element_path(path, i);
                    if (!value[i].is_object())
                        fail(item_path, "expected a section (JSON object), got {}",
                            describe(value[i]));
                    parse_section(key.child, value[i], item_path, key.open(target), i);
                }
                return;
            }
            const Value converted = convert(key, value, path);
            if (key.check) {
                const std::string problem = key.check(converted);
                if (!problem.empty())
                    fail(path, "{}", problem);
            }
            key.store(target, converted);
        }

        void check_count(const KeySpec& key, const Json& list, const std::string& path) const
        {
            if (list.size() < static_cast<std::size_t>(key.min_count))
                fail(path, "expected at least {} element{}, got {}", key.min_count,
                    key.min_count == 1 ? "" : "s", list.size());
        }

        double number(const Json& value, const std::string& path, const Limits& limits) const
        {
            if (!value.is_number())
                fail(path, "expected a number, got {}", describe(value));
            const double x = value.get<double>();
            if (!std::isfinite(x))
                fail(path, "{} is not finite", x);
            check_limits(x, path, limits);
            return x;
        }

        int integer(const Json& value, const std::string& path, const Limits& limits) const
        {
            if (!value.is_number())
                fail(path, "expected an integer, got {}", describe(value));
            double x = 0.0;
            if (value.is_number_unsigned()) {
                const auto u = value.get<std::uint64_t>();
                if (u > static_cast<std::uint64_t>(INT_MAX))
                    fail(path, "{} is too large for an integer", u);
                x = static_cast<double>(u);
            } else if (value.is_number_integer()) {
                const auto i = value.get<std::int64_t>();
                if (i > INT_MAX || i < INT_MIN)
                    fail(path, "{} is too large for an integer", i);
                x = static_cast<double>(i);
            } else {
                x = value.get<double>();
                if (!std::isfinite(x) || std::floor(x) != x)
                    fail(path, "{} is not an integer", x);
                if (x > INT_MAX || x < INT_MIN)
                    fail(path, "{} is too large for an integer", x);
            }
            check_limits(x, path, limits);
            return static_cast<int>(x);
        }

        void check_limits(double x, const std::string& path, const Limits& limits) const
        {
            if (limits.contains(x))
                return;
            if (limits.lower && limits.upper)
                fail(path, "{} is out of range {}", x, limits.text());
            fail(path, "{} is out of range: must be {}", x, limits.text());
        }

        Value convert(const KeySpec& key, const Json& value, const std::string& path) const
        {
            switch (key.type) {
            case Type::number:
                return number(value, path, key.limits);
            case Type::integer:
                return integer(value, path, key.limits);
            case Type::vec3: {
                if (!value.is_array() || value.size() != 3)
                    fail(path, "expected [x, y, z] (a list of 3 numbers), got {}", describe(value));
                Vec3 v;
                for (int i = 0; i < 3; ++i)
                    v[i] = number(value[i], element_path(path, i), key.limits);
                return v;
            }
            case Type::interval: {
                if (!value.is_array() || value.size() != 2)
                    fail(
                        path, "expected [min, max] (a list of 2 numbers), got {}", describe(value));
                return Vec2(number(value[0], element_path(path, 0), key.limits),
                    number(value[1], element_path(path, 1), key.limits));
            }
            case Type::string: {
                if (!value.is_string())
                    fail(path, "expected a string, got {}", describe(value));
                std::string text = value.get<std::string>();
                check_choice(key, text, path);
                return text;
            }
            case Type::path:
                return resolve_path(value, path);
            case Type::strings: {
                if (key.accept_single && value.is_string()) {
                    std::string text = value.get<std::string>();
                    check_choice(key, text, path);
                    return std::vector<std::string> { text };
                }
                if (!value.is_array())
                    fail(path, "expected {}, got {}", type_text(key), describe(value));
                check_count(key, value, path);
                std::vector<std::string> texts;
                for (std::size_t i = 0; i < value.size(); ++i) {
                    const std::string item_path = element_path(path, i);
                    if (!value[i].is_string())
                        fail(item_path, "expected a string, got {}", describe(value[i]));
                    std::string text = value[i].get<std::string>();
                    check_choice(key, text, item_path);
                    if (std::find(texts.begin(), texts.end(), text) != texts.end())
                        fail(item_path, "{} is listed twice", short_json(value[i]));
                    texts.push_back(std::move(text));
                }
                return texts;
            }
            case Type::integers: {
                if (!value.is_array())
                    fail(path, "expected a list of integers, got {}", describe(value));
                check_count(key, value, path);
                std::vector<int> values;
                for (std::size_t i = 0; i < value.size(); ++i)
                    values.push_back(integer(value[i], element_path(path, i), key.limits));
                return values;
            }
            case Type::section:
            case Type::section_array:
                break;
            }
            MAT_CHECK(false, "scene parser: unhandled key type");
            return 0.0;
        }

        void check_choice(
            const KeySpec& key, const std::string& text, const std::string& path) const
        {
            if (key.choices.empty()
                || std::find(key.choices.begin(), key.choices.end(), text) != key.choices.end())
                return;
            std::string choices;
            for (const std::string& choice : key.choices)
                choices += (choices.empty() ? "" : ", ") + choice;
            fail(path, "{} is not one of {}", short_json(Json(text)), choices);
        }

        std::string resolve_path(const Json& value, const std::string& path) const
        {
            if (!value.is_string())
                fail(path, "expected a path (string), got {}", describe(value));
            const std::string text = value.get<std::string>();
            if (text.empty())
                fail(path, "the path is empty");
            std::error_code ec;
            fs::path resolved = fs::absolute(m_base_dir / fs::path(text), ec);
            if (ec)
                fail(path, "cannot resolve {}: {}", text, ec.message());
            resolved = resolved.lexically_normal();
            if (m_options.check_files) {
                const fs::file_status status = fs::status(resolved, ec);
                if (!fs::exists(status))
                    fail(path, "file not found: {}", resolved.string());
                if (fs::is_directory(status))
                    fail(path, "{} is a directory, expected a file", resolved.string());
            }
            return resolved.string();
        }

        /// Checks that involve several keys of a section, and derived values.
        void finish(Section section, const std::string& path, Target target, std::size_t index)
        {
            switch (section) {
            case Section::root:
                finish_root(*std::get<Scene*>(target));
                break;
            case Section::object: {
                ObjectSettings& object = *std::get<ObjectSettings*>(target);
                if (!given(join_key(path, "name")))
                    object.name = fmt::format("object{}", index);
                finish_object(object, path);
                break;
            }
            case Section::pin:
                finish_pin(*std::get<PinRegion*>(target), path);
                break;
            case Section::box: {
                const PinBox& box = *std::get<PinBox*>(target);
                for (int axis = 0; axis < 3; ++axis)
                    if (box.min[axis] > box.max[axis])
                        fail(join_key(path, "max"), "{} is below min {} along {}", box.max[axis],
                            box.min[axis], "xyz"[axis]);
                break;
            }
            case Section::collider: {
                ColliderSettings& collider = *std::get<ColliderSettings*>(target);
                // Scaled first: the squared norm of [1e300, 1e300, 0] overflows to infinity.
                collider.normal.stableNormalize();
                break;
            }
            default:
                break;
            }
        }

        void finish_pin(PinRegion& pin, const std::string& path) const
        {
            std::vector<std::string> kinds;
            for (const char* kind : { "box", "sphere", "nodes" })
                if (given(join_key(path, kind)))
                    kinds.emplace_back(kind);
            if (kinds.size() != 1)
                fail(path, "a pin region needs exactly one of box, sphere, nodes; got {}",
                    kinds.empty() ? std::string("none")
                                  : fmt::format("{}", fmt::join(kinds, " and ")));
            pin.kind = kinds[0] == "box" ? PinKind::box
                : kinds[0] == "sphere"   ? PinKind::sphere
                                         : PinKind::nodes;
            check_keyframe_times(pin.motion, join_key(path, "motion"));
        }

        void finish_object(const ObjectSettings& object, const std::string& path) const
        {
            const std::string keyframes = join_key(path, "keyframes");
            if (object.motion != ObjectMotion::kinematic) {
                if (given(keyframes))
                    fail(keyframes, "only a kinematic object has keyframes (motion is \"{}\")",
                        motion_name(object.motion));
                return;
            }
            if (!object.pins.empty())
                fail(join_key(path, "pins"),
                    "a kinematic object moves rigidly as prescribed: it cannot have pins");
            if (!object.keyframes.empty()) {
                for (const char* key : { "velocity", "angular_velocity" })
                    if (given(join_key(path, key)))
                        fail(join_key(path, key),
                            "a kinematic object with keyframes moves by them: give keyframes or "
                            "velocity and angular_velocity, not both");
            }
            check_keyframe_times(object.keyframes, keyframes);
        }

        void check_keyframe_times(
            const std::vector<PinKeyframe>& keys, const std::string& list_path) const
        {
            for (std::size_t i = 1; i < keys.size(); ++i)
                if (!(keys[i].time > keys[i - 1].time))
                    fail(join_key(element_path(list_path, i), "time"),
                        "{} is not after the previous keyframe's time {}", keys[i].time,
                        keys[i - 1].time);
        }

        void finish_root(Scene& scene) const
        {
            std::map<std::string, std::size_t> names;
            for (std::size_t i = 0; i < scene.objects.size(); ++i) {
                const auto [it, inserted] = names.emplace(scene.objects[i].name, i);
                if (!inserted)
                    fail(join_key(element_path("objects", i), "name"),
                        "{} is already the name of objects[{}]",
                        short_json(Json(scene.objects[i].name)), it->second);
            }

            const TimeSettings& time = scene.time;
            if (given("time.frames") && time.duration)
                fail("time.duration", "cannot be combined with time.frames (give one of them)");
            if (time.fps && given("output.every"))
                fail("time.fps", "cannot be combined with output.every (give one of them)");

            int steps = scene.output.every;
            if (time.fps) {
                const double ratio = 1.0 / (*time.fps * time.dt);
                const double rounded = std::round(ratio);
                if (rounded < 1.0)
                    fail("time.fps", "{} with dt {} gives {} steps per frame; need at least 1",
                        *time.fps, time.dt, ratio);
                if (!(rounded <= INT_MAX))
                    fail("time.fps", "{} with dt {} gives too many steps per frame ({})", *time.fps,
                        time.dt, ratio);
                if (std::abs(ratio - rounded) > 1e-6 * ratio)
                    fail("time.fps",
                        "1 / (fps * dt) = {} steps per frame is not a whole number (to 1e-6 "
                        "relative); choose fps and dt so that it is",
                        ratio);
                steps = static_cast<int>(rounded);
            }

            int frames = time.frames;
            if (time.duration) {
                const double frame_interval = steps * time.dt;
                const double count = std::round(*time.duration / frame_interval);
                if (count < 1.0)
                    fail("time.duration", "{} s is less than half a frame interval ({} s)",
                        *time.duration, frame_interval);
                if (!(count <= INT_MAX))
                    fail("time.duration", "{} s gives too many frames", *time.duration);
                frames = static_cast<int>(count);
            }
            scene.steps_per_frame = steps;
            scene.frames = frames;
            scene.time.frames = frames;
            scene.output.every = steps;
        }

        std::string m_file;
        SceneOptions m_options;
        fs::path m_base_dir;
        std::set<std::string> m_given; ///< key paths present in the file
    };

} // namespace

bool scene_collides(const Scene& scene)
{
    return scene.solver.collision != CollisionMode::off
        && (scene.objects.size() > 1 || scene.solver.self_collision);
}

const char* motion_name(ObjectMotion motion)
{
    switch (motion) {
    case ObjectMotion::static_:
        return "static";
    case ObjectMotion::kinematic:
        return "kinematic";
    case ObjectMotion::dynamic:
        break;
    }
    return "dynamic";
}

Scene parse_scene(
    const std::string& json_text, const std::string& path_for_messages, const SceneOptions& options)
{
    const Json root = parse_scene_json(json_text, path_for_messages);
    Scene scene = Parser(path_for_messages, options).parse(root);
    logger().debug("{}: {} object(s), {} collider(s), {} frames of {} step(s) of {} s",
        path_for_messages, scene.objects.size(), scene.colliders.size(), scene.frames,
        scene.steps_per_frame, scene.time.dt);
    return scene;
}

Scene read_scene(const std::string& path, const SceneOptions& options)
{
    std::error_code ec;
    if (std::filesystem::is_directory(path, ec))
        throw_error("{}: cannot read the scene: it is a directory", path);
    std::ifstream in(path, std::ios::binary);
    if (!in)
        throw_error("{}: cannot open the scene: {}", path, std::strerror(errno));
    std::ostringstream text;
    text << in.rdbuf();
    if (in.bad())
        throw_error("{}: read error", path);
    return parse_scene(text.str(), path, options);
}

} // namespace mat
