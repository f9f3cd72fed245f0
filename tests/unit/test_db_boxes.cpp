// DB text boxes (vision/db_boxes.hpp) on hand-made probability maps: the polygon offset, the
// unclip, corner order, thresholds, letterbox padding, and the boxes filled as a mask.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>

#include "keyfleet/vision/db_boxes.hpp"

namespace keyfleet::vision {
namespace {

// ---------------------------------------------------------------- polygon offset and unclip

TEST(DbBoxes, OffsetSquareIsRoundedSquare) {
  const std::vector<cv::Point2f> square = {{0, 0}, {10, 0}, {10, 10}, {0, 10}};
  const float d = 2;
  const auto grown = offset_convex_polygon(square, d, 8);
  ASSERT_EQ(grown.size(), 4u * 9u);
  // Every point lies at distance d from the square (outside it).
  for (const auto& p : grown) {
    const float dx = std::max({0.f, -p.x, p.x - 10});
    const float dy = std::max({0.f, -p.y, p.y - 10});
    EXPECT_NEAR(std::hypot(dx, dy), d, 1e-4) << p;
  }
  float left = 1e9f, top = 1e9f, right = -1e9f, bottom = -1e9f;
  for (const auto& p : grown) {
    left = std::min(left, p.x);
    top = std::min(top, p.y);
    right = std::max(right, p.x);
    bottom = std::max(bottom, p.y);
  }
  EXPECT_NEAR(left, -d, 1e-4);
  EXPECT_NEAR(top, -d, 1e-4);
  EXPECT_NEAR(right, 10 + d, 1e-4);
  EXPECT_NEAR(bottom, 10 + d, 1e-4);
  // Area of the Minkowski sum: square + four side strips + a disc (arcs sampled by chords).
  const double exact = 100 + 4 * 10 * d + CV_PI * d * d;
  EXPECT_NEAR(cv::contourArea(grown), exact, 0.01 * exact);
  // The orientation of the input does not matter.
  const std::vector<cv::Point2f> reversed(square.rbegin(), square.rend());
  EXPECT_NEAR(cv::contourArea(offset_convex_polygon(reversed, d, 8)), exact, 0.01 * exact);
}

TEST(DbBoxes, UnclipGrowsByAreaTimesRatioOverPerimeter) {
  const TextQuad square = {cv::Point2f(0, 0), cv::Point2f(10, 0), cv::Point2f(10, 10),
                           cv::Point2f(0, 10)};
  const float distance = 100 * 1.5f / 40;  // 3.75
  const cv::RotatedRect grown = unclip(square, 1.5f);
  EXPECT_NEAR(grown.center.x, 5, 1e-3);
  EXPECT_NEAR(grown.center.y, 5, 1e-3);
  EXPECT_NEAR(std::min(grown.size.width, grown.size.height), 10 + 2 * distance, 0.05);
  EXPECT_NEAR(std::max(grown.size.width, grown.size.height), 10 + 2 * distance, 0.05);
}

TEST(DbBoxes, OrderedCornersStartTopLeftClockwise) {
  const auto q = ordered_corners(cv::RotatedRect({50, 20}, {60, 10}, 0));
  EXPECT_NEAR(q[0].x, 20, 1e-3);
  EXPECT_NEAR(q[0].y, 15, 1e-3);
  EXPECT_NEAR(q[1].x, 80, 1e-3);
  EXPECT_NEAR(q[2].y, 25, 1e-3);
  EXPECT_NEAR(q[3].x, 20, 1e-3);
  EXPECT_NEAR(q[3].y, 25, 1e-3);
}

// ---------------------------------------------------------------- DB post-processing

TEST(DbPostprocess, RectangleGivesOneQuadGrownByTheUnclipRatio) {
  cv::Mat prob(100, 200, CV_32F, cv::Scalar(0));
  prob(cv::Rect(40, 30, 80, 20)).setTo(0.9);   // text: x 40..119, y 30..49
  prob(cv::Rect(150, 70, 30, 20)).setTo(0.4);  // above the binary threshold, below the box one
  DbParams params;                             // binary 0.3, box 0.6, unclip 1.5
  const auto found = db_postprocess(prob, prob.size(), 1.f, prob.size(), params);
  ASSERT_EQ(found.size(), 1u) << "the 0.4 blob must be dropped by the box threshold";
  EXPECT_NEAR(found[0].score, 0.9, 0.01);
  // The contour runs through the outer pixel centres: a 79 x 19 box, grown by
  // area * ratio / perimeter on every side.
  const float w = 79, h = 19, d = w * h * 1.5f / (2 * (w + h));
  const TextQuad& q = found[0].quad;
  EXPECT_NEAR(q[0].x, 40 - d, 0.6);
  EXPECT_NEAR(q[0].y, 30 - d, 0.6);
  EXPECT_NEAR(q[1].x, 119 + d, 0.6);
  EXPECT_NEAR(q[1].y, 30 - d, 0.6);
  EXPECT_NEAR(q[2].x, 119 + d, 0.6);
  EXPECT_NEAR(q[2].y, 49 + d, 0.6);
  EXPECT_NEAR(q[3].x, 40 - d, 0.6);
  EXPECT_NEAR(q[3].y, 49 + d, 0.6);

  // Without unclipping the quad is the box itself; with the box threshold at 0.3 the faint
  // blob is kept too, after the text (reading order: top first).
  params.unclip_ratio = 0;
  params.box_threshold = 0.3f;
  const auto both = db_postprocess(prob, prob.size(), 1.f, prob.size(), params);
  ASSERT_EQ(both.size(), 2u);
  EXPECT_NEAR(both[0].quad[0].x, 40, 0.6);
  EXPECT_NEAR(both[0].quad[2].x, 119, 0.6);
  EXPECT_NEAR(both[1].quad[0].x, 150, 0.6);
}

TEST(DbPostprocess, MapsBackToImagePixelsAndIgnoresPadding) {
  cv::Mat prob(100, 200, CV_32F, cv::Scalar(0));
  prob(cv::Rect(10, 10, 40, 10)).setTo(1.0);
  prob(cv::Rect(10, 80, 40, 10)).setTo(1.0);  // in the letterbox padding (rows 60..)
  DbParams params;
  params.unclip_ratio = 0;
  // The image was 400 x 120, scaled by 0.5 into the top 200 x 60 of the map.
  const auto found = db_postprocess(prob, {200, 60}, 0.5f, {400, 120}, params);
  ASSERT_EQ(found.size(), 1u);
  EXPECT_NEAR(found[0].quad[0].x, 20, 1.2);
  EXPECT_NEAR(found[0].quad[0].y, 20, 1.2);
  EXPECT_NEAR(found[0].quad[2].x, 98, 1.2);
  EXPECT_NEAR(found[0].quad[2].y, 38, 1.2);
}

TEST(DbPostprocess, TinyOrEmptyInputsGiveNothing) {
  DbParams params;
  cv::Mat prob(50, 50, CV_32F, cv::Scalar(0));
  prob(cv::Rect(10, 10, 20, 2)).setTo(1.0);  // thinner than min_size
  EXPECT_TRUE(db_postprocess(prob, prob.size(), 1.f, prob.size(), params).empty());
  EXPECT_TRUE(db_postprocess(cv::Mat(), {10, 10}, 1.f, {10, 10}, params).empty());
  EXPECT_TRUE(db_postprocess(prob, prob.size(), 0.f, prob.size(), params).empty());
  EXPECT_TRUE(db_postprocess(prob, {0, 0}, 1.f, prob.size(), params).empty());
}

TEST(DbBoxes, FilledBoxesCoverTheGrownQuadsAndNothingElse) {
  cv::Mat prob(100, 200, CV_32F, cv::Scalar(0));
  prob(cv::Rect(40, 30, 80, 20)).setTo(0.9);
  const auto boxes = db_postprocess(prob, prob.size(), 1.f, prob.size(), DbParams{});
  ASSERT_EQ(boxes.size(), 1u);
  const cv::Mat mask = fill_boxes(boxes, prob.size());
  ASSERT_EQ(mask.type(), CV_8U);
  ASSERT_EQ(mask.size(), prob.size());
  // The grown box: 79 x 19 through the outer pixel centres plus d on every side.
  const double d = 79.0 * 19.0 * 1.5 / (2 * (79 + 19));
  const double expected = (79 + 2 * d + 1) * (19 + 2 * d + 1);
  EXPECT_NEAR(cv::countNonZero(mask), expected, 0.06 * expected);
  EXPECT_EQ(mask.at<uchar>(40, 80), 255);  // the text's middle
  EXPECT_EQ(mask.at<uchar>(80, 165), 0);   // far from it
  EXPECT_EQ(cv::countNonZero(fill_boxes({}, {20, 10})), 0);
}

}  // namespace
}  // namespace keyfleet::vision
