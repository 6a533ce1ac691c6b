// Recipes of HDF5 files for structure-aware fuzzing (tests/fuzz/h5_recipe.hpp).

#include "tests/fuzz/h5_recipe.hpp"

#include <algorithm>
#include <cstring>

#include "common/error.hpp"
#include "formats/hdf5_file.hpp"

namespace mat::fuzz {

namespace {
    constexpr std::size_t max_values = std::size_t(1) << 18;
    /// Values that a whole recipe may read past its end (as zeros): the cost of building a
    /// file stays proportional to the recipe's size.
    constexpr std::size_t max_padding_bytes = std::size_t(1) << 16;

    /// Reads a recipe; past its end every number is 0 and every text empty.
    class RecipeReader {
    public:
        RecipeReader(const std::uint8_t* data, std::size_t size)
            : m_data(data)
            , m_size(size)
        {
        }
        bool done() const { return m_at >= m_size; }

        template <typename T> T number()
        {
            T value {};
            const std::size_t available = std::min(sizeof(T), m_size - std::min(m_at, m_size));
            if (available > 0)
                std::memcpy(&value, m_data + m_at, available);
            m_at += sizeof(T);
            return value;
        }

        std::string text(std::size_t length)
        {
            const std::size_t start = std::min(m_at, m_size);
            const std::size_t end = std::min(start + length, m_size);
            m_at += length;
            return std::string(reinterpret_cast<const char*>(m_data) + start, end - start);
        }
        std::string short_text() { return text(number<std::uint8_t>()); }
        std::string long_text() { return text(number<std::uint16_t>()); }

        /// Whether `count` values of `bytes` each may be read: at most max_values, and those
        /// past the end of the recipe within what is left of max_padding_bytes.
        bool affords(std::size_t count, std::size_t bytes)
        {
            if (count > max_values)
                return false;
            const std::size_t left = m_size - std::min(m_at, m_size);
            const std::size_t past_end = count * bytes > left ? count * bytes - left : 0;
            if (past_end > m_padding_left)
                return false;
            m_padding_left -= past_end;
            return true;
        }

    private:
        const std::uint8_t* m_data;
        std::size_t m_size;
        std::size_t m_at = 0;
        std::size_t m_padding_left = max_padding_bytes;
    };

    struct Shape {
        int rank = 1;
        Index spare_items = 0; ///< a series: items reserved past those written (0: growing)
        Index dims[3] = { 0, 1, 1 };
        std::size_t values() const { return std::size_t(dims[0] * dims[1] * dims[2]); }
    };

    Shape read_shape(RecipeReader& in)
    {
        Shape shape;
        const int code = in.number<std::uint8_t>();
        shape.rank = code % 3 + 1;
        shape.spare_items = code / 3 % 4;
        for (int d = 0; d < shape.rank; ++d)
            shape.dims[d] = in.number<std::uint16_t>();
        return shape;
    }

    template <typename Scalar>
    void write_data(RecipeReader& in, H5Writer& out, const std::string& path)
    {
        using Matrix = Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
        using Vector = Eigen::Matrix<Scalar, Eigen::Dynamic, 1>;
        Shape shape = read_shape(in);
        // A series of 0 items still makes one item's buffer: bound it too.
        if (std::size_t(shape.dims[1] * shape.dims[2]) > max_values
            || !in.affords(shape.values(), sizeof(Scalar))
            || (shape.rank == 3 && shape.dims[0] > 256))
            return;
        if constexpr (!std::is_same_v<Scalar, double>) {
            if (shape.rank == 3) { // series hold float64 only: the first two dimensions
                shape.rank = 2;
                shape.dims[2] = 1;
            }
        }
        if (shape.rank == 3) {
            // A reserved series (spare items > 0) has rows past the items written, as a
            // trajectory of a run that stopped early does.
            const Index capacity = shape.spare_items > 0 ? shape.dims[0] + shape.spare_items : 0;
            out.create_series(path, { shape.dims[1], shape.dims[2] }, capacity);
            RowMatX item(shape.dims[1], shape.dims[2]);
            for (Index i = 0; i < shape.dims[0]; ++i) {
                for (Index k = 0; k < item.size(); ++k)
                    item.data()[k] = in.number<double>();
                out.append(path, item);
            }
            return;
        }
        Matrix values(shape.dims[0], shape.dims[1]);
        for (Index k = 0; k < values.size(); ++k)
            values.data()[k] = in.number<Scalar>();
        if (shape.rank == 1)
            out.write_vector(path, Vector(Eigen::Map<const Vector>(values.data(), values.size())));
        else
            out.write_matrix(path, values);
    }

    void build_record(RecipeReader& in, H5Writer& out)
    {
        const int op = in.number<std::uint8_t>() % 8;
        const std::string path = in.short_text();
        switch (op) {
        case 0:
            out.create_group(path);
            break;
        case 1:
            write_data<double>(in, out, path);
            break;
        case 2:
            write_data<int>(in, out, path);
            break;
        case 3:
            write_data<std::int64_t>(in, out, path);
            break;
        case 4:
            out.write_string(path, in.long_text());
            break;
        case 5: {
            const std::string name = in.short_text();
            out.set_attribute(path, name, in.long_text());
            break;
        }
        case 6: {
            const std::string name = in.short_text();
            const int count = in.number<std::uint8_t>() % 3 + 1;
            std::vector<std::int64_t> values;
            for (int i = 0; i < count; ++i)
                values.push_back(in.number<std::int64_t>());
            if (count == 1)
                out.set_attribute(path, name, values[0]);
            else
                out.set_attribute(path, name, values);
            break;
        }
        default: {
            const std::string name = in.short_text();
            out.set_attribute(path, name, in.number<double>());
            break;
        }
        }
    }

    /// Writes a recipe.
    class RecipeWriter {
    public:
        template <typename T> void number(T value)
        {
            const auto* bytes = reinterpret_cast<const std::uint8_t*>(&value);
            m_bytes.insert(m_bytes.end(), bytes, bytes + sizeof(T));
        }
        void text(const std::string& value, std::size_t max_length)
        {
            if (value.size() > max_length)
                throw_error("recipe: text of {} bytes, at most {} fit", value.size(), max_length);
            if (max_length <= 0xff)
                number(std::uint8_t(value.size()));
            else
                number(std::uint16_t(value.size()));
            m_bytes.insert(m_bytes.end(), value.begin(), value.end());
        }
        void record(int op, const std::string& path)
        {
            number(std::uint8_t(op));
            text(path, 0xff);
        }
        void shape(const std::vector<Index>& dims)
        {
            number(std::uint8_t(dims.size() - 1));
            for (const Index d : dims) {
                if (d > 0xffff)
                    throw_error("recipe: dimension {} does not fit in 16 bits", d);
                number(std::uint16_t(d));
            }
        }
        std::vector<std::uint8_t> take() { return std::move(m_bytes); }

    private:
        std::vector<std::uint8_t> m_bytes;
    };

    void dump_attributes(const H5Reader& in, const std::string& object, RecipeWriter& out)
    {
        for (const std::string& name : in.attribute_names(object)) {
            if (name == "shape" && in.is_group(object)) { // a CSR group's [rows, cols]
                const SparseRowMat matrix = in.read_sparse(object);
                out.record(6, object);
                out.text(name, 0xff);
                out.number(std::uint8_t(1));
                out.number(std::int64_t(matrix.rows()));
                out.number(std::int64_t(matrix.cols()));
                continue;
            }
            try {
                const std::string text = in.read_string_attribute(object, name);
                out.record(5, object);
                out.text(name, 0xff);
                out.text(text, 0xffff);
                continue;
            } catch (const Error&) {
            }
            try {
                const std::int64_t value = in.read_int_attribute(object, name);
                out.record(6, object);
                out.text(name, 0xff);
                out.number(std::uint8_t(0));
                out.number(value);
                continue;
            } catch (const Error&) {
            }
            const double value = in.read_double_attribute(object, name);
            out.record(7, object);
            out.text(name, 0xff);
            out.number(value);
        }
    }

    template <typename Scalar, typename Read>
    bool try_dump(const std::string& path, const std::vector<Index>& dims, int op, Read&& read,
        RecipeWriter& out)
    {
        Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> values;
        try {
            values = read();
        } catch (const Error&) {
            return false;
        }
        out.record(op, path);
        out.shape(dims);
        for (Index k = 0; k < values.size(); ++k)
            out.number(values.data()[k]);
        return true;
    }

    void dump_dataset(const H5Reader& in, const std::string& path, RecipeWriter& out)
    {
        const std::vector<Index> dims = in.shape(path);
        if (dims.empty()) {
            out.record(4, path);
            out.text(in.read_string(path), 0xffff);
            return;
        }
        if (dims.size() == 3) {
            out.record(1, path);
            out.shape(dims);
            for (Index i = 0; i < dims[0]; ++i) {
                const RowMatX item = in.read_series_item(path, i);
                for (Index k = 0; k < item.size(); ++k)
                    out.number(item.data()[k]);
            }
            return;
        }
        const bool matrix = dims.size() == 2;
        const bool done = try_dump<int>(
                              path, dims, 2,
                              [&] {
                                  return matrix ? RowMatXi(in.read_matrix_int(path))
                                                : RowMatXi(in.read_vector_int(path));
                              },
                              out)
            || try_dump<std::int64_t>(
                path, dims, 3,
                [&] {
                    return matrix ? RowMatXl(in.read_matrix_int64(path))
                                  : RowMatXl(in.read_vector_int64(path));
                },
                out)
            || try_dump<double>(
                path, dims, 1,
                [&] {
                    return matrix ? RowMatX(in.read_matrix(path)) : RowMatX(in.read_vector(path));
                },
                out);
        if (!done)
            throw_error("{}: '{}': no recipe for this dataset", in.path(), path);
    }

    void dump_group(const H5Reader& in, const std::string& group, RecipeWriter& out)
    {
        if (group != "/")
            out.record(0, group);
        dump_attributes(in, group, out);
        for (const std::string& name : in.list(group)) {
            const std::string child = (group == "/" ? "" : group) + "/" + name;
            if (in.is_group(child)) {
                dump_group(in, child, out);
            } else {
                dump_dataset(in, child, out);
                dump_attributes(in, child, out);
            }
        }
    }
} // namespace

bool build_h5_from_recipe(const std::uint8_t* data, std::size_t size, const std::string& path)
{
    try {
        H5Writer out(path);
        RecipeReader in(data, size);
        while (!in.done()) {
            try {
                build_record(in, out);
            } catch (const Error&) {
                // the writer refused this record: the file goes on without it
            }
        }
        out.commit();
        return true;
    } catch (const Error&) {
        return false;
    }
}

std::vector<std::uint8_t> recipe_from_h5(const std::string& path)
{
    const H5Reader in(path);
    RecipeWriter out;
    dump_group(in, "/", out);
    return out.take();
}

} // namespace mat::fuzz
