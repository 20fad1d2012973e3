#include "web_server.hpp"

#include <httplib.h>

#include <nlohmann/json.hpp>
#include <stdexcept>

namespace thermovis::view {
namespace {

constexpr const char* kBoundary = "thermovisframe";

// The view a request names (?view=), fused without one; nothing for an unknown name.
std::optional<display::View> requested_view(const httplib::Request& request) {
  if (!request.has_param("view")) return display::View::fused;
  return display::parse_view(request.get_param_value("view"));
}

void unknown_view(const httplib::Request& request, httplib::Response& response) {
  response.status = 400;
  response.set_content("unknown view '" + request.get_param_value("view") +
                           "': expected fused, visible, infrared or side\n",
                       "text/plain");
}

void json(httplib::Response& response, const std::string& body) {
  response.set_header("Cache-Control", "no-store");
  response.set_content(body, "application/json");
}

}  // namespace

WebServer::WebServer(ViewHub& hub, const std::string& host, int port)
    : hub_(hub), server_(std::make_unique<httplib::Server>()) {
  // Each stream client holds one thread for as long as it watches; the JSON polls need a few.
  server_->new_task_queue = [] { return new httplib::ThreadPool(16); };
  // No Nagle delay: the end of a part (and its closing boundary, which lets the browser show
  // it) would otherwise wait for the client's delayed ACK, up to 40 ms.
  server_->set_tcp_nodelay(true);
  // A small send buffer (inherited by accepted sockets): a client that reads slower than frames
  // come has at most about one frame queued in the kernel, so it always gets a recent frame
  // (the stream waits for the write, then sends the newest) instead of a growing backlog.
  server_->set_socket_options([](socket_t sock) {
    int yes = 1;
    ::setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
    int bytes = 128 * 1024;
    ::setsockopt(sock, SOL_SOCKET, SO_SNDBUF, &bytes, sizeof bytes);
  });

  server_->Get("/", [](const httplib::Request&, httplib::Response& response) {
    response.set_content(kPageHtml, "text/html; charset=utf-8");
  });

  server_->Get("/stream.mjpg", [this](const httplib::Request& request,
                                      httplib::Response& response) {
    const auto view = requested_view(request);
    if (!view) return unknown_view(request, response);
    hub_.want(*view);
    response.set_header("Cache-Control", "no-store");
    response.set_content_provider(
        std::string("multipart/x-mixed-replace; boundary=") + kBoundary,
        [this, view = *view, last = std::uint64_t{0}](std::size_t offset,
                                                      httplib::DataSink& sink) mutable {
          // Called again as long as it returns true: waits (here, on an HTTP thread) for a newer
          // frame than the last one sent, then sends only the newest. Each part is followed at
          // once by the next boundary: a browser shows a part only when it sees the boundary
          // that ends it, which would otherwise come with the next frame, one frame late.
          const std::string boundary = std::string("--") + kBoundary + "\r\n";
          if (offset == 0 && !sink.write(boundary.data(), boundary.size())) return false;
          const auto frame = hub_.wait_frame(view, last, std::chrono::milliseconds(1000));
          if (hub_.stopped()) return false;
          if (!frame) return sink.is_writable();
          last = frame->number;
          const std::string head =
              "Content-Type: image/jpeg\r\nContent-Length: " + std::to_string(frame->jpeg.size()) +
              "\r\nX-Frame-Seq: " + std::to_string(frame->seq) + "\r\n\r\n";
          // One write per part: with TCP_NODELAY the whole part leaves at once.
          std::string part;
          part.reserve(head.size() + frame->jpeg.size() + boundary.size() + 2);
          part.append(head).append(frame->jpeg).append("\r\n").append(boundary);
          return sink.write(part.data(), part.size());
        });
  });

  server_->Get("/frame.jpg", [this](const httplib::Request& request, httplib::Response& response) {
    const auto view = requested_view(request);
    if (!view) return unknown_view(request, response);
    auto frame = hub_.latest(*view);
    // A view nobody watched is not encoded: ask for it and wait for the next one.
    if (!frame || !hub_.wanted(*view))
      frame = hub_.wait_frame(*view, frame ? frame->number : 0, std::chrono::milliseconds(3000));
    if (!frame) {
      response.status = 503;
      response.set_content("no frame yet\n", "text/plain");
      return;
    }
    response.set_header("Cache-Control", "no-store");
    response.set_header("X-Frame-Seq", std::to_string(frame->seq));
    response.set_content(frame->jpeg, "image/jpeg");
  });

  server_->Get("/targets.json", [this](const httplib::Request&, httplib::Response& response) {
    json(response, hub_.targets_json());
  });
  server_->Get("/status.json", [this](const httplib::Request&, httplib::Response& response) {
    json(response, hub_.status_json());
  });
  server_->Get("/display-latency.json",
               [this](const httplib::Request&, httplib::Response& response) {
                 json(response, hub_.display_latency_json());
               });
  server_->Post(
      "/display-latency", [this](const httplib::Request& request, httplib::Response& response) {
        std::vector<DisplaySample> samples;
        try {
          const auto body = nlohmann::json::parse(request.body);
          for (const auto& s : body.at("samples")) {
            samples.push_back(
                {s.at(0).get<std::int64_t>() * 100'000, s.at(1).get<std::int64_t>() * 1000});
          }
        } catch (const std::exception& e) {
          response.status = 400;
          response.set_content(
              std::string("expected {\"samples\": [[capture_100us, shown_us], ...]}: ") + e.what() +
                  "\n",
              "text/plain");
          return;
        }
        hub_.add_display_samples(samples);
        response.status = 204;
      });

  port_ =
      port == 0 ? server_->bind_to_any_port(host) : (server_->bind_to_port(host, port) ? port : -1);
  if (port_ <= 0) {
    throw std::runtime_error("cannot listen on " + host + ":" + std::to_string(port) +
                             " (address in use or not local?)");
  }
}

WebServer::~WebServer() { stop(); }

void WebServer::start() {
  thread_ = std::thread([this] { server_->listen_after_bind(); });
}

void WebServer::stop() {
  hub_.stop();
  server_->stop();
  if (thread_.joinable()) thread_.join();
}

}  // namespace thermovis::view
