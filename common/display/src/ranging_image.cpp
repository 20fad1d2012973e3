#include "thermovis/display/ranging_image.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

#include "thermovis/display/frame_stamp.hpp"
#include "thermovis/util/enum_names.hpp"

namespace thermovis::display {
namespace {

constexpr util::EnumName<View> kViewNames[] = {{View::fused, "fused"},
                                               {View::visible, "visible"},
                                               {View::infrared, "infrared"},
                                               {View::side_by_side, "side"}};

constexpr util::EnumName<std::uint32_t> kBandNames[] = {
    {kBandVisible, "visible"}, {kBandInfrared, "infrared"}, {kBandFused, "fused"}};

constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;

cv::Mat to_bgr(const cv::Mat& image) {
  if (image.empty()) throw std::invalid_argument("display: empty image");
  if (image.type() == CV_8UC3) return image.clone();
  if (image.type() == CV_8UC1) {
    cv::Mat bgr;
    cv::cvtColor(image, bgr, cv::COLOR_GRAY2BGR);
    return bgr;
  }
  throw std::invalid_argument("display: image type " + std::to_string(image.type()) +
                              ", expected 8-bit grey or BGR");
}

// Box colours by band, chosen to stand out on grey infrared and on colour imagery alike.
cv::Scalar colour_of(const Target& t) {
  if (t.obstacle) return {255, 64, 255};  // magenta
  if (!std::isfinite(t.distance_m)) return {160, 160, 160};
  switch (t.band) {
    case kBandVisible:
      return {0, 230, 255};  // yellow
    case kBandInfrared:
      return {0, 128, 255};  // orange
    default:
      return {80, 255, 80};  // green
  }
}

// The plate of a text at `origin` (its top-left), kept inside the image.
cv::Rect plate_of(const cv::Mat& image, const std::string& text, cv::Point origin, double scale) {
  int baseline = 0;
  const cv::Size size = cv::getTextSize(text, kFont, scale, 1, &baseline);
  const int pad = 2;
  const cv::Size plate(size.width + 2 * pad, size.height + baseline + 2 * pad);
  origin.x = std::clamp(origin.x, 0, std::max(0, image.cols - plate.width));
  origin.y = std::clamp(origin.y, 0, std::max(0, image.rows - plate.height));
  return {origin, plate};
}

// Text on a dark plate so that it reads on any background.
void label(cv::Mat& image, const std::string& text, const cv::Rect& plate, double scale,
           const cv::Scalar& colour) {
  int baseline = 0;
  const cv::Size size = cv::getTextSize(text, kFont, scale, 1, &baseline);
  cv::rectangle(image, plate, cv::Scalar(0, 0, 0), cv::FILLED);
  cv::putText(image, text, plate.tl() + cv::Point(2, 2 + size.height), kFont, scale, colour, 1,
              cv::LINE_AA);
}

void label(cv::Mat& image, const std::string& text, cv::Point origin, double scale,
           const cv::Scalar& colour) {
  label(image, text, plate_of(image, text, origin, scale), scale, colour);
}

void draw_targets(cv::Mat& image, const std::vector<Target>& targets, double scale) {
  const double text_scale = std::clamp(image.cols / 1800.0, 0.35, 0.6);
  std::vector<cv::Rect> boxes;
  std::vector<const Target*> drawn;
  for (const Target& t : targets) {
    if (!(std::isfinite(t.box.x) && std::isfinite(t.box.y) && std::isfinite(t.box.width) &&
          std::isfinite(t.box.height)))
      continue;
    boxes.emplace_back(cv::Point(static_cast<int>(std::floor(t.box.x * scale)),
                                 static_cast<int>(std::floor(t.box.y * scale))),
                       cv::Point(static_cast<int>(std::ceil((t.box.x + t.box.width) * scale)),
                                 static_cast<int>(std::ceil((t.box.y + t.box.height) * scale))));
    drawn.push_back(&t);
    cv::rectangle(image, boxes.back(), colour_of(t), 2, cv::LINE_AA);
  }
  // Captions after all boxes, each where it overlaps no caption placed before: above its box,
  // else below it, else stacked further up (distant people stand close together in the image).
  std::vector<cv::Rect> placed;
  for (std::size_t i = 0; i < drawn.size(); ++i) {
    const cv::Rect& box = boxes[i];
    const std::string text = target_caption(*drawn[i]);
    const int height = plate_of(image, text, {0, 0}, text_scale).height;
    std::vector<cv::Point> candidates{{box.x, box.y - height - 2}, {box.x, box.y + box.height + 2}};
    for (int k = 2; k < 8; ++k) candidates.emplace_back(box.x, box.y - k * (height + 1) - 2);
    cv::Rect plate = plate_of(image, text, candidates.front(), text_scale);
    for (const cv::Point& c : candidates) {
      const cv::Rect p = plate_of(image, text, c, text_scale);
      if (std::none_of(placed.begin(), placed.end(),
                       [&](const cv::Rect& q) { return (p & q).area() > 0; })) {
        plate = p;
        break;
      }
    }
    placed.push_back(plate);
    label(image, text, plate, text_scale, colour_of(*drawn[i]));
  }
}

// The free space as a line through each column's row (broken where it is unknown).
void draw_free_space(cv::Mat& image, const Overlay& overlay, double scale) {
  std::vector<cv::Point> run;
  const auto flush = [&] {
    if (run.size() >= 2) {
      cv::polylines(image, run, false, cv::Scalar(255, 255, 0), 2, cv::LINE_AA);  // cyan
    }
    run.clear();
  };
  for (std::size_t u = 0; u < overlay.free_space_row.size(); ++u) {
    const float row = overlay.free_space_row[u];
    if (!std::isfinite(row)) {
      flush();
      continue;
    }
    run.emplace_back(static_cast<int>(std::lround(static_cast<double>(u) * scale)),
                     static_cast<int>(std::lround(row * scale)));
  }
  flush();
}

std::string status_text(const Status& s) {
  char text[256];
  std::string latency = "-";
  if (std::isfinite(s.latency_ms)) {
    char l[32];
    std::snprintf(l, sizeof l, "%.1f ms", s.latency_ms);
    latency = l;
  }
  std::snprintf(text, sizeof text,
                "frame %llu   capture to range %s   over %.0f ms: %llu of %llu   DEADLINE "
                "misses %llu",
                static_cast<unsigned long long>(s.frame_seq), latency.c_str(), s.deadline_ms,
                static_cast<unsigned long long>(s.over_deadline),
                static_cast<unsigned long long>(s.frames),
                static_cast<unsigned long long>(s.deadline_misses));
  std::string out = text;
  if (!s.note.empty()) out += "   " + s.note;
  return out;
}

// Header (stamp, then the status line) above `body`, padded to the stamp's width.
cv::Mat with_header(const cv::Mat& body, const Status& status) {
  const int width = std::max(body.cols, kStampWidth);
  cv::Mat out(body.rows + kHeaderRows, width, CV_8UC3, cv::Scalar(0, 0, 0));
  body.copyTo(out(cv::Rect(0, kHeaderRows, body.cols, body.rows)));
  draw_stamp(out, status.frame_seq, status.capture_time_ns);
  const bool late = std::isfinite(status.latency_ms) && status.latency_ms > status.deadline_ms;
  const double scale = 0.42;
  cv::putText(out, status_text(status), {4, kStampCell + 18}, kFont, scale,
              late ? cv::Scalar(80, 160, 255) : cv::Scalar(230, 230, 230), 1, cv::LINE_AA);
  return out;
}

}  // namespace

const char* to_string(View view) { return util::name_of(kViewNames, view, "fused"); }

std::optional<View> parse_view(const std::string& name) { return util::parse(kViewNames, name); }

const char* band_name(std::uint32_t band) { return util::name_of(kBandNames, band, "-"); }

std::string target_caption(const Target& t) {
  char text[128];
  // People are what the display is mostly about: their class goes without saying.
  const std::string name =
      (t.label.empty() || t.label == "person" ? std::string() : t.label + " ") + "#" +
      std::to_string(t.id);
  if (t.obstacle) {
    std::snprintf(text, sizeof text, "obstacle %.1f m", t.distance_m);
  } else if (!std::isfinite(t.distance_m)) {
    std::snprintf(text, sizeof text, "%s no range", name.c_str());
  } else {
    const char* band = t.band == kBandVisible    ? " VIS"
                       : t.band == kBandInfrared ? " IR"
                       : t.band == kBandFused    ? " FUS"
                                                 : "";
    std::snprintf(text, sizeof text, "%s %.2f +- %.2f m%s", name.c_str(), t.distance_m, t.sigma_m,
                  band);
  }
  return text;
}

cv::Mat compose(const cv::Mat& image, const std::vector<Target>& targets, const Status& status,
                const Overlay& overlay) {
  cv::Mat body = to_bgr(image);
  draw_free_space(body, overlay, 1.0);
  draw_targets(body, targets, 1.0);
  return with_header(body, status);
}

cv::Mat compose_side_by_side(const cv::Mat& visible, const cv::Mat& infrared, const cv::Mat& fused,
                             const std::vector<Target>& targets, const Status& status,
                             double panel_scale, const Overlay& overlay) {
  if (!(panel_scale > 0.0 && panel_scale <= 1.0))
    throw std::invalid_argument("display: panel scale must be in (0, 1]");
  if (visible.size() != infrared.size() || visible.size() != fused.size())
    throw std::invalid_argument("display: side-by-side panels differ in size");
  std::vector<cv::Mat> panels;
  const char* names[] = {"visible", "infrared", "fused"};
  int i = 0;
  for (const cv::Mat* m : {&visible, &infrared, &fused}) {
    cv::Mat panel;
    cv::resize(to_bgr(*m), panel, cv::Size(), panel_scale, panel_scale, cv::INTER_AREA);
    draw_free_space(panel, overlay, panel_scale);
    draw_targets(panel, targets, panel_scale);
    label(panel, names[i++], {panel.cols - 80, panel.rows - 20}, 0.45, {255, 255, 255});
    panels.push_back(panel);
  }
  cv::Mat row;
  cv::hconcat(panels, row);
  return with_header(row, status);
}

}  // namespace thermovis::display
