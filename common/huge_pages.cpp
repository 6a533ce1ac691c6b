#include "common/huge_pages.hpp"

#include <new>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace mat {

HugePageBuffer::HugePageBuffer(std::size_t count, std::size_t min_bytes)
    : m_size(count)
{
    if (count == 0)
        return;
    constexpr std::size_t huge = std::size_t { 2 } << 20;
    const std::size_t bytes = count * sizeof(double);
    const bool large = bytes >= min_bytes;
    const std::size_t align = large ? huge : 64;
    const std::size_t rounded = (bytes + align - 1) / align * align;
    m_data.reset(static_cast<double*>(std::aligned_alloc(align, rounded)));
    if (m_data == nullptr)
        throw std::bad_alloc();
#if defined(MADV_HUGEPAGE)
    if (large)
        // Not granted (huge pages off, or none free): the pages stay small.
        static_cast<void>(madvise(m_data.get(), rounded, MADV_HUGEPAGE));
#endif
}

} // namespace mat
