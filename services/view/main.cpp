// thermovis-view: the live fusion-ranging display. Reads the pipeline's frames and results,
// publishes the fusion-ranging image on thermovis/display and serves it to browsers.
#include <CLI/CLI.hpp>
#include <iostream>

#include "thermovis/node/service.hpp"
#include "view_node.hpp"
#include "web_server.hpp"

int main(int argc, char** argv) {
  using namespace thermovis;
  node::ServiceApp app("thermovis-view",
                       "the fusion-ranging image, live in a browser and on thermovis/display");
  std::string host = "127.0.0.1";
  int port = 8090;
  view::ViewConfig config;
  app.add_option("--port", port, "HTTP port (0: any free port, printed)")
      ->capture_default_str()
      ->check(CLI::Range(0, 65535));
  app.add_option("--bind", host, "address to listen on (0.0.0.0: every interface)")
      ->capture_default_str();
  app.add_option("--max-fps", config.max_fps, "compositions and encodes per second")
      ->capture_default_str()
      ->check(CLI::Range(0.5, 60.0));
  app.add_option("--jpeg-quality", config.jpeg_quality, "JPEG quality of the stream")
      ->capture_default_str()
      ->check(CLI::Range(10, 100));
  app.add_option("--latency-deadline-ms", config.deadline_ms, "latency budget drawn and counted")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  CLI11_PARSE(app, argc, argv);

  return node::run_service(app.common, [&] {
    auto participant = node::make_participant(app.common);
    view::ViewHub hub;
    view::ViewNode viewer(*participant, hub, config, app.common.service);
    view::WebServer web(hub, host, port);
    web.start();
    std::cout << app.common.service << ": serving http://"
              << (host == "0.0.0.0" ? "127.0.0.1" : host) << ":" << web.port() << "/" << std::endl;
    viewer.run();
    web.stop();
    const auto s = viewer.stats();
    std::cerr << app.common.service << ": fused frames " << s.fused_frames << ", composed "
              << s.composed << ", encoded " << s.encoded << ", overwritten while copied "
              << s.overwritten << ", bad " << s.bad << "\n";
  });
}
