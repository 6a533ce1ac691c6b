#pragma once
// Structure-aware fuzzing of the HDF5 readers (docs/building.md, Fuzzing): a "recipe" is a
// compact binary list of HDF5 objects (groups, datasets, attributes) that always builds a VALID
// HDF5 file through H5Writer, whatever bytes the fuzzer mutated. The readers then see
// well-formed containers with wrong content: missing or extra datasets, wrong ranks, shapes and
// types, NaN, huge or negative values, counts that disagree between datasets, bad indices.
//
// Records, one after the other (integers little-endian; an input that ends early reads zeros):
//   u8 op, path (u8 length + bytes), then by op % 8:
//   0 group          (nothing more)
//   1 float64 data   shape, then one f64 per value
//   2 int32 data     shape, then one i32 per value
//   3 int64 data     shape, then one i64 per value
//   4 text dataset   u16 length + bytes
//   5 text attribute   on the object at path: name (u8 length + bytes), u16 length + bytes
//   6 int64 attribute  name, u8 count code (count = code % 3 + 1; 1 = scalar), i64 values
//   7 float64 attribute name, f64 value
//   shape: u8 rank code, rank = code % 3 + 1, then u16 per dimension; rank 1 = vector,
//   2 = matrix, 3 = a series of rows x cols items (float64 only; integer data of rank 3 is
//   written as the matrix of its first two dimensions). A series with code / 3 % 4 = s > 0
//   reserves s items past those written (H5Writer::create_series's capacity).
// A record the writer refuses (a bad path, a dataset that exists) is skipped; so is a record of
// more than 2^18 values or a series of more than 256 items, or one that reads past the
// recipe's end once 64 KiB of zeros were read there (building a file costs time in proportion
// to the recipe).

#include <cstdint>
#include <string>
#include <vector>

namespace mat::fuzz {

/// Builds the HDF5 file of `recipe` at `path`. Returns false if not even an empty file could
/// be written (then there is no file to read).
bool build_h5_from_recipe(const std::uint8_t* data, std::size_t size, const std::string& path);

/// The recipe of an existing HDF5 file made by H5Writer (groups, 1-D to 3-D datasets of
/// integers or floats, text datasets, scalar attributes, CSR groups' shape attributes), for
/// turning real bakes and trajectories into seeds.
std::vector<std::uint8_t> recipe_from_h5(const std::string& path);

} // namespace mat::fuzz
