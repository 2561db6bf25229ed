#include <gtest/gtest.h>
#include "lie.hpp"
using namespace cosserat;
TEST(Smoke, ExpLogRoundTrip) {
  Vec6 x; x << 0.3, -0.2, 0.5, 1.0, 0.1, -0.4;
  EXPECT_LT((log_se3(exp_se3(x)) - x).norm(), 1e-12);
}
