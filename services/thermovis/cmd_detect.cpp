// thermovis detect: the people the detection stage finds in one image (or one registered
// infrared + visible pair), as text or JSON. The image is taken as it is (no rectified grid:
// no ground prior).
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "command.hpp"
#include "detect_options.hpp"
#include "thermovis/detect/evaluation.hpp"

namespace {

namespace dt = thermovis::detect;

struct Options {
  std::string image, visible;
  bool json = false;
  thermovis::cli::DetectorFlags detector;
};

int run_detect(const Options& opt) {
  dt::PersonDetector detector = opt.detector.make();
  const dt::Band band = detector.options().band;
  cv::Mat infrared, visible;
  if (band == dt::Band::visible) {
    visible = dt::read_visible_image(opt.image);
  } else {
    infrared = dt::read_infrared_image(opt.image);
  }
  if (band == dt::Band::fused) {
    if (opt.visible.empty()) throw std::invalid_argument("--band fused needs --visible FILE");
    visible = dt::read_visible_image(opt.visible);
  }
  const std::vector<dt::Detection> found = detector.detect(infrared, visible, nullptr);
  if (opt.json) {
    nlohmann::json boxes = nlohmann::json::array();
    for (const auto& d : found) {
      boxes.push_back({{"label", d.cls},
                       {"box", {d.box.x, d.box.y, d.box.br().x, d.box.br().y}},
                       {"score", d.score},
                       {"source", d.source}});
    }
    std::cout << nlohmann::json{{"image", opt.image},
                                {"band", dt::band_name(band)},
                                {"detections", boxes}}
                     .dump()
              << "\n";
    return 0;
  }
  std::cout << opt.image << ": " << found.size() << " detections (" << dt::band_name(band)
            << "; boxes [x0, y0, x1, y1] in 0-based pixel edges)\n";
  for (const auto& d : found) {
    std::cout << "  " << d.cls << " [" << d.box.x << ", " << d.box.y << ", " << d.box.br().x << ", "
              << d.box.br().y << "] score " << d.score << "\n";
  }
  return 0;
}

THERMOVIS_COMMAND("detect", "People in one image (or a registered infrared + visible pair)",
                  [](CLI::App& app) -> thermovis::cli::Runner {
                    auto opt = std::make_shared<Options>();
                    app.add_option("--image", opt->image,
                                   "image file: infrared (8-bit, or 16-bit raw counts) for "
                                   "--band infrared|fused, visible for --band visible")
                        ->required();
                    app.add_option("--visible", opt->visible,
                                   "--band fused: the visible image registered with --image");
                    app.add_flag("--json", opt->json, "one JSON object");
                    opt->detector.add_to(app);
                    return [opt] { return run_detect(*opt); };
                  });

}  // namespace
