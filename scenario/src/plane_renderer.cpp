#include "keyfleet/scenario/plane_renderer.hpp"

#include <opencv2/imgproc.hpp>

namespace keyfleet::scenario {
namespace {

constexpr double kNearM = 0.05;

// Clips a convex polygon (camera coordinates) to z >= kNearM (Sutherland-Hodgman).
std::vector<Eigen::Vector3d> clip_near(const std::vector<Eigen::Vector3d>& polygon) {
  std::vector<Eigen::Vector3d> out;
  for (std::size_t i = 0; i < polygon.size(); ++i) {
    const Eigen::Vector3d& a = polygon[i];
    const Eigen::Vector3d& b = polygon[(i + 1) % polygon.size()];
    const bool a_in = a.z() >= kNearM, b_in = b.z() >= kNearM;
    if (a_in) out.push_back(a);
    if (a_in != b_in) out.push_back(a + (b - a) * ((kNearM - a.z()) / (b.z() - a.z())));
  }
  return out;
}

}  // namespace

PlaneRenderer::PlaneRenderer(const CameraModel& camera) : camera_(camera) {
  k_ << camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1;
}

bool PlaneRenderer::project(const CameraPose& pose, const Eigen::Vector3d& point,
                            cv::Point2d& pixel) const {
  const Eigen::Vector3d c = pose.rotation_cw * point + pose.translation_cw;
  if (c.z() < kNearM) return false;
  const Eigen::Vector3d p = k_ * c;
  pixel = {p.x() / p.z(), p.y() / p.z()};
  return true;
}

RenderedView PlaneRenderer::render(const StreetWorld& world, const CameraPose& pose,
                                   const DayLighting& lighting) const {
  RenderedView view;
  view.radiance.create(camera_.height, camera_.width, CV_32FC3);
  // Sky: brighter toward the horizon, scaled like everything else by the day's light.
  const cv::Scalar& sky_light = lighting.sky;
  for (int y = 0; y < camera_.height; ++y) {
    const float f = 0.85f + 0.15f * float(y) / float(camera_.height);
    view.radiance.row(y).setTo(
        cv::Scalar(250 * f * sky_light[0], 215 * f * sky_light[1], 175 * f * sky_light[2]));
  }
  view.plane_id = cv::Mat(camera_.height, camera_.width, CV_32SC1, cv::Scalar(-1));
  view.text_mask = cv::Mat::zeros(camera_.height, camera_.width, CV_8UC1);
  cv::Mat inverse_depth = cv::Mat::zeros(camera_.height, camera_.width, CV_32F);
  for (const auto& plane : world.planes)
    draw_plane(plane, pose, lighting.groups.at(std::size_t(plane.lighting_group)), view,
               inverse_depth);
  return view;
}

void PlaneRenderer::draw_plane(const TexturedPlane& plane, const CameraPose& pose,
                               const cv::Scalar& light, RenderedView& view,
                               cv::Mat& inverse_depth) const {
  std::vector<Eigen::Vector3d> corners;
  for (const auto& corner : plane.corners())
    corners.push_back(pose.rotation_cw * corner + pose.translation_cw);
  const auto clipped = clip_near(corners);
  if (clipped.size() < 3) return;
  std::vector<cv::Point> outline;
  for (const auto& c : clipped) {
    const Eigen::Vector3d p = k_ * c;
    // Clamp far outside points: the outline only bounds the region to fill.
    const double x = std::clamp(p.x() / p.z(), -1e5, 1e5), y = std::clamp(p.y() / p.z(), -1e5, 1e5);
    outline.emplace_back(cvRound(x), cvRound(y));
  }
  const cv::Rect frame(0, 0, camera_.width, camera_.height);
  const cv::Rect roi = cv::boundingRect(outline) & frame;
  if (roi.area() == 0) return;

  // Inverse depth on this plane is affine in the pixel: (n . K^-1 [x y 1]) / d.
  const Eigen::Vector3d normal = pose.rotation_cw * plane.u.cross(plane.v);
  const double d = normal.dot(pose.rotation_cw * plane.origin + pose.translation_cw);
  if (std::abs(d) < 1e-9) return;  // seen edge-on
  const double a = normal.x() / (camera_.fx * d), b = normal.y() / (camera_.fy * d);
  const double c =
      (normal.z() - normal.x() * camera_.cx / camera_.fx - normal.y() * camera_.cy / camera_.fy) /
      d;

  cv::Mat inside = cv::Mat::zeros(roi.size(), CV_8UC1);
  std::vector<cv::Point> local;
  for (const auto& p : outline) local.emplace_back(p.x - roi.x, p.y - roi.y);
  cv::fillConvexPoly(inside, local, 255);

  // Texture pixel -> world -> camera -> image, shifted into the region.
  Eigen::Matrix<double, 3, 4> projection;
  projection << pose.rotation_cw, pose.translation_cw;
  Eigen::Matrix<double, 4, 3> texture_to_world = Eigen::Matrix<double, 4, 3>::Zero();
  texture_to_world.block<3, 1>(0, 0) = plane.u * (plane.width_m / plane.texture.cols);
  texture_to_world.block<3, 1>(0, 1) = -plane.v * (plane.height_m / plane.texture.rows);
  texture_to_world.block<3, 1>(0, 2) = plane.origin + plane.v * plane.height_m;
  texture_to_world(3, 2) = 1;
  Eigen::Matrix3d shift;
  shift << 1, 0, -roi.x, 0, 1, -roi.y, 0, 0, 1;
  const Eigen::Matrix3d h = shift * k_ * projection * texture_to_world;
  cv::Mat homography(3, 3, CV_64F);
  for (int r = 0; r < 3; ++r)
    for (int col = 0; col < 3; ++col) homography.at<double>(r, col) = h(r, col);

  if (!plane.alpha.empty()) {  // see-through parts never win
    cv::Mat alpha;
    cv::warpPerspective(plane.alpha, alpha, homography, roi.size(), cv::INTER_NEAREST,
                        cv::BORDER_CONSTANT, 0);
    inside &= alpha > 127;
  }

  // One pass: depth test inside the outline, z-buffer and plane id updated where it wins.
  cv::Mat wins(roi.size(), CV_8UC1);
  bool any = false;
  for (int y = 0; y < roi.height; ++y) {
    const std::uint8_t* in = inside.ptr<std::uint8_t>(y);
    float* z = inverse_depth.ptr<float>(roi.y + y) + roi.x;
    int* id = view.plane_id.ptr<int>(roi.y + y) + roi.x;
    std::uint8_t* win = wins.ptr<std::uint8_t>(y);
    const double row = b * (roi.y + y) + c;
    for (int x = 0; x < roi.width; ++x) {
      const float inv = float(a * (roi.x + x) + row);
      const bool nearer = in[x] && inv > z[x];
      win[x] = nearer ? 255 : 0;
      if (nearer) {
        z[x] = inv;
        id[x] = plane.id;
        any = true;
      }
    }
  }
  if (!any) return;

  cv::Mat colour;
  cv::warpPerspective(plane.texture, colour, homography, roi.size(), cv::INTER_LINEAR,
                      cv::BORDER_REPLICATE);
  const float lb = float(light[0]), lg = float(light[1]), lr = float(light[2]);
  for (int y = 0; y < roi.height; ++y) {
    const std::uint8_t* win = wins.ptr<std::uint8_t>(y);
    const cv::Vec3b* src = colour.ptr<cv::Vec3b>(y);
    cv::Vec3f* dst = view.radiance.ptr<cv::Vec3f>(roi.y + y) + roi.x;
    for (int x = 0; x < roi.width; ++x)
      if (win[x]) dst[x] = {src[x][0] * lb, src[x][1] * lg, src[x][2] * lr};
  }
  if (plane.text_mask.empty()) {
    view.text_mask(roi).setTo(0, wins);
  } else {
    cv::Mat text;
    cv::warpPerspective(plane.text_mask, text, homography, roi.size(), cv::INTER_LINEAR,
                        cv::BORDER_CONSTANT, 0);
    cv::Mat on_text = text > 127;
    on_text.copyTo(view.text_mask(roi), wins);
  }
}

}  // namespace keyfleet::scenario
