// Frame files and the ffmpeg program (render/video.hpp); encoding itself is in commands_test.
#include "video.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

namespace rd = cosserat::render;
namespace fs = std::filesystem;

namespace {

TEST(VideoTest, FramePathsAreNumberedWithFiveDigits) {
  EXPECT_EQ(rd::frame_path("out", 0), "out/frame_00000.png");
  EXPECT_EQ(rd::frame_path("out/", 42), "out/frame_00042.png");
  EXPECT_EQ(rd::frame_path("o", 123456), "o/frame_123456.png");
}

TEST(VideoTest, RemoveFramesTouchesOnlyFrames) {
  const fs::path dir = fs::temp_directory_path() / ("cosserat_render_video_test_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  for (const char* name : {"frame_00000.png", "frame_00017.png", "frame_1.png", "frame_00000.png.bak", "other.png"})
    std::ofstream(dir / name) << "x";
  EXPECT_EQ(rd::remove_frames(dir.string()), 2);
  EXPECT_FALSE(fs::exists(dir / "frame_00000.png"));
  EXPECT_TRUE(fs::exists(dir / "frame_1.png"));
  EXPECT_TRUE(fs::exists(dir / "frame_00000.png.bak"));
  EXPECT_TRUE(fs::exists(dir / "other.png"));
  EXPECT_EQ(rd::remove_frames((dir / "missing").string()), 0);
  fs::remove_all(dir);
}

TEST(VideoTest, FindsProgramsOnThePath) {
  EXPECT_FALSE(rd::find_program("sh").empty());
  EXPECT_TRUE(rd::find_program("no-such-program-here").empty());
}

}  // namespace
