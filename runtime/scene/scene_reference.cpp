// The reference of the scene format (scene_keys, scene_reference_markdown), generated from the
// key table.

#include "runtime/scene/scene.hpp"

#include <string>
#include <vector>

#include <fmt/format.h>

#include "runtime/scene/scene_schema.hpp"

namespace mat::scene_schema {

namespace {

    std::string quoted_list(const std::vector<std::string>& values)
    {
        std::string text;
        for (const std::string& value : values)
            text += (text.empty() ? "\"" : ", \"") + value + "\"";
        return text;
    }

    std::string escape_cell(const std::string& text)
    {
        std::string out;
        for (char c : text) {
            if (c == '|')
                out += '\\';
            out += c;
        }
        return out;
    }

} // namespace

std::string type_text(const KeySpec& key)
{
    std::string limits = key.limits.text();
    if (key.limits.lower && key.limits.upper)
        limits = "in " + limits;
    const std::string suffix = limits.empty() ? "" : " " + limits;
    switch (key.type) {
    case Type::number:
        return "number" + suffix;
    case Type::integer:
        return "integer" + suffix;
    case Type::vec3:
        return "[x, y, z]";
    case Type::string:
        return key.choices.empty() ? "string" : "one of " + quoted_list(key.choices);
    case Type::path:
        return "path";
    case Type::strings:
        return std::string(key.accept_single ? "string or list of strings" : "list of strings")
            + " from " + quoted_list(key.choices);
    case Type::integers:
        return "list of integers" + suffix;
    case Type::interval:
        return "[min, max]";
    case Type::section:
        return "section";
    case Type::section_array:
        return "list of sections";
    }
    return "";
}

std::string default_text(const KeySpec& key)
{
    if (key.required)
        return "required";
    if (!key.default_doc.empty())
        return key.default_doc;
    if (key.default_value.is_null())
        return "none";
    return short_json(key.default_value);
}

} // namespace mat::scene_schema

namespace mat {

std::vector<SceneKeyInfo> scene_keys()
{
    std::vector<SceneKeyInfo> keys;
    for (const scene_schema::KeySpec& key : scene_schema::key_table())
        keys.push_back({ scene_schema::section_path(key.section), key.name,
            scene_schema::type_text(key), scene_schema::default_text(key), key.doc });
    return keys;
}

std::string scene_reference_markdown()
{
    std::string text = "A scene is a JSON object; units are SI. Unknown keys are errors. Bake "
                       "paths are relative to the scene file's directory. Pin regions are in "
                       "the bake's coordinates.\n";
    std::string section;
    bool first = true;
    for (const SceneKeyInfo& key : scene_keys()) {
        if (first || key.section != section) {
            section = key.section;
            first = false;
            text
                += fmt::format("\n### {}\n\n", section.empty() ? "Top level" : "`" + section + "`");
            text += "| key | type | default | doc |\n| --- | --- | --- | --- |\n";
        }
        text += fmt::format("| `{}` | {} | {} | {} |\n", key.key,
            scene_schema::escape_cell(key.type), scene_schema::escape_cell(key.default_value),
            scene_schema::escape_cell(key.doc));
    }
    return text;
}

} // namespace mat
