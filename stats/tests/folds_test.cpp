// Held-out folds by group.
#include <gtest/gtest.h>

#include "stend/stats/folds.hpp"

using stend::stats::group_folds;

TEST(GroupFolds, OneFoldPerGroupInLabelOrder) {
  const std::vector<int> group = {7, 3, 7, 5, 3};
  const auto f = group_folds(group, 0);
  ASSERT_EQ(f.size(), 3u);
  EXPECT_EQ(f[0], (std::vector<int>{1, 4}));  // group 3
  EXPECT_EQ(f[1], (std::vector<int>{3}));     // group 5
  EXPECT_EQ(f[2], (std::vector<int>{0, 2}));  // group 7
  EXPECT_EQ(group_folds(group, 12), f);       // fewer groups than the cap
}

TEST(GroupFolds, GroupsDealtRoundRobinBeyondTheCap) {
  const std::vector<int> group = {0, 1, 2, 3, 4};
  const auto f = group_folds(group, 2);
  ASSERT_EQ(f.size(), 2u);
  EXPECT_EQ(f[0], (std::vector<int>{0, 2, 4}));
  EXPECT_EQ(f[1], (std::vector<int>{1, 3}));
  EXPECT_TRUE(group_folds({}, 3).empty());
}
