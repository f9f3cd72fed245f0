// The evaluation's measures on hand-made cases with known answers.
#include <gtest/gtest.h>

#include "keyfleet/eval/eval_runner.hpp"
#include "keyfleet/eval/metrics.hpp"

namespace keyfleet::eval {
namespace {

using Indices = std::vector<std::size_t>;

TEST(SpreadEvenly, KeepsTheMiddleOfEqualSlices) {
  EXPECT_EQ(spread_evenly(10, 1.0), (Indices{0, 1, 2, 3, 4, 5, 6, 7, 8, 9}));
  EXPECT_EQ(spread_evenly(10, 0.5), (Indices{1, 3, 5, 7, 9}));
  EXPECT_EQ(spread_evenly(10, 0.35), (Indices{1, 3, 6, 8}));  // round(3.5) = 4
  EXPECT_EQ(spread_evenly(10, 0.2), (Indices{2, 7}));
  EXPECT_EQ(spread_evenly(100, 0.1).size(), 10u);
}

TEST(SpreadEvenly, KeepsAtLeastOneAndNothingFromNothing) {
  EXPECT_EQ(spread_evenly(3, 0.1), (Indices{1}));
  EXPECT_EQ(spread_evenly(1, 0.5), (Indices{0}));
  EXPECT_TRUE(spread_evenly(0, 0.5).empty());
  EXPECT_TRUE(spread_evenly(10, 0.0).empty());
  EXPECT_EQ(spread_evenly(4, 7.0), (Indices{0, 1, 2, 3}));  // more than all is all
}

TEST(SpreadEvenly, SameFractionSameCountForEveryStrategy) {
  for (std::size_t n : {7u, 95u, 110u})
    for (double f : {1.0, 0.75, 0.5, 0.35, 0.2, 0.1}) {
      const auto kept = spread_evenly(n, f);
      EXPECT_EQ(kept, spread_evenly(n, f));
      EXPECT_NEAR(double(kept.size()), f * double(n), 0.5 + 1e-9) << n << " " << f;
      for (std::size_t i = 1; i < kept.size(); ++i) EXPECT_LT(kept[i - 1], kept[i]);
      EXPECT_LT(kept.back(), n);
    }
}

TEST(Recall, CountsOnlyRelevantFinds) {
  EXPECT_DOUBLE_EQ(recall({1, 2, 5}, {1, 2, 3, 4}), 0.5);
  EXPECT_DOUBLE_EQ(recall({}, {1, 2}), 0.0);
  EXPECT_DOUBLE_EQ(recall({1, 2}, {1, 2}), 1.0);
  EXPECT_DOUBLE_EQ(recall({1}, {}), 0.0);
}

scenario::WordInView word(int sign, const std::string& text, double x0, double y0, double x1,
                          double y1, scenario::WordVisibility visibility, bool legible = true) {
  scenario::WordInView w;
  w.sign_id = sign;
  w.text = text;
  w.box_x0 = x0, w.box_y0 = y0, w.box_x1 = x1, w.box_y1 = y1;
  w.visibility = visibility;
  w.legible = legible;
  return w;
}

scenario::FrameTruth street_frame() {
  using V = scenario::WordVisibility;
  scenario::FrameTruth f;
  f.words = {word(1, "ICE CREAM", 100, 100, 200, 130, V::kFull),
             word(2, "SALE", 300, 100, 350, 120, V::kFull),
             word(3, "SALE", 400, 300, 450, 320, V::kCut),
             word(4, "###", 10, 10, 40, 30, V::kFull, false),
             word(5, "PUB", 500, 400, 540, 420, V::kOccluded)};
  return f;
}

TEST(Words, FullyVisibleMeansLegibleAndWhole) {
  EXPECT_EQ(fully_visible_signs(street_frame()), (std::set<int>{1, 2}));
}

TEST(Words, NormalisedToUpperCaseLettersAndDigits) {
  EXPECT_EQ(normalise_word("Cafe-Bar 24!"), "CAFEBAR24");
  EXPECT_EQ(normalise_word("..."), "");
}

TEST(Words, ReadWhenEveryPartIsReadInItsPlace) {
  const auto frame = street_frame();
  const std::vector<WordRead> read = {{"ice", 100, 100, 140, 130},
                                      {"Cream!", 150, 101, 199, 129},
                                      {"SALE", 305, 102, 345, 118},
                                      {"PUB", 10, 10, 40, 30}};  // right text, wrong place
  EXPECT_EQ(signs_read(read, frame), (std::set<int>{1, 2}));
  // Half of a two-word sign is not the sign; the same text elsewhere is not this sign.
  EXPECT_EQ(signs_read({{"ICE", 100, 100, 140, 130}}, frame), (std::set<int>{}));
  EXPECT_EQ(signs_read({{"SALE", 402, 301, 448, 319}}, frame), (std::set<int>{3}));
  EXPECT_EQ(signs_read({{"###", 10, 10, 40, 30}}, frame), (std::set<int>{}));  // illegible
  EXPECT_EQ(signs_read({}, frame), (std::set<int>{}));
}

TEST(TopK, RightWhenAPositionWithinToleranceIsAmongTheFirstK) {
  TopK acc;
  add_query(acc, 11, {10, 50, 12}, 5);         // right at 1
  add_query(acc, 30, {10, 50, 29}, 5);         // right at 3
  add_query(acc, 30, {}, 5);                   // nothing retrieved
  add_query(acc, 30, {0, 0, 0, 0, 0, 30}, 5);  // the 6th does not count
  add_query(acc, 30, {35.0, 0, 0}, 5);         // the tolerance is inclusive
  EXPECT_EQ(acc.queries, 5u);
  EXPECT_EQ(acc.top1, 2u);
  EXPECT_EQ(acc.top5, 3u);
  EXPECT_DOUBLE_EQ(acc.top1_rate(), 0.4);
  EXPECT_DOUBLE_EQ(acc.top5_rate(), 0.6);
  EXPECT_DOUBLE_EQ(TopK{}.top1_rate(), 0.0);
}

TEST(TopK, AnswerableOnlyWithACandidateNearby) {
  EXPECT_TRUE(answerable(10, {0, 14.9}, 5));
  EXPECT_FALSE(answerable(10, {0, 15.1}, 5));
  EXPECT_FALSE(answerable(10, {}, 5));
}

TEST(Bytes, SumsEverySendOfKnownFrames) {
  EXPECT_EQ(bytes_sent({0, 2, 2, 7}, {100, 200, 300}), 700u);
  EXPECT_EQ(bytes_sent({}, {100}), 0u);
}

TEST(Summary, SumsCountsAndAveragesRecallsOverDrones) {
  std::vector<WordScore> words = {{"d0", "full", 0.5, 100, 50, 10, 8, 5, 1000, ""},
                                  {"d1", "full", 0.5, 80, 40, 20, 10, 4, 500, ""},
                                  {"d0", "vslam", 0.5, 100, 50, 10, 7, 3, 900, ""}};
  PlaceScore a{"d0", "d1", "full", "bow", 0.5, 40, 2, {}, ""};
  a.topk = {10, 4, 8};
  PlaceScore b{"d1", "d0", "full", "bow", 0.5, 50, 0, {}, ""};
  b.topk = {10, 6, 9};
  const auto s = summarise(words, {a, b}, {"vslam", "full"}, {0.5});
  ASSERT_EQ(s.size(), 2u);
  EXPECT_EQ(s[0].strategy, "vslam");
  const auto& full = s[1];
  EXPECT_EQ(full.keyframes, 90u);
  EXPECT_EQ(full.words_in_sequence, 30u);
  EXPECT_EQ(full.words_read, 9u);
  EXPECT_DOUBLE_EQ(full.word_recall, (0.5 + 0.2) / 2);
  EXPECT_DOUBLE_EQ(full.full_word_recall, (0.8 + 0.5) / 2);
  EXPECT_EQ(full.bytes, 1500u);
  EXPECT_EQ(full.topk.queries, 20u);
  EXPECT_DOUBLE_EQ(full.topk.top1_rate(), 0.5);
  EXPECT_DOUBLE_EQ(full.topk.top5_rate(), 0.85);
}

}  // namespace
}  // namespace keyfleet::eval
