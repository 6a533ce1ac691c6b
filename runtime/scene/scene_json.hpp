#pragma once
// Internal to runtime/scene: JSON text to a nlohmann::json document, with errors a user can act
// on. A syntax error names the line and column (converted from nlohmann's byte offset); a key
// repeated in one object (which nlohmann would silently resolve to the last) is an error naming
// its key path.

#include <string>

#include "runtime/scene/scene_schema.hpp"

namespace mat::scene_schema {

/// Parses `text`; throws mat::Error "<file>: line L, column C: <problem>" on a syntax error, or
/// "<file>: <key path>: duplicate key".
Json parse_scene_json(const std::string& text, const std::string& file);

} // namespace mat::scene_schema
