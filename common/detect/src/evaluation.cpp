#include "thermovis/detect/evaluation.hpp"

#include <algorithm>
#include <cstdint>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <stdexcept>

namespace thermovis::detect {

namespace fs = std::filesystem;

namespace {

fs::path find_image(const fs::path& folder, const std::string& name) {
  for (const char* ext : {".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp", ".pgm"}) {
    const fs::path p = folder / (name + ext);
    if (fs::is_regular_file(p)) return p;
  }
  return {};
}

// One entry of boxes.json; throws std::invalid_argument saying what is wrong with it.
void parse_entry(const nlohmann::json& boxes, AnnotatedFrame& frame) {
  if (!boxes.is_array()) throw std::invalid_argument("expected a list of boxes");
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    const auto& b = boxes[i];
    const std::string where = "box " + std::to_string(i) + ": ";
    if (!b.is_object() || !b.contains("label") || !b["label"].is_string())
      throw std::invalid_argument(where + "expected {\"label\": text, \"box\": [x0, y0, x1, y1]}");
    if (!b.contains("box") || !b["box"].is_array() || b["box"].size() != 4)
      throw std::invalid_argument(where + "\"box\" must be 4 numbers [x0, y0, x1, y1]");
    double v[4];
    for (std::size_t k = 0; k < 4; ++k) {
      if (!b["box"][k].is_number())
        throw std::invalid_argument(where + "\"box\" must be 4 numbers [x0, y0, x1, y1]");
      v[k] = b["box"][k].get<double>();
    }
    if (!(v[2] > v[0] && v[3] > v[1]) || v[0] < 0 || v[1] < 0)
      throw std::invalid_argument(where + "needs 0 <= x0 < x1 and 0 <= y0 < y1 (pixel edges)");
    const cv::Rect r(cv::Point(cvRound(v[0]), cvRound(v[1])),
                     cv::Point(cvRound(v[2]), cvRound(v[3])));
    const std::string label = b["label"].get<std::string>();
    if (label == "person") frame.persons.push_back(r);
    if (label == "bicycle") frame.dont_care.push_back(r);
  }
}

}  // namespace

AnnotatedSet parse_annotated_set(const std::string& boxes_json, const fs::path& dir,
                                 const std::string& source_name) {
  nlohmann::json doc;
  try {
    doc = nlohmann::json::parse(boxes_json);
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(source_name + ": not JSON: " + e.what());
  }
  if (!doc.is_object())
    throw std::runtime_error(source_name + ": expected an object {\"<name>\": [boxes], ...}");
  AnnotatedSet set;
  for (const auto& [name, boxes] : doc.items()) {
    AnnotatedFrame frame;
    frame.name = name;
    try {
      parse_entry(boxes, frame);
    } catch (const std::invalid_argument& e) {
      set.errors.push_back(source_name + ": entry \"" + name + "\": " + e.what());
      continue;
    }
    frame.infrared = find_image(dir / "infrared", name);
    if (frame.infrared.empty()) {
      set.errors.push_back((dir / "infrared" / name).string() + ".*: no image for the entry \"" +
                           name + "\" of " + source_name);
      continue;
    }
    frame.visible = find_image(dir / "visible", name);
    set.frames.push_back(std::move(frame));
  }
  std::sort(set.frames.begin(), set.frames.end(),
            [](const AnnotatedFrame& a, const AnnotatedFrame& b) { return a.name < b.name; });
  return set;
}

AnnotatedSet load_annotated_set(const fs::path& dir) {
  if (!fs::is_directory(dir)) throw std::runtime_error(dir.string() + ": no such folder");
  const fs::path file = dir / "boxes.json";
  std::ifstream in(file);
  if (!in) throw std::runtime_error(file.string() + ": cannot read");
  std::stringstream text;
  text << in.rdbuf();
  return parse_annotated_set(text.str(), dir, file.string());
}

namespace {

cv::Mat read_image(const fs::path& file) {
  cv::Mat m = cv::imread(file.string(), cv::IMREAD_UNCHANGED);
  if (m.empty()) throw std::runtime_error(file.string() + ": cannot read the image (or empty)");
  return m;
}

std::runtime_error type_error(const fs::path& file, const cv::Mat& m, const std::string& expected) {
  return std::runtime_error(file.string() + ": " + std::to_string(m.channels()) +
                            "-channel image of depth " + cv::depthToString(m.depth()) +
                            ", expected " + expected);
}

}  // namespace

cv::Mat read_infrared_image(const fs::path& file) {
  const cv::Mat m = read_image(file);
  if (m.type() == CV_8UC1 || m.type() == CV_16UC1) return m;
  if (m.depth() != CV_8U || (m.channels() != 3 && m.channels() != 4))
    throw type_error(file, m, "8-bit or 16-bit greyscale");
  cv::Mat grey;
  cv::cvtColor(m, grey, m.channels() == 3 ? cv::COLOR_BGR2GRAY : cv::COLOR_BGRA2GRAY);
  return grey;
}

cv::Mat read_visible_image(const fs::path& file) {
  const cv::Mat m = read_image(file);
  if (m.type() == CV_8UC3) return m;
  if (m.type() != CV_8UC1 && m.type() != CV_8UC4)
    throw type_error(file, m, "8-bit greyscale or colour");
  cv::Mat bgr;
  cv::cvtColor(m, bgr, m.channels() == 1 ? cv::COLOR_GRAY2BGR : cv::COLOR_BGRA2BGR);
  return bgr;
}

FrameImages load_frame_images(const AnnotatedFrame& frame, bool need_visible) {
  FrameImages out;
  out.infrared = read_infrared_image(frame.infrared);
  if (need_visible) {
    if (frame.visible.empty())
      throw std::runtime_error("visible/" + frame.name + ".*: no visible image of the frame");
    out.visible = read_visible_image(frame.visible);
    if (out.visible.size() != out.infrared.size()) {
      throw std::runtime_error(frame.visible.string() + ": " + std::to_string(out.visible.cols) +
                               "x" + std::to_string(out.visible.rows) +
                               ", but the infrared image is " + std::to_string(out.infrared.cols) +
                               "x" + std::to_string(out.infrared.rows));
    }
  }
  const cv::Rect image(0, 0, out.infrared.cols, out.infrared.rows);
  for (std::size_t i = 0; i < frame.persons.size(); ++i) {
    if ((frame.persons[i] & image) != frame.persons[i]) {
      throw std::runtime_error("boxes.json: entry \"" + frame.name + "\": a person box reaches " +
                               "outside the " + std::to_string(image.width) + "x" +
                               std::to_string(image.height) + " image " +
                               frame.infrared.filename().string());
    }
  }
  return out;
}

bool is_training_frame(const std::string& name) {
  std::uint32_t h = 2166136261u;
  for (const char c : name.substr(0, name.empty() ? 0 : name.size() - 1)) {
    h ^= static_cast<std::uint8_t>(c);
    h *= 16777619u;
  }
  return h % 2 == 0;
}

Figures evaluate(const std::vector<FrameResult>& frames, double iou, double min_height,
                 double max_height) {
  auto in_range = [&](const cv::Rect& r) {
    return r.height >= min_height && r.height < max_height;
  };
  struct Ranked {
    double score;
    std::size_t frame, index;
  };
  std::vector<Ranked> ranked;
  Figures f;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    for (std::size_t k = 0; k < frames[i].detections.size(); ++k)
      ranked.push_back({frames[i].detections[k].score, i, k});
    for (const cv::Rect& p : frames[i].persons) f.persons += in_range(p) ? 1 : 0;
  }
  std::stable_sort(ranked.begin(), ranked.end(),
                   [](const Ranked& a, const Ranked& b) { return a.score > b.score; });
  std::vector<std::vector<bool>> taken(frames.size());
  for (std::size_t i = 0; i < frames.size(); ++i) taken[i].assign(frames[i].persons.size(), false);
  std::vector<int> hit;  // per counted detection: 1 true, 0 false positive
  for (const Ranked& r : ranked) {
    const FrameResult& fr = frames[r.frame];
    const cv::Rect& box = fr.detections[r.index].box;
    double best = 0.0;
    std::size_t best_k = 0;
    for (std::size_t k = 0; k < fr.persons.size(); ++k) {
      const double o = intersection_over_union(box, fr.persons[k]);
      if (o > best) best = o, best_k = k;
    }
    if (best >= iou) {
      // VOC: the best-overlapping person decides; a second detection of it is a false positive.
      const bool counted = in_range(fr.persons[best_k]);
      if (!counted) continue;
      hit.push_back(taken[r.frame][best_k] ? 0 : 1);
      taken[r.frame][best_k] = true;
      continue;
    }
    bool dont_care = false;
    for (const cv::Rect& d : fr.dont_care)
      dont_care = dont_care || intersection_over_union(box, d) >= iou;
    if (dont_care || !in_range(box)) continue;
    hit.push_back(0);
  }
  f.detections = static_cast<int>(hit.size());
  std::vector<double> recall, precision;
  int tp = 0;
  for (std::size_t i = 0; i < hit.size(); ++i) {
    tp += hit[i];
    recall.push_back(f.persons ? static_cast<double>(tp) / f.persons : 0.0);
    precision.push_back(static_cast<double>(tp) / static_cast<double>(i + 1));
  }
  f.true_positives = tp;
  f.precision = hit.empty() ? 0.0 : precision.back();
  f.recall = recall.empty() ? 0.0 : recall.back();
  // All-point interpolation: precision made non-increasing from the right, integrated over the
  // recall steps.
  for (std::size_t i = precision.size(); i-- > 1;)
    precision[i - 1] = std::max(precision[i - 1], precision[i]);
  double previous = 0.0;
  for (std::size_t i = 0; i < recall.size(); ++i) {
    f.ap += (recall[i] - previous) * precision[i];
    previous = recall[i];
  }
  return f;
}

}  // namespace thermovis::detect
