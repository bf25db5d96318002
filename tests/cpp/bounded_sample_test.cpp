// SPDX-License-Identifier: BSD-3-Clause
// The CLI's run summaries in bounded memory (cpp/apps/bounded_sample.hpp): exact up to capacity, a fair sample after.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "bounded_sample.hpp"

TEST(BoundedSample, ExactPercentilesUpToItsCapacity) {
    BoundedSample s(1000);
    EXPECT_TRUE(std::isnan(s.median()) && std::isnan(s.percentile(0.99)));  // nothing yet
    std::vector<double> all;
    std::mt19937 rng(3);
    for (int i = 0; i < 1000; ++i) {
        all.push_back(std::uniform_real_distribution<double>(0.0, 50.0)(rng));
        s.add(all.back());
    }
    std::sort(all.begin(), all.end());
    EXPECT_EQ(s.count(), 1000u);
    EXPECT_EQ(s.median(), 0.5 * (all[499] + all[500]));  // an even count: the mean of the two middle values
    EXPECT_EQ(s.percentile(0.99), all[989]);
    EXPECT_EQ(s.percentile(0.5), all[499]);
    EXPECT_EQ(s.max(), all.back());
}

TEST(BoundedSample, TheMedianOfAnOddCountIsItsMiddleValue) {
    BoundedSample s;
    for (const double v : {4.88, 3.83, 9.0}) s.add(v);
    EXPECT_EQ(s.median(), 4.88);
    s.add(1.0);
    EXPECT_DOUBLE_EQ(s.median(), 0.5 * (3.83 + 4.88));
}

TEST(BoundedSample, BeyondItsCapacityAFairSampleOfEveryValue) {
    BoundedSample s(2000);
    for (int i = 0; i < 200000; ++i) s.add(i % 2 == 0 ? i / 200000.0 : 1.0 - i / 200000.0);  // uniform on [0, 1)
    EXPECT_EQ(s.count(), 200000u);
    EXPECT_DOUBLE_EQ(s.max(), 1.0 - 1 / 200000.0);
    EXPECT_NEAR(s.median(), 0.5, 0.03);         // a sample of the whole run, not its first 2000 values (≤ 0.01)
    EXPECT_NEAR(s.percentile(0.99), 0.99, 0.01);
    BoundedSample late(2000);  // a run whose values rise: the sample follows them
    for (int i = 0; i < 100000; ++i) late.add(i);
    EXPECT_NEAR(late.median(), 50000.0, 3000.0);
}
