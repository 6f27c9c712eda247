#include <mucosa/image/exr.hpp>

#include <gtest/gtest.h>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>

#include "test_support.hpp"

using namespace mucosa;
using namespace mucosa::image;

TEST(Exr, FloatImagesRoundTripExactly) {
    test::TempDir dir;
    for (int c : {1, 3, 4}) {
        ImageF img(37, 23, c);
        for (std::size_t i = 0; i < img.size(); ++i) img.data()[i] = static_cast<float>(i) * 0.001f - 0.3f;
        writeExr(dir / "h.exr", img);
        EXPECT_EQ(readExr(dir / "h.exr"), img) << c;
    }
}

TEST(Exr, MissingOrCorruptFileIsAnInputError) {
    test::TempDir dir;
    EXPECT_THROW(readExr(dir / "none.exr"), IoError);
    writeFileAtomic(dir / "bad.exr", std::string("not an exr"));
    EXPECT_THROW(readExr(dir / "bad.exr"), InputError);
}
