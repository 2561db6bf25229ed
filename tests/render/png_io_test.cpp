// PNG files (render/png_io.hpp).
#include "png_io.hpp"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

namespace rd = cosserat::render;

namespace {

TEST(PngTest, RoundTrip) {
  rd::Image img(37, 11);
  for (size_t i = 0; i < img.rgb.size(); ++i) img.rgb[i] = static_cast<std::uint8_t>(i * 7);
  const std::string path = "/tmp/cosserat_render_png_test.png";
  rd::write_png(path, img);
  const rd::Image back = rd::read_png(path);
  EXPECT_EQ(back.width, 37);
  EXPECT_EQ(back.height, 11);
  EXPECT_TRUE(back.rgb == img.rgb);
  EXPECT_THROW(rd::read_png("/nonexistent/x.png"), std::runtime_error);
  EXPECT_THROW(rd::write_png("/nonexistent/x.png", img), std::runtime_error);
}

}  // namespace
