#pragma once
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <vector>

#include "keyfleet/common/scenario_truth.hpp"
#include "keyfleet/scenario/street_world.hpp"

namespace keyfleet::scenario {

// World-to-camera rigid transform (OpenCV camera axes).
struct CameraPose {
  Eigen::Matrix3d rotation_cw = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation_cw = Eigen::Vector3d::Zero();
  Eigen::Vector3d centre() const { return -rotation_cw.transpose() * translation_cw; }
};

struct RenderedView {
  cv::Mat radiance;   // CV_32FC3, linear scene brightness (0..~255 at unit lighting)
  cv::Mat plane_id;   // CV_32SC1, -1 = sky
  cv::Mat text_mask;  // CV_8UC1, 255 inside a word box of the nearest plane
};

// Renders textured planes with a z-buffer: each plane is warped by its homography into
// the part of the frame its near-clipped outline covers, and wins the pixels where its
// (analytic) inverse depth is the largest so far.
class PlaneRenderer {
 public:
  explicit PlaneRenderer(const CameraModel& camera);
  RenderedView render(const StreetWorld& world, const CameraPose& pose,
                      const DayLighting& lighting) const;
  // The pixel where a world point projects; false when it is behind the camera.
  bool project(const CameraPose& pose, const Eigen::Vector3d& point, cv::Point2d& pixel) const;
  const CameraModel& camera() const { return camera_; }

 private:
  void draw_plane(const TexturedPlane& plane, const CameraPose& pose, const cv::Scalar& light,
                  RenderedView& view, cv::Mat& inverse_depth) const;
  CameraModel camera_;
  Eigen::Matrix3d k_;
};

}  // namespace keyfleet::scenario
