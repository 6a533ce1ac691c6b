#pragma once
// A small reader of the VTK XML the frame writers produce, independent of them, for tests:
// start tags and attributes, and <DataArray> contents decoded (ascii or inline base64 binary).

#include <gtest/gtest.h>

#include <cctype>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

namespace mat::test::vtk {

/// Decodes padded base64 (RFC 4648); fails the test on a bad character.
inline std::string base64_decode(const std::string& text)
{
    static const std::string alphabet
        = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    std::uint32_t bits = 0;
    int count = 0;
    for (char c : text) {
        if (c == '=' || std::isspace(static_cast<unsigned char>(c)))
            continue;
        const std::size_t v = alphabet.find(c);
        EXPECT_NE(v, std::string::npos) << "bad base64 character '" << c << "'";
        bits = (bits << 6) | std::uint32_t(v);
        count += 6;
        if (count >= 8) {
            count -= 8;
            out.push_back(char((bits >> count) & 0xffu));
        }
    }
    return out;
}

/// The value of attribute `name` in the start tag `tag` ("" if absent), XML-unescaped.
inline std::string attribute(const std::string& tag, const std::string& name)
{
    const std::string key = " " + name + "=\"";
    const std::size_t begin = tag.find(key);
    if (begin == std::string::npos)
        return "";
    const std::size_t start = begin + key.size();
    std::string value = tag.substr(start, tag.find('"', start) - start);
    const std::pair<const char*, const char*> entities[] = { { "&lt;", "<" }, { "&gt;", ">" },
        { "&quot;", "\"" }, { "&apos;", "'" }, { "&amp;", "&" } };
    for (const auto& [entity, plain] : entities)
        for (std::size_t at; (at = value.find(entity)) != std::string::npos;)
            value.replace(at, std::strlen(entity), plain);
    return value;
}

/// Start tags of the elements called `element`, in order.
inline std::vector<std::string> start_tags(const std::string& xml, const std::string& element)
{
    std::vector<std::string> out;
    for (std::size_t at = 0; (at = xml.find("<" + element + " ", at)) != std::string::npos; ++at)
        out.push_back(xml.substr(at, xml.find('>', at) - at + 1));
    return out;
}

struct ParsedArray {
    std::string type, name, format;
    int components = 0;
    std::vector<double> values;
};

/// Every <DataArray> of a VTU, decoded (binary: checks the UInt64 byte-count header).
inline std::vector<ParsedArray> parse_data_arrays(const std::string& xml)
{
    std::vector<ParsedArray> out;
    std::size_t at = 0;
    while ((at = xml.find("<DataArray ", at)) != std::string::npos) {
        const std::size_t tag_end = xml.find('>', at);
        const std::size_t end = xml.find("</DataArray>", tag_end);
        EXPECT_NE(end, std::string::npos);
        const std::string tag = xml.substr(at, tag_end - at + 1);
        const std::string content = xml.substr(tag_end + 1, end - tag_end - 1);
        ParsedArray array { attribute(tag, "type"), attribute(tag, "Name"),
            attribute(tag, "format"), std::atoi(attribute(tag, "NumberOfComponents").c_str()), {} };
        if (array.format == "binary") {
            // One base64 stream for header and data, as VTK reads it: '=' only at its end.
            const std::size_t last = content.find_last_not_of(" \n");
            const std::size_t pad = content.find('=');
            EXPECT_TRUE(pad == std::string::npos || pad + 2 >= last) << array.name;
            const std::string bytes = base64_decode(content);
            EXPECT_GE(bytes.size(), 8u);
            std::uint64_t count = 0;
            std::memcpy(&count, bytes.data(), 8); // the tests run on little-endian hosts
            EXPECT_EQ(count, bytes.size() - 8) << "byte-count header of " << array.name;
            const char* data = bytes.data() + 8;
            if (array.type == "Float64")
                for (std::size_t i = 0; i + 8 <= count; i += 8) {
                    double v;
                    std::memcpy(&v, data + i, 8);
                    array.values.push_back(v);
                }
            else if (array.type == "Int32")
                for (std::size_t i = 0; i + 4 <= count; i += 4) {
                    std::int32_t v;
                    std::memcpy(&v, data + i, 4);
                    array.values.push_back(v);
                }
            else if (array.type == "UInt8")
                for (std::size_t i = 0; i < count; ++i)
                    array.values.push_back(static_cast<unsigned char>(data[i]));
            else
                ADD_FAILURE() << "unexpected type " << array.type;
        } else {
            EXPECT_EQ(array.format, "ascii");
            std::istringstream in(content);
            for (std::string word; in >> word;)
                array.values.push_back(std::strtod(word.c_str(), nullptr));
        }
        out.push_back(array);
        at = end;
    }
    return out;
}

inline const ParsedArray& find_array(
    const std::vector<ParsedArray>& arrays, const std::string& name)
{
    for (const ParsedArray& a : arrays)
        if (a.name == name)
            return a;
    ADD_FAILURE() << "no DataArray " << name;
    static const ParsedArray none;
    return none;
}

} // namespace mat::test::vtk
