#include "runtime/scene/scene_json.hpp"

#include <algorithm>
#include <set>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "common/error.hpp"

namespace mat::scene_schema {

namespace {

    /// Line and column (1-based) of the byte at `offset` in `text`.
    std::pair<std::size_t, std::size_t> line_column(const std::string& text, std::size_t offset)
    {
        offset = std::min(offset, text.size());
        std::size_t line = 1;
        std::size_t line_start = 0;
        for (std::size_t i = 0; i < offset; ++i) {
            if (text[i] == '\n') {
                ++line;
                line_start = i + 1;
            }
        }
        return { line, offset - line_start + 1 };
    }

    /// nlohmann's message without its "[json.exception...] parse error at line L, column C: "
    /// prefix (we report our own position).
    std::string json_message(const char* what)
    {
        std::string message = what;
        const std::size_t bracket = message.find("] ");
        if (message.rfind("[json.exception", 0) == 0 && bracket != std::string::npos)
            message = message.substr(bracket + 2);
        const std::size_t column = message.find("column ");
        const std::size_t colon = message.find(": ", column == std::string::npos ? 0 : column);
        if (message.rfind("parse error", 0) == 0 && colon != std::string::npos)
            message = message.substr(colon + 2);
        return message;
    }

} // namespace

Json parse_scene_json(const std::string& text, const std::string& file)
{
    struct Frame {
        bool is_array = false;
        std::size_t index = 0; ///< arrays: elements begun so far
        std::string key; ///< objects: the current key
        std::set<std::string> keys; ///< objects: keys seen
    };
    std::vector<Frame> frames;
    const auto path_of = [&frames](const std::string& last_key) {
        std::string path;
        for (const Frame& frame : frames)
            path = frame.is_array ? element_path(path, frame.index - 1)
                                  : (&frame == &frames.back() ? path : join_key(path, frame.key));
        return join_key(path, last_key);
    };
    const auto callback = [&](int, Json::parse_event_t event, Json& parsed) {
        const bool begins_value = event == Json::parse_event_t::value
            || event == Json::parse_event_t::object_start
            || event == Json::parse_event_t::array_start;
        if (begins_value && !frames.empty() && frames.back().is_array)
            ++frames.back().index;
        switch (event) {
        case Json::parse_event_t::object_start:
        case Json::parse_event_t::array_start:
            frames.emplace_back();
            frames.back().is_array = event == Json::parse_event_t::array_start;
            break;
        case Json::parse_event_t::object_end:
        case Json::parse_event_t::array_end:
            frames.pop_back();
            break;
        case Json::parse_event_t::key: {
            const std::string key = parsed.get<std::string>();
            if (!frames.back().keys.insert(key).second)
                throw_error("{}: {}: duplicate key", file, path_of(key));
            frames.back().key = key;
            break;
        }
        case Json::parse_event_t::value:
            break;
        }
        return true;
    };

    try {
        return Json::parse(text, callback);
    } catch (const Json::parse_error& e) {
        const auto [line, column] = line_column(text, e.byte == 0 ? 0 : e.byte - 1);
        throw_error("{}: line {}, column {}: {}", file, line, column, json_message(e.what()));
    } catch (const Json::exception& e) {
        // e.g. "number overflow parsing '1e999'": no position, so look for the token.
        std::string message = json_message(e.what());
        const std::size_t open = message.find('\'');
        const std::size_t close = message.rfind('\'');
        if (open != std::string::npos && close > open + 1) {
            const std::size_t at = text.find(message.substr(open + 1, close - open - 1));
            if (at != std::string::npos) {
                const auto [line, column] = line_column(text, at);
                throw_error("{}: line {}, column {}: {}", file, line, column, message);
            }
        }
        throw_error("{}: {}", file, message);
    }
}

} // namespace mat::scene_schema
