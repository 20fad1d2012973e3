#include "renderer.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

namespace thermovis::sim::detail {
namespace {

constexpr int kSuperSamples = 4;        // per axis, at static edges: coverage to 1/16 of a pixel
constexpr int kMovingSuperSamples = 3;  // per axis, at moving targets' edges (per frame: cheaper)
constexpr int kRegionPad = 2;           // px around a moving target's projected box

}  // namespace

Renderer::Renderer(const Scene& scene)
    : world_(std::make_unique<World>(scene)),
      exposure_(scene.visible),
      ir_transfer_(scene.infrared),
      static_targets_(world_->place(false, 0.0)),
      sky_counts_(ir_transfer_.counts(scene.infrared.sky_c)) {
  for (const auto& t : world_->targets()) hull_points_.push_back(hull_of(t));
}

void Renderer::finish_static_scene(CameraLayers& c) const {
  c.static_clean.create(c.size, c.image_type());
  finish(c, c.static_linear, cv::Rect(cv::Point(0, 0), c.size), c.static_clean, true);
}

bool Renderer::is_moving_id(std::uint16_t id) const {
  if (id < kFirstTargetId || id == kNoRayId) return false;
  const std::size_t i = id - kFirstTargetId;
  return i < world_->targets().size() && world_->targets()[i].spec.moving();
}

Renderer::Linear Renderer::radiance(const CameraLayers& c, const Hit& hit,
                                    const Eigen::Vector3d& d) const {
  if (hit.texture < 0) {  // sky
    if (!c.visible) return {sky_counts_, 0.0f, 0.0f};
    const Eigen::Vector3f sky =
        (world_->scene().visible.sky_colour * exposure_.white_dn).cast<float>();
    return {sky.x(), sky.y(), sky.z()};
  }
  const SurfaceSample s = world_->shade(hit, d, c.pixel_angle_rad);
  if (!c.visible) return {ir_transfer_.counts(s.temperature_c), 0.0f, 0.0f};
  // Uniform textures are self-luminous (markers, lamps): not shaded by the sun.
  const bool shaded = world_->scene().textures[static_cast<std::size_t>(hit.texture)].pattern !=
                      TexturePattern::uniform;
  const float k =
      (shaded ? World::lighting(hit.normal) : 1.0f) * static_cast<float>(exposure_.white_dn);
  return {k * s.reflectance_bgr.x(), k * s.reflectance_bgr.y(), k * s.reflectance_bgr.z()};
}

// The static scene along one ray.
Renderer::Linear Renderer::trace_static(const CameraLayers& c, const Eigen::Vector3d& d,
                                        Hit& hit) const {
  world_->trace_background(c.centre, d, hit);
  World::trace_targets(static_targets_, c.centre, d, hit);
  return radiance(c, hit, d);
}

// Mean of the static scene over kSuperSamples^2 rays spread over the pixel's area.
Renderer::Linear Renderer::supersample_static(const CameraLayers& c, int x, int y) const {
  Linear sum(0.0f, 0.0f, 0.0f);
  int count = 0;
  for (int j = 0; j < kSuperSamples; ++j) {
    for (int i = 0; i < kSuperSamples; ++i) {
      const Eigen::Vector2d px(x - 0.5 + (i + 0.5) / kSuperSamples,
                               y - 0.5 + (j + 0.5) / kSuperSamples);
      Eigen::Vector3d ray;
      if (!c.camera->model->unproject(px, ray)) continue;
      Hit hit;
      sum += trace_static(c, c.R_world_cam * ray.normalized(), hit);
      ++count;
    }
  }
  return count > 0 ? sum * (1.0f / static_cast<float>(count)) : sum;
}

// The ray through image point (px, py), bilinear between the precomputed pixel rays (the ray
// field is smooth: the error is far below a hundredth of a pixel); exact where a neighbour
// has no ray.
Eigen::Vector3d Renderer::ray_at(const CameraLayers& c, double px, double py) const {
  const int x0 = std::clamp(static_cast<int>(std::floor(px)), 0, c.size.width - 2);
  const int y0 = std::clamp(static_cast<int>(std::floor(py)), 0, c.size.height - 2);
  const float fx = static_cast<float>(px - x0), fy = static_cast<float>(py - y0);
  const float gx = 1.0f - fx, gy = 1.0f - fy;
  const float* a = c.rays.ptr<float>(y0) + 3 * x0;      // then b = a + 3
  const float* d = c.rays.ptr<float>(y0 + 1) + 3 * x0;  // then e = d + 3
  float r[3];
  for (int k = 0; k < 3; ++k)
    r[k] = (a[k] * gx + a[k + 3] * fx) * gy + (d[k] * gx + d[k + 3] * fx) * fy;
  if (std::isnan(r[0])) {
    Eigen::Vector3d ray;
    if (!c.camera->model->unproject(Eigen::Vector2d(px, py), ray))
      return Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
    return c.R_world_cam * ray.normalized();
  }
  // Not renormalised: between neighbouring unit rays the interpolated length is 1 to within
  // 1e-6 (like the float pixel rays' 1e-7), and every intersection takes any length.
  return {r[0], r[1], r[2]};
}

// Anti-aliasing of a moving target's edge pixel: kMovingSuperSamples^2 rays against the moving
// targets; the rays that miss them see the static scene, whose pixel value (already
// anti-aliased) stands for it. Each target part is shaded once per pixel.
Renderer::Linear Renderer::supersample_moving(const CameraLayers& c, int x, int y,
                                              const std::vector<const PreparedTarget*>& moving,
                                              const Linear& static_value) const {
  const double depth = c.static_depth.at<float>(y, x);
  Linear sum(0.0f, 0.0f, 0.0f);
  int count = 0;
  int shaded_texture = -1;
  std::uint16_t shaded_id = kNoRayId;
  Linear shaded(0.0f, 0.0f, 0.0f);
  for (int j = 0; j < kMovingSuperSamples; ++j) {
    for (int i = 0; i < kMovingSuperSamples; ++i) {
      const Eigen::Vector3d d = ray_at(c, x - 0.5 + (i + 0.5) / kMovingSuperSamples,
                                       y - 0.5 + (j + 0.5) / kMovingSuperSamples);
      if (std::isnan(d.x())) continue;
      ++count;
      Hit hit;
      hit.t = depth;
      for (const PreparedTarget* pt : moving) World::trace_target(*pt, d, hit);
      if (hit.texture < 0) {
        sum += static_value;
        continue;
      }
      if (hit.id != shaded_id || hit.texture != shaded_texture) {
        shaded = radiance(c, hit, d);
        shaded_id = hit.id;
        shaded_texture = hit.texture;
      }
      sum += shaded;
    }
  }
  return count > 0 ? sum * (1.0f / static_cast<float>(count)) : static_value;
}

// Each pixel's ray, and the static scene along it: depth, surface id and linear value,
// supersampled at edges.
void Renderer::trace_static_scene(CameraLayers& c) const {
  const camera::RigCamera& cam = *c.camera;
  const int linear_type = c.visible ? CV_32FC3 : CV_32FC1;
  c.rays.create(c.size, CV_32FC3);
  c.static_depth.create(c.size, CV_32FC1);
  c.static_id.create(c.size, CV_16UC1);
  c.static_linear.create(c.size, linear_type);
  cv::parallel_for_(cv::Range(0, c.size.height), [&](const cv::Range& rows) {
    for (int y = rows.start; y < rows.end; ++y) {
      for (int x = 0; x < c.size.width; ++x) {
        Eigen::Vector3d ray;
        auto& r = c.rays.at<cv::Vec3f>(y, x);
        if (!cam.model->unproject(Eigen::Vector2d(x, y), ray)) {
          r = cv::Vec3f(NAN, NAN, NAN);
          c.static_depth.at<float>(y, x) = 0.0f;
          c.static_id.at<std::uint16_t>(y, x) = kNoRayId;
          set_linear(c.static_linear, y, x, Linear(0.0f, 0.0f, 0.0f));
          continue;
        }
        const Eigen::Vector3d d = c.R_world_cam * ray.normalized();
        r = cv::Vec3f(static_cast<float>(d.x()), static_cast<float>(d.y()),
                      static_cast<float>(d.z()));
        Hit hit;
        set_linear(c.static_linear, y, x, trace_static(c, d, hit));
        c.static_depth.at<float>(y, x) = static_cast<float>(hit.t);
        c.static_id.at<std::uint16_t>(y, x) = hit.id;
      }
    }
  });
  // Anti-aliasing: supersample the pixels on an edge between two things.
  cv::parallel_for_(cv::Range(0, c.size.height), [&](const cv::Range& rows) {
    for (int y = rows.start; y < rows.end; ++y) {
      for (int x = 0; x < c.size.width; ++x) {
        if (on_edge(c.static_id, y, x, c.static_id, cv::Point(0, 0)))
          set_linear(c.static_linear, y, x, supersample_static(c, x, y));
      }
    }
  });
}

void Renderer::set_linear(cv::Mat& m, int y, int x, const Linear& v) {
  if (m.channels() == 3) {
    m.at<cv::Vec3f>(y, x) = v;
  } else {
    m.at<float>(y, x) = v[0];
  }
}

Renderer::Linear Renderer::get_linear(const cv::Mat& m, int y, int x) {
  if (m.channels() == 3) return m.at<cv::Vec3f>(y, x);
  return {m.at<float>(y, x), 0.0f, 0.0f};
}

// True when pixel (y, x) of `ids` (whose top-left is `origin` in the image) has a 4-neighbour
// with another id; neighbours outside `ids` are read from the full-image `static_ids`.
bool Renderer::on_edge(const cv::Mat& ids, int y, int x, const cv::Mat& static_ids,
                       cv::Point origin) {
  const std::uint16_t id = ids.at<std::uint16_t>(y, x);
  if (id == kNoRayId) return false;
  constexpr int dx[4] = {1, -1, 0, 0}, dy[4] = {0, 0, 1, -1};
  for (int k = 0; k < 4; ++k) {
    const int nx = x + dx[k], ny = y + dy[k];
    std::uint16_t other = id;
    if (nx >= 0 && ny >= 0 && nx < ids.cols && ny < ids.rows) {
      other = ids.at<std::uint16_t>(ny, nx);
    } else {
      const int gx = nx + origin.x, gy = ny + origin.y;
      if (gx >= 0 && gy >= 0 && gx < static_ids.cols && gy < static_ids.rows)
        other = static_ids.at<std::uint16_t>(gy, gx);
    }
    if (other != id && other != kNoRayId) return true;
  }
  return false;
}

// Linear values of `rect` (image coordinates; `linear` and `clean` hold just that rectangle)
// -> the noise-free raw image; `blur` applies the visible optical blur first.
void Renderer::finish(const CameraLayers& c, const cv::Mat& linear, cv::Rect rect, cv::Mat& clean,
                      bool blur) const {
  if (c.visible) {
    const double sigma = world_->scene().visible.blur_sigma_px;
    if (blur && sigma > 0.0) {
      cv::Mat blurred;
      cv::GaussianBlur(linear, blurred, cv::Size(0, 0), sigma, sigma, cv::BORDER_REPLICATE);
      blurred.convertTo(clean, CV_8UC3);
    } else {
      linear.convertTo(clean, CV_8UC3);
    }
    return;
  }
  const float ref = static_cast<float>(world_->scene().infrared.counts_at_20c);
  const auto top = static_cast<float>(c.max_count());
  for (int y = 0; y < rect.height; ++y) {
    const float* in = linear.ptr<float>(y);
    const float* offset = c.fpn_offset.ptr<float>(rect.y + y) + rect.x;
    const float* gain = c.fpn_gain.ptr<float>(rect.y + y) + rect.x;
    auto* out = clean.ptr<std::uint16_t>(y);
    for (int x = 0; x < rect.width; ++x) {
      const float counts = ref + gain[x] * (in[x] - ref) + offset[x];
      out[x] = static_cast<std::uint16_t>(std::lround(std::clamp(counts, 0.0f, top)));
    }
  }
}

std::vector<Eigen::Vector3d> Renderer::hull_of(const CompiledTarget& t) {
  // Corners of the local bounding box and 4 points along each edge: the projected extent of
  // a box whose edges the lens bends.
  std::vector<Eigen::Vector3d> pts;
  const Eigen::Vector3d lo = t.bound_lo, hi = t.bound_hi;
  for (int i = 0; i <= 5; ++i) {
    for (int j = 0; j <= 5; ++j) {
      for (int k = 0; k <= 5; ++k) {
        const int ends = (i % 5 == 0) + (j % 5 == 0) + (k % 5 == 0);
        if (ends < 2) continue;  // corners and edges only
        const Eigen::Vector3d f(i / 5.0, j / 5.0, k / 5.0);
        pts.push_back(lo + (hi - lo).cwiseProduct(f));
      }
    }
  }
  return pts;
}

std::optional<TruthBox> Renderer::projected_extent(const CameraLayers& c,
                                                   const std::vector<Eigen::Vector3d>& points,
                                                   const CompiledTarget& target,
                                                   const Eigen::Vector3d& foot) const {
  TruthBox box{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
               -std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
  bool any_valid = false;
  bool beyond_left = false, beyond_right = false, beyond_top = false, beyond_bottom = false;
  for (const Eigen::Vector3d& p : points) {
    const Eigen::Vector3d ray = c.T_cam_world * (foot + target.R_world_local * p);
    Eigen::Vector2d px;
    if (!c.camera->model->project(ray, px)) {
      beyond_left = beyond_left || ray.x() < 0.0;
      beyond_right = beyond_right || ray.x() > 0.0;
      beyond_top = beyond_top || ray.y() < 0.0;
      beyond_bottom = beyond_bottom || ray.y() > 0.0;
      continue;
    }
    any_valid = true;
    box.x_min = std::min(box.x_min, px.x());
    box.y_min = std::min(box.y_min, px.y());
    box.x_max = std::max(box.x_max, px.x());
    box.y_max = std::max(box.y_max, px.y());
  }
  if (!any_valid) return std::nullopt;
  if (beyond_left) box.x_min = -0.5;
  if (beyond_right) box.x_max = c.size.width - 0.5;
  if (beyond_top) box.y_min = -0.5;
  if (beyond_bottom) box.y_max = c.size.height - 0.5;
  return box;
}

// The image rectangle a placed target may cover in camera c (with a margin), or an empty one.
cv::Rect Renderer::target_region(const CameraLayers& c, const PlacedTarget& pt) const {
  const std::size_t index = pt.target->id - kFirstTargetId;
  const auto extent = projected_extent(c, hull_points_[index], *pt.target, pt.foot);
  if (!extent) return {};
  const int margin = kRegionPad + blur_radius(c);
  const cv::Rect box(cv::Point(static_cast<int>(std::floor(extent->x_min)) - margin,
                               static_cast<int>(std::floor(extent->y_min)) - margin),
                     cv::Point(static_cast<int>(std::ceil(extent->x_max)) + margin + 1,
                               static_cast<int>(std::ceil(extent->y_max)) + margin + 1));
  return box & cv::Rect(cv::Point(0, 0), c.size);
}

int Renderer::blur_radius(const CameraLayers& c) const {
  if (!c.visible || world_->scene().visible.blur_sigma_px <= 0.0) return 0;
  return static_cast<int>(std::ceil(4.0 * world_->scene().visible.blur_sigma_px));
}

// The prepared targets whose region (`regions`, image coordinates) holds pixel (x, y): the
// only ones its rays can meet, since a region holds its target's projection with a margin.
void Renderer::covering(const std::vector<PreparedTarget>& prepared,
                        const std::vector<cv::Rect>& regions, int x, int y,
                        std::vector<const PreparedTarget*>& out) {
  out.clear();
  for (std::size_t k = 0; k < prepared.size(); ++k) {
    if (regions[k].contains(cv::Point(x, y))) out.push_back(&prepared[k]);
  }
}

void Renderer::render_region(const CameraLayers& c, cv::Rect out_rect,
                             const std::vector<PlacedTarget>& moving,
                             const std::vector<cv::Rect>& moving_regions, cv::Mat& clean) const {
  const int rb = blur_radius(c);
  const cv::Rect image(cv::Point(0, 0), c.size);
  const cv::Rect rr = cv::Rect(out_rect.x - rb, out_rect.y - rb, out_rect.width + 2 * rb,
                               out_rect.height + 2 * rb) &
                      image;
  const std::vector<PreparedTarget> prepared = World::prepare(moving, c.centre);
  std::vector<const PreparedTarget*> near;
  near.reserve(prepared.size());
  cv::Mat linear, ids;
  c.static_linear(rr).copyTo(linear);
  c.static_id(rr).copyTo(ids);
  for (int y = 0; y < rr.height; ++y) {
    const int gy = rr.y + y;
    const auto* static_id = c.static_id.ptr<std::uint16_t>(gy) + rr.x;
    const float* depth = c.static_depth.ptr<float>(gy) + rr.x;
    const float* ray = c.rays.ptr<float>(gy) + 3 * rr.x;
    auto* id = ids.ptr<std::uint16_t>(y);
    for (int x = 0; x < rr.width; ++x) {
      if (static_id[x] == kNoRayId) continue;
      covering(prepared, moving_regions, rr.x + x, gy, near);
      if (near.empty()) continue;
      const Eigen::Vector3d d(ray[3 * x], ray[3 * x + 1], ray[3 * x + 2]);
      Hit hit;
      hit.t = depth[x];
      for (const PreparedTarget* pt : near) World::trace_target(*pt, d, hit);
      if (hit.texture < 0) continue;  // no moving target in front of the static scene
      id[x] = hit.id;
      set_linear(linear, y, x, radiance(c, hit, d));
    }
  }
  for (int y = 0; y < rr.height; ++y) {
    for (int x = 0; x < rr.width; ++x) {
      if (!on_edge(ids, y, x, c.static_id, rr.tl())) continue;
      // Only edges that involve a moving target changed; static edges are already smooth.
      const std::uint16_t id = ids.at<std::uint16_t>(y, x);
      bool involves_moving = is_moving_id(id);
      for (const cv::Point n :
           {cv::Point(1, 0), cv::Point(-1, 0), cv::Point(0, 1), cv::Point(0, -1)}) {
        const int nx = x + n.x, ny = y + n.y;
        if (nx >= 0 && ny >= 0 && nx < rr.width && ny < rr.height)
          involves_moving = involves_moving || is_moving_id(ids.at<std::uint16_t>(ny, nx));
      }
      if (involves_moving) {
        covering(prepared, moving_regions, rr.x + x, rr.y + y, near);
        set_linear(linear, y, x,
                   supersample_moving(c, rr.x + x, rr.y + y, near,
                                      get_linear(c.static_linear, rr.y + y, rr.x + x)));
      }
    }
  }
  cv::Mat finished = linear;
  if (rb > 0) {
    cv::GaussianBlur(linear, finished, cv::Size(0, 0), world_->scene().visible.blur_sigma_px,
                     world_->scene().visible.blur_sigma_px, cv::BORDER_REPLICATE);
  }
  const cv::Rect inner = out_rect - rr.tl();
  clean.create(out_rect.size(), c.image_type());
  finish(c, finished(inner), out_rect, clean, false);
}

std::vector<cv::Rect> Renderer::regions(const CameraLayers& c,
                                        const std::vector<PlacedTarget>& moving) const {
  std::vector<cv::Rect> out;
  for (const PlacedTarget& pt : moving) out.push_back(target_region(c, pt));
  return out;
}

}  // namespace thermovis::sim::detail
