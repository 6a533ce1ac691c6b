#pragma once
// Random mutations of a valid text file, for "garbage never crashes" tests of the text readers.

#include <random>
#include <string>
#include <string_view>

namespace mat::test {

/// How many kinds of mutation mutate_text knows (kinds 0 .. num_text_mutations - 1).
constexpr int num_text_mutations = 5;

/// `text` mutated by one kind of change, drawing from `rng`:
///   0: truncated at a random length;
///   1: 1 to 4 bytes replaced by characters of `alphabet` (format-like noise);
///   2: 1 to 4 raw random bytes replaced, inserted or erased;
///   3: a random line duplicated or dropped;
///   4 (and any other): replaced by up to 199 bytes, half from `alphabet`, half random.
std::string mutate_text(std::string text, std::mt19937& rng, int kind, std::string_view alphabet);

} // namespace mat::test
