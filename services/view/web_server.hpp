#pragma once
// thermovis-view's web side (cpp-httplib): the page, the live MJPEG stream of each view, the
// targets and status as JSON, and the display-latency reports the page posts back.
//
//   GET  /                      the page (page.cpp; no external resources)
//   GET  /stream.mjpg?view=V    multipart/x-mixed-replace JPEG stream, V = fused (default),
//                               visible, infrared or side; each client gets the newest frame
//                               when it is ready for one (a slow client skips frames)
//   GET  /frame.jpg?view=V      the newest JPEG of V
//   GET  /targets.json          the targets of the frame shown
//   GET  /status.json           latency history, counters, every service's health
//   POST /display-latency       {"samples": [[capture_100us, shown_us], ...]} from the page
//   GET  /display-latency.json  what the pages measured: capture->shown, capture->range,
//                               range->shown (p50, p95, max)
#include <memory>
#include <string>
#include <thread>

#include "view_hub.hpp"

namespace httplib {
class Server;
}

namespace thermovis::view {

extern const char* const kPageHtml;  // page.cpp

class WebServer {
 public:
  // Binds host:port (port 0: any free port). Throws std::runtime_error naming the address when
  // it cannot be bound.
  WebServer(ViewHub& hub, const std::string& host, int port);
  ~WebServer();
  WebServer(const WebServer&) = delete;
  WebServer& operator=(const WebServer&) = delete;

  int port() const { return port_; }
  void start();  // serves on its own threads
  void stop();

 private:
  ViewHub& hub_;
  std::unique_ptr<httplib::Server> server_;
  int port_ = 0;
  std::thread thread_;
};

}  // namespace thermovis::view
