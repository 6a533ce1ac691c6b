#include "tests/support/text_mutation.hpp"

#include <cstddef>

namespace mat::test {

std::string mutate_text(std::string text, std::mt19937& rng, int kind, std::string_view alphabet)
{
    const auto below = [&](std::size_t n) {
        return n == 0 ? std::size_t(0) : std::uniform_int_distribution<std::size_t>(0, n - 1)(rng);
    };
    switch (kind) {
    case 0:
        text.resize(below(text.size() + 1));
        break;
    case 1:
        for (std::size_t m = 0, n = 1 + below(4); m < n && !text.empty(); ++m)
            text[below(text.size())] = alphabet[below(alphabet.size())];
        break;
    case 2:
        for (std::size_t m = 0, n = 1 + below(4); m < n && !text.empty(); ++m) {
            const std::size_t at = below(text.size());
            const char byte = static_cast<char>(below(256));
            if (m % 3 == 0)
                text[at] = byte;
            else if (m % 3 == 1)
                text.insert(text.begin() + static_cast<std::ptrdiff_t>(at), byte);
            else
                text.erase(at, 1);
        }
        break;
    case 3: {
        const std::size_t at = text.find('\n', below(text.size()));
        const std::size_t end = at == std::string::npos ? text.npos : text.find('\n', at + 1);
        if (at != std::string::npos && end != std::string::npos) {
            const std::string line = text.substr(at, end - at);
            if (below(2) == 0)
                text.insert(end, line);
            else
                text.erase(at, end - at);
        }
        break;
    }
    default:
        text.clear();
        for (std::size_t n = below(200); n > 0; --n)
            text += below(2) ? alphabet[below(alphabet.size())] : static_cast<char>(below(256));
    }
    return text;
}

} // namespace mat::test
