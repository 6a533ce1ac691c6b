#include "formats/png_io.hpp"

#include <cstdint>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

// Decoding is test-only: the library only writes PNG.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#pragma GCC diagnostic ignored "-Wsign-compare"
#pragma GCC diagnostic ignored "-Wunused-parameter"
#pragma GCC diagnostic ignored "-Wunused-function"
#define STB_IMAGE_IMPLEMENTATION
#define STB_IMAGE_STATIC
#define STBI_ONLY_PNG
#include <stb/stb_image.h>
#pragma GCC diagnostic pop

#include "common/error.hpp"
#include "tests/support/temp_files.hpp"

namespace mat {
namespace {

    using PngIo = test::ScratchDirTest;

    TEST_F(PngIo, RoundTripsEveryPixel)
    {
        const int width = 37, height = 23; // odd sizes: rows are not padded
        std::mt19937 random(7);
        std::vector<std::uint8_t> rgb(width * height * 3);
        for (auto& byte : rgb)
            byte = static_cast<std::uint8_t>(random() & 0xff);
        const std::string file = path("image.png");
        write_png(file, width, height, rgb);
        EXPECT_TRUE(has_png_signature(file));
        int w = 0, h = 0, channels = 0;
        unsigned char* pixels = stbi_load(file.c_str(), &w, &h, &channels, 3);
        ASSERT_NE(pixels, nullptr);
        EXPECT_EQ(w, width);
        EXPECT_EQ(h, height);
        EXPECT_EQ(channels, 3);
        const std::vector<std::uint8_t> decoded(pixels, pixels + rgb.size());
        stbi_image_free(pixels);
        EXPECT_EQ(decoded, rgb);
        EXPECT_EQ(num_entries(), 1u); // the temporary was renamed
    }

    TEST_F(PngIo, RejectsAWrongPixelCountAndLeavesNoFile)
    {
        const std::string file = path("image.png");
        const std::vector<std::uint8_t> rgb(10 * 10 * 3 - 1);
        try {
            write_png(file, 10, 10, rgb);
            FAIL() << "expected mat::Error";
        } catch (const Error& e) {
            EXPECT_NE(std::string(e.what()).find("image.png"), std::string::npos) << e.what();
            EXPECT_NE(std::string(e.what()).find("expected 300"), std::string::npos) << e.what();
        }
        EXPECT_FALSE(std::filesystem::exists(file));
        EXPECT_THROW(write_png(file, 0, 10, {}), Error);
        EXPECT_THROW(write_png(path("no_such_dir/image.png"), 1, 1, { 0, 0, 0 }), Error);
    }

    TEST_F(PngIo, SignatureCheckRejectsOtherFiles)
    {
        const std::string file = write_text("not.png", "GIF89a not a png");
        EXPECT_FALSE(has_png_signature(file));
        EXPECT_FALSE(has_png_signature(path("missing.png")));
    }

} // namespace
} // namespace mat
