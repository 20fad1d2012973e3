// thermovis-rectify-fuse: raw stereo frames -> rectified, registered and fused stereo frames.
#include <CLI/CLI.hpp>
#include <iostream>

#include "rectify_fuse_node.hpp"
#include "thermovis/node/service.hpp"
#include "thermovis/runtime/grid_options.hpp"
#include "thermovis/runtime/rig_io.hpp"

int main(int argc, char** argv) {
  using namespace thermovis;
  node::ServiceApp app("thermovis-rectify-fuse",
                       "rectification, registration, enhancement and fusion");
  rectify_fuse::RectifyFuseConfig config;
  std::string method = "fast";
  bool no_enhance = false;
  runtime::add_grid_options(app, config.grid);
  app.add_option("--fusion", method, "fast | vsmwls | vsmwls-paper")->capture_default_str();
  app.add_flag("--no-enhance", no_enhance, "skip the visible contrast enhancement");
  bool no_bin = false;
  app.add_flag("--no-bin-visible", no_bin,
               "remap the visible cameras' raw images as they are, not binned to about the "
               "grid's px per rad first (2 x 2 on the pipeline grid)");
  std::string visible_encoding = "mono8";
  app.add_option("--visible-encoding", visible_encoding,
                 "thermovis/rectified/visible's pixels: mono8 (the cameras' luma: every stage "
                 "matches, detects and finds obstacles on it, and a third of the bytes costs "
                 "less to rectify) | bgr8 (their colour, for readers that want it); "
                 "thermovis/fused keeps the colour either way")
      ->check(CLI::IsMember({"bgr8", "mono8"}))
      ->capture_default_str();
  std::string fused_eyes = "left";
  app.add_option("--fused-eyes", fused_eyes,
                 "left (the display's) | both (needed by thermovis-match --band fused)")
      ->check(CLI::IsMember({"left", "both"}))
      ->capture_default_str();
  bool parallel_bands = false;
  app.add_flag("--parallel-bands", parallel_bands,
               "rectify the visible pair on a second thread while the infrared pair is "
               "rectified (for machines with a spare core; on a saturated one it delays the "
               "infrared pair that detection waits for)");
  app.add_option("--fused-rate-hz", config.fused_rate_hz,
                 "thermovis/fused (left eye) at most this many captures a second, 0: every "
                 "capture (with --fused-eyes both always every capture)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app.add_deadline_option("DEADLINE QoS period");
  CLI11_PARSE(app, argc, argv);

  return node::run_service(app.common, [&] {
    const auto parsed = fuse::method_from_name(method);
    if (!parsed) throw std::invalid_argument("unknown fusion method '" + method + "'");
    config.stage.fusion.method = *parsed;
    if (no_enhance) config.stage.fusion.enhance_visible.reset();
    config.stage.bin_visible = !no_bin;
    config.stage.visible_mono = visible_encoding == "mono8";
    config.fuse_right_eye = fused_eyes == "both";
    config.parallel_bands = parallel_bands;
    config.deadline = app.deadline();
    const auto rig = runtime::load_rig_or_default(app.common.rig);
    auto participant = node::make_participant(app.common);
    rectify_fuse::RectifyFuseNode node(*participant, rig, config, app.common.service);
    std::cerr << "thermovis-rectify-fuse: grid " << node.grid_size().width << "x"
              << node.grid_size().height << "\n";
    node.run();
    const auto stats = node.stats();
    std::cerr << "thermovis-rectify-fuse: processed " << stats.processed << ", dropped "
              << stats.dropped << ", bad " << stats.bad << ", repeated " << stats.repeated
              << ", fused " << stats.fused << ", not fused under the fused rate "
              << stats.fusion_skipped << "\n";
  });
}
