#pragma once
// Large, long-lived buffers backed by huge pages (docs/method.md, "Pages and wake-ups"). On a
// virtual machine whose first touch of each 4 KiB page traps into the hypervisor (12.6 us a page
// measured on the 2-core development machine, where writing the page costs well under 1 us), a
// buffer written for the first time costs more in page faults than in the writes. A transparent
// huge page (2 MiB) takes one fault for 512 such pages.

#include <algorithm>
#include <cstddef>
#include <cstdlib>
#include <memory>

#include "common/eigen_types.hpp"

namespace mat {

/// Buffers smaller than this are left to small pages: a huge page is zeroed whole when first
/// touched, so it pays only where most of it will be written.
constexpr std::size_t huge_page_min_bytes = std::size_t { 4 } << 20;

/// `count` doubles, uninitialized (as Eigen's storage), 64-byte aligned; from `min_bytes`
/// (huge_page_min_bytes, or less for a buffer that is written whole at once) up, 2 MiB-aligned, a
/// whole number of 2 MiB pages, and advised for transparent huge pages (Linux madvise
/// MADV_HUGEPAGE). The advice is a hint only: the contents and every result are the same whether
/// the kernel grants it or not (and where it is not Linux).
class HugePageBuffer {
public:
    HugePageBuffer() = default;
    explicit HugePageBuffer(std::size_t count, std::size_t min_bytes = huge_page_min_bytes);
    double* data() const { return m_data.get(); }
    std::size_t size() const { return m_size; }

private:
    struct Free {
        void operator()(double* p) const { std::free(p); }
    };
    std::unique_ptr<double[], Free> m_data;
    std::size_t m_size = 0;
};

/// Columns of `rows` doubles per block of a pool of columns: at least 64, and as many as fill
/// huge_page_min_bytes (so that the block takes huge pages).
inline Index huge_block_columns(Index rows)
{
    const Index column = static_cast<Index>(sizeof(double)) * std::max<Index>(1, rows);
    return std::max<Index>(64, (static_cast<Index>(huge_page_min_bytes) + column - 1) / column);
}

/// A column-major rows x cols block of doubles in a HugePageBuffer (uninitialized).
class HugePageBlock {
public:
    HugePageBlock() = default;
    HugePageBlock(Index rows, Index cols, std::size_t min_bytes = huge_page_min_bytes)
        : m_storage(static_cast<std::size_t>(rows * cols), min_bytes)
        , m_rows(rows)
        , m_cols(cols)
    {
    }
    Index rows() const { return m_rows; }
    Index cols() const { return m_cols; }
    double* col(Index c) const { return m_storage.data() + c * m_rows; }
    double& operator()(Index r, Index c) const { return m_storage.data()[c * m_rows + r]; }

private:
    HugePageBuffer m_storage;
    Index m_rows = 0;
    Index m_cols = 0;
};

} // namespace mat
