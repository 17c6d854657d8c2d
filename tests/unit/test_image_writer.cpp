// The background image writer: frames queued are written (and read back whole), flush() waits for
// them, a failure surfaces at flush() naming the file, and the queue holds at most its capacity.
#include <gtest/gtest.h>

#include <atomic>
#include <thread>

#include "engine/io/image_writer.h"
#include "tests/support/test_meshes.h"

namespace strata {
namespace {

std::shared_ptr<const Image> gradient(int width, int height, float shift) {
    auto image = std::make_shared<Image>(width, height, ImageChannels{ImageChannel::rgba, ImageChannel::depth});
    for (size_t p = 0; p < image->pixel_count(); ++p) {
        for (int c = 0; c < 3; ++c) image->rgba[4 * p + c] = float(p % 97) / 97.0f + shift;
        image->rgba[4 * p + 3] = 1;
        image->depth[p] = float(p) + shift;
    }
    return image;
}

TEST(ImageWriter, WritesEveryQueuedFrame) {
    test::TempDir dir;
    ImageWriter writer(2);
    for (int i = 0; i < 8; ++i)
        writer.write(gradient(64, 32, float(i)), dir / ("f" + std::to_string(i) + ".exr"),
                     {ImageChannel::rgba, ImageChannel::depth});
    writer.write(gradient(64, 32, 0), dir / "f.png");
    EXPECT_LE(writer.pending(), 3u);  // the queue's capacity, plus the frame being written
    writer.flush();
    EXPECT_EQ(writer.pending(), 0u);
    for (int i = 0; i < 8; ++i) {
        const Image back = read_exr(dir / ("f" + std::to_string(i) + ".exr"));
        ASSERT_EQ(back.width, 64);
        EXPECT_EQ(back.depth[100], 100.0f + float(i));
    }
    EXPECT_TRUE(std::filesystem::exists(dir / "f.png"));
}

TEST(ImageWriter, AFailureSurfacesAtFlushNamingTheFile) {
    test::TempDir dir;
    ImageWriter writer;
    writer.write(gradient(8, 8, 0), dir / "missing" / "a.png");
    writer.write(gradient(8, 8, 0), dir / "missing" / "b.png");
    writer.write(gradient(8, 8, 0), dir / "fine.png");
    try {
        writer.flush();
        FAIL() << "flush() did not report the failed frames";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("a.png"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("1 more"), std::string::npos) << e.what();
    }
    EXPECT_TRUE(std::filesystem::exists(dir / "fine.png"));
    EXPECT_NO_THROW(writer.flush());  // reported once
}

}  // namespace
}  // namespace strata
