#pragma once
// What the viewer's tests share: a small HTTP client for the viewer (cpp-httplib), a WebDriver
// client for headless Chromium (chromedriver's HTTP API: the W3C WebDriver protocol), free
// local ports, and the viewer's command line on a private DDS domain.
#include <httplib.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <regex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "thermovis/test/child_process.hpp"
#include "thermovis/test/data.hpp"
#include "thermovis/transport/participant.hpp"

namespace thermovis::test {

// A TCP port on 127.0.0.1 that was free a moment ago (bound to port 0, then released).
inline int free_port() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  address.sin_port = 0;
  socklen_t length = sizeof address;
  if (fd < 0 || ::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0 ||
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length) != 0) {
    if (fd >= 0) ::close(fd);
    throw std::runtime_error("no free local port");
  }
  ::close(fd);
  return ntohs(address.sin_port);
}

// thermovis-view on `domain` (loopback profile) on a free port chosen by itself (--port 0).
inline std::vector<std::string> viewer_command(int domain,
                                               const std::vector<std::string>& extra = {}) {
  std::vector<std::string> argv{(bin_dir() / "thermovis-view").string(),
                                "--domain",
                                std::to_string(domain),
                                "--profile",
                                transport::kLoopbackProfile,
                                "--port",
                                "0"};
  argv.insert(argv.end(), extra.begin(), extra.end());
  return argv;
}

// The port a viewer started with --port 0 serves on (from the URL it prints), 0 until known.
inline int viewer_port(const ChildProcess& viewer) {
  static const std::regex url(R"(http://127\.0\.0\.1:(\d+)/)");
  std::smatch m;
  const std::string log = viewer.log();
  return std::regex_search(log, m, url) ? std::stoi(m[1]) : 0;
}

// GET a JSON document from the viewer; null on any failure.
inline nlohmann::json get_json(int port, const std::string& path) {
  httplib::Client client("127.0.0.1", port);
  client.set_read_timeout(5, 0);
  const auto response = client.Get(path.c_str());
  if (!response || response->status != 200) return nullptr;
  try {
    return nlohmann::json::parse(response->body);
  } catch (const std::exception&) {
    return nullptr;
  }
}

inline std::vector<unsigned char> base64_decode(const std::string& text) {
  static const std::string alphabet =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::vector<unsigned char> out;
  unsigned value = 0;
  int bits = 0;
  for (const char c : text) {
    const auto i = alphabet.find(c);
    if (i == std::string::npos) continue;  // padding, line breaks
    value = (value << 6) | static_cast<unsigned>(i);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out.push_back(static_cast<unsigned char>((value >> bits) & 0xff));
    }
  }
  return out;
}

// A headless Chromium driven through chromedriver (W3C WebDriver over HTTP). The session is
// deleted (the browser closed) on destruction, then chromedriver is killed.
class Browser {
 public:
  static bool available() {
    return std::filesystem::exists("/usr/bin/chromium") &&
           std::filesystem::exists("/usr/bin/chromedriver");
  }

  explicit Browser(const std::filesystem::path& dir)
      : port_(free_port()),
        driver_({"/usr/bin/chromedriver", "--port=" + std::to_string(port_)},
                dir / "chromedriver.log"),
        client_("127.0.0.1", port_) {
    client_.set_read_timeout(120, 0);
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    while (true) {
      const auto status = client_.Get("/status");
      if (status && status->status == 200) break;
      if (std::chrono::steady_clock::now() > until)
        throw std::runtime_error("chromedriver did not start:\n" + driver_.log());
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    const nlohmann::json capabilities = {
        {"capabilities",
         {{"alwaysMatch",
           {{"browserName", "chrome"},
            // The stream never finishes loading: navigation returns at DOMContentLoaded.
            {"pageLoadStrategy", "eager"},
            {"goog:chromeOptions",
             {{"binary", "/usr/bin/chromium"},
              {"args",
               {"--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                "--window-size=1400,1000", "--no-first-run",
                "--user-data-dir=" + (dir / "chromium-profile").string()}}}}}}}}};
    const auto session = call("POST", "/session", capabilities);
    session_ = session.at("sessionId").get<std::string>();
  }
  ~Browser() {
    if (!session_.empty()) client_.Delete(("/session/" + session_).c_str());
  }
  Browser(const Browser&) = delete;
  Browser& operator=(const Browser&) = delete;

  void open(const std::string& url) { call("POST", path("/url"), {{"url", url}}); }

  // Runs `script` (a function body) in the page and returns its value.
  nlohmann::json run(const std::string& script) {
    return call("POST", path("/execute/sync"),
                {{"script", script}, {"args", nlohmann::json::array()}});
  }

  // PNG bytes of one element (CSS selector) as shown on the page.
  std::vector<unsigned char> screenshot(const std::string& selector) {
    const auto element =
        call("POST", path("/element"), {{"using", "css selector"}, {"value", selector}});
    const std::string id = element.begin().value().get<std::string>();
    return base64_decode(call("GET", path("/element/" + id + "/screenshot")).get<std::string>());
  }

  std::string driver_log() const { return driver_.log(); }

 private:
  std::string path(const std::string& tail) const { return "/session/" + session_ + tail; }

  // One WebDriver command; its "value", or std::runtime_error with the driver's message.
  nlohmann::json call(const std::string& method, const std::string& where,
                      const nlohmann::json& body = nullptr) {
    const auto response =
        method == "GET"
            ? client_.Get(where.c_str())
            : client_.Post(where.c_str(), body.is_null() ? "{}" : body.dump(), "application/json");
    if (!response) throw std::runtime_error("chromedriver: no answer to " + method + " " + where);
    const auto reply = nlohmann::json::parse(response->body, nullptr, false);
    if (response->status != 200 || reply.is_discarded()) {
      throw std::runtime_error("chromedriver: " + method + " " + where + ": HTTP " +
                               std::to_string(response->status) + " " + response->body);
    }
    return reply.at("value");
  }

  int port_;
  ChildProcess driver_;
  httplib::Client client_;
  std::string session_;
};

}  // namespace thermovis::test
