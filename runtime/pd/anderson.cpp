#include "runtime/pd/anderson.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "common/error.hpp"

namespace mat {

namespace {

    /// Entries per block of a pass over the vector (fixed: the dot products' summation order).
    constexpr Index block_size = 2048;

    Index num_blocks(Index size)
    {
        return (size + block_size - 1) / block_size;
    }

    /// body(first, last) for each block, in parallel.
    template <typename Body> void for_blocks(Index size, const Body& body)
    {
        tbb::parallel_for(tbb::blocked_range<Index>(0, num_blocks(size), 1),
            [&](const tbb::blocked_range<Index>& range) {
                for (Index b = range.begin(); b != range.end(); ++b)
                    body(b, b * block_size, std::min(size, (b + 1) * block_size));
            });
    }

    using SmallMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0,
        anderson_max_window, anderson_max_window>;
    using SmallVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, anderson_max_window, 1>;

} // namespace

void AndersonAcceleration::configure(Index size, int window, const Eigen::Ref<const VecX>& weights)
{
    MAT_CHECK(window >= 1 && window <= anderson_max_window, "anderson: window {} outside [1, {}]",
        window, anderson_max_window);
    MAT_CHECK(weights.size() == size && (weights.array() > 0.0).all(),
        "anderson: {} weights for {} entries (all must be positive)", weights.size(), size);
    m_started = false;
    if (m_weights.data() != weights.data())
        m_weights = weights;
    if (size == m_size && window == m_window)
        return;
    m_size = size;
    m_window = window;
    m_u.resize(size);
    m_f.resize(size);
    m_f_previous.resize(size);
    m_g_previous.resize(size);
    m_df.resize(size, window);
    m_dg.resize(size, window);
    m_gram.resize(window, window);
    m_partial.resize(2 * window, num_blocks(size));
    m_rhs.resize(window);
    m_theta.resize(window);
}

void AndersonAcceleration::start(const double* u)
{
    std::copy(u, u + m_size, m_u.data());
    m_started = true;
    m_has_previous = false;
    m_count = 0;
    m_head = 0;
}

bool AndersonAcceleration::advance(double* g)
{
    MAT_CHECK(m_started, "anderson: advance() before start()");
    // f = g - u; the new differences against the previous residual and G.
    const bool add = m_has_previous;
    const int j = m_head;
    for_blocks(m_size, [&](Index, Index first, Index last) {
        for (Index i = first; i < last; ++i) {
            const double f = g[i] - m_u(i);
            m_f(i) = f;
            if (add) {
                m_df(i, j) = f - m_f_previous(i);
                m_dg(i, j) = g[i] - m_g_previous(i);
            }
            m_f_previous(i) = f;
            m_g_previous(i) = g[i];
        }
    });
    m_has_previous = true;
    if (add) {
        m_count = std::min(m_count + 1, m_window);
        m_head = (m_head + 1) % m_window;
    }
    if (m_count == 0) {
        std::copy(g, g + m_size, m_u.data());
        return false;
    }
    // Partial sums per block: dF_j . dF_c (the new Gram row) and dF_c . f, c over the history.
    const int count = m_count;
    for_blocks(m_size, [&](Index b, Index first, Index last) {
        for (int c = 0; c < count; ++c) {
            double gram = 0.0, rhs = 0.0;
            for (Index i = first; i < last; ++i) {
                const double weighted = m_weights(i) * m_df(i, c);
                gram += m_df(i, j) * weighted;
                rhs += m_f(i) * weighted;
            }
            m_partial(c, b) = gram;
            m_partial(m_window + c, b) = rhs;
        }
    });
    for (int c = 0; c < count; ++c) {
        double gram = 0.0, rhs = 0.0;
        for (Index b = 0; b < m_partial.cols(); ++b) {
            gram += m_partial(c, b);
            rhs += m_partial(m_window + c, b);
        }
        m_gram(j, c) = gram;
        m_gram(c, j) = gram;
        m_rhs(c) = rhs;
    }
    // theta from the regularized normal equations (columns in ring order: any order solves the
    // same least-squares problem).
    SmallMatrix normal = m_gram.topLeftCorner(count, count);
    const double scale = normal.diagonal().maxCoeff();
    normal.diagonal().array() += 1e-10 * scale + 1e-300;
    const Eigen::LLT<SmallMatrix> llt(normal);
    SmallVector theta = llt.solve(m_rhs.head(count));
    const bool usable = llt.info() == Eigen::Success && theta.allFinite() && scale > 0.0;
    if (!usable)
        theta.setZero();
    // u = g - dG theta.
    for_blocks(m_size, [&](Index, Index first, Index last) {
        for (Index i = first; i < last; ++i) {
            double u = g[i];
            for (int c = 0; c < count; ++c)
                u -= m_dg(i, c) * theta(c);
            m_u(i) = u;
            g[i] = u;
        }
    });
    return usable;
}

double AndersonAcceleration::residual_norm(const double* g)
{
    MAT_CHECK(m_started, "anderson: residual_norm() before start()");
    for_blocks(m_size, [&](Index b, Index first, Index last) {
        double sum = 0.0;
        for (Index i = first; i < last; ++i)
            sum += m_weights(i) * (g[i] - m_u(i)) * (g[i] - m_u(i));
        m_partial(0, b) = sum;
    });
    double sum = 0.0;
    for (Index b = 0; b < m_partial.cols(); ++b)
        sum += m_partial(0, b);
    return std::sqrt(sum);
}

void AndersonAcceleration::fall_back(double* out)
{
    MAT_CHECK(m_has_previous, "anderson: fall_back() without a plain iterate");
    std::copy(m_g_previous.data(), m_g_previous.data() + m_size, m_u.data());
    std::copy(m_g_previous.data(), m_g_previous.data() + m_size, out);
    m_has_previous = false;
    m_count = 0;
    m_head = 0;
}

} // namespace mat
