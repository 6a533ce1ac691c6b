#pragma once
// Counts the program's calls of the global operator new (std containers; Eigen allocates with
// malloc and is not counted), for tests and benchmarks that check a loop allocates nothing.
// Link tests/support/allocation_counter.cpp into the one executable that uses it: it replaces
// the global operator new and delete.

namespace mat::test {

/// Calls of operator new so far.
long allocation_count();

} // namespace mat::test
