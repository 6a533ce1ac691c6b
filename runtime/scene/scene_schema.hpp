#pragma once
// Internal to runtime/scene: the one table of scene keys (scene_schema.cpp) and the types that
// describe a key. Each key says which section it belongs to, its value type, its range or
// choices, its default (or that it is required, or that it has none) and its doc, and holds the
// binding that stores a checked value into the Scene structs. The parser (scene.cpp), the
// Markdown reference and scene_keys() all walk this table.

#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include <nlohmann/json.hpp>

#include "runtime/scene/scene.hpp"

namespace mat::scene_schema {

using Json = nlohmann::json;

/// The objects of a scene file, each filled by the keys declared for it.
enum class Section {
    root,
    time,
    solver,
    object,
    material,
    pin,
    box,
    sphere,
    keyframe,
    object_keyframe,
    collider,
    output,
};

enum class Type {
    number, ///< finite double
    integer, ///< integral number that fits an int
    vec3, ///< array of exactly 3 numbers
    string,
    path, ///< string, resolved against the scene's directory
    strings, ///< list of distinct strings from `choices`; with `accept_single`, a string too
    integers, ///< list of integers (limits apply to each)
    interval, ///< [min, max], two numbers
    section, ///< a JSON object, filled by the keys of `child`
    section_array, ///< a JSON array of such objects
};

/// Where a key's value is stored: the struct the current section fills.
using Target
    = std::variant<Scene*, TimeSettings*, SolverSettings*, ObjectSettings*, MaterialSettings*,
        PinRegion*, PinBox*, PinSphere*, PinKeyframe*, ColliderSettings*, OutputSettings*>;
/// A checked value, converted to its C++ type.
using Value = std::variant<double, int, Vec3, std::string, std::vector<std::string>,
    std::vector<int>, Vec2>;

/// Numeric limits of a number, an integer or each element of a list.
struct Limits {
    std::optional<double> lower;
    bool lower_open = false; ///< lower bound excluded
    std::optional<double> upper;
    bool upper_open = false; ///< upper bound excluded

    bool contains(double value) const;
    /// "[0, 0.5)", "> 0", ">= 1"; "" without bounds.
    std::string text() const;
};

/// A check beyond type and limits; returns "" if `value` is fine, else the problem.
using Check = std::function<std::string(const Value& value)>;

struct KeySpec {
    Section section = Section::root;
    std::string name;
    Type type = Type::number;
    bool required = false;
    Json default_value; ///< null: no default (the key is optional and absent means "none")
    std::string default_doc; ///< the default as the reference shows it, if not default_value
    Limits limits;
    std::vector<std::string> choices; ///< allowed strings
    bool accept_single = false; ///< strings: a single string stands for a list of one
    int min_count = 0; ///< section_array / strings: minimum number of elements
    Check check;
    std::string doc;
    Section child = Section::root; ///< section, section_array: the section of the value
    /// Stores a checked value (all types but section, section_array).
    std::function<void(Target, const Value&)> store;
    /// section: the sub-struct; section_array: a new element appended to the vector.
    std::function<Target(Target)> open;

    // Builder steps, used by the table.
    KeySpec& set_required()
    {
        required = true;
        return *this;
    }
    KeySpec& set_default(Json value, std::string doc_text = "")
    {
        default_value = std::move(value);
        default_doc = std::move(doc_text);
        return *this;
    }
    KeySpec& set_default_doc(std::string doc_text)
    {
        default_doc = std::move(doc_text);
        return *this;
    }
    KeySpec& above(double bound) { return set_lower(bound, true); }
    KeySpec& at_least(double bound) { return set_lower(bound, false); }
    KeySpec& below(double bound) { return set_upper(bound, true); }
    KeySpec& at_most(double bound) { return set_upper(bound, false); }
    KeySpec& set_lower(double bound, bool open)
    {
        limits.lower = bound;
        limits.lower_open = open;
        return *this;
    }
    KeySpec& set_upper(double bound, bool open)
    {
        limits.upper = bound;
        limits.upper_open = open;
        return *this;
    }
    KeySpec& set_choices(std::vector<std::string> values)
    {
        choices = std::move(values);
        return *this;
    }
    KeySpec& set_accept_single()
    {
        accept_single = true;
        return *this;
    }
    KeySpec& set_min_count(int count)
    {
        min_count = count;
        return *this;
    }
    KeySpec& set_check(Check function)
    {
        check = std::move(function);
        return *this;
    }
    KeySpec& set_doc(std::string text)
    {
        doc = std::move(text);
        return *this;
    }
};

/// The table: every key of the scene format, grouped by section, in reference order.
const std::vector<KeySpec>& key_table();

/// The path of a section as the reference writes it: "" (root), "time", "objects[]",
/// "objects[].pins[].box", ... (derived from the section keys of the table).
std::string section_path(Section section);

/// The type of a key as the reference writes it, e.g. "number > 0", "list of strings".
std::string type_text(const KeySpec& key);

/// The default of a key as the reference writes it: "required", "none", or the value.
std::string default_text(const KeySpec& key);

/// The key path of `key` in the section at `path` ("" = the top level): "time.dt".
std::string join_key(const std::string& path, const std::string& key);

/// The key path of element `index` of the list at `path`: "objects[2]".
std::string element_path(const std::string& path, std::size_t index);

/// A JSON value in one short line for messages and docs: numbers as %g-like shortest form,
/// strings quoted, containers "[a, b]"; cut to about `max_length` characters.
std::string short_json(const Json& value, std::size_t max_length = 60);

} // namespace mat::scene_schema
