// thermovis status: the pipeline's health as the services publish it (thermovis/health,
// RELIABLE + TRANSIENT_LOCAL: the last state of every service reaches a late subscriber).
#include <chrono>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <thread>

#include "command.hpp"
#include "thermovis/node/health.hpp"
#include "thermovis/node/service.hpp"
#include "thermovis/transport/clock.hpp"
#include "thermovis/transport/qos.hpp"
#include "thermovis/transport/reader.hpp"
#include "thermovis/transport/topics.hpp"

namespace {

struct Options {
  thermovis::node::CommonOptions common;
  double wait_s = 3.0;  // discovery of every service on a busy host
  bool json = false;
};

int run_status(const Options& opt) {
  auto participant = thermovis::node::make_participant(opt.common);
  thermovis::transport::Reader<thermovis::Health> reader(
      *participant, thermovis::transport::topics::kHealth, thermovis::transport::state_topic_qos());
  std::map<std::string, thermovis::Health> last;
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(opt.wait_s);
  while (std::chrono::steady_clock::now() < until) {
    reader.wait_for_data(std::chrono::milliseconds(100));
    auto samples = reader.take();
    for (std::size_t i = 0; i < samples.size(); ++i)
      last[samples[i].service().to_string()] = samples[i];
  }
  const std::int64_t now = thermovis::transport::now_ns();
  nlohmann::json services = nlohmann::json::array();
  for (const auto& [name, h] : last) {
    std::uint64_t requested = 0, offered = 0;
    for (const auto& t : h.topics()) {
      requested += t.requested_deadline_missed();
      offered += t.offered_deadline_missed();
    }
    services.push_back({{"service", name},
                        {"state", thermovis::node::health_state_name(h.state())},
                        {"age_s", static_cast<double>(now - h.time_ns()) / 1e9},
                        {"frames_processed", h.frames_processed()},
                        {"errors", h.errors()},
                        {"deadline_missed_requested", requested},
                        {"deadline_missed_offered", offered},
                        {"message", h.message().to_string()}});
  }
  if (opt.json) {
    std::cout << nlohmann::json{{"domain", opt.common.domain}, {"services", services}}.dump()
              << std::endl;
  } else if (services.empty()) {
    std::cout << "no service reported health on DDS domain " << opt.common.domain << " within "
              << opt.wait_s << " s\n";
  } else {
    std::cout << std::left << std::setw(24) << "service" << std::setw(10) << "state" << std::right
              << std::setw(8) << "age s" << std::setw(10) << "frames" << std::setw(8) << "errors"
              << std::setw(10) << "missed"
              << "  message\n";
    for (const auto& s : services) {
      std::cout << std::left << std::setw(24) << s["service"].get<std::string>() << std::setw(10)
                << s["state"].get<std::string>() << std::right << std::setw(8) << std::fixed
                << std::setprecision(1) << s["age_s"].get<double>() << std::setw(10)
                << s["frames_processed"].get<std::uint64_t>() << std::setw(8)
                << s["errors"].get<std::uint32_t>() << std::setw(10)
                << s["deadline_missed_requested"].get<std::uint64_t>() +
                       s["deadline_missed_offered"].get<std::uint64_t>()
                << "  " << s["message"].get<std::string>() << "\n";
    }
  }
  return services.empty() ? 3 : 0;
}

THERMOVIS_COMMAND("status", "health of the pipeline's services on a DDS domain, as a table",
                  [](CLI::App& app) -> thermovis::cli::Runner {
                    auto opt = std::make_shared<Options>();
                    opt->common.service = "thermovis-status";
                    thermovis::node::add_common_options(app, opt->common);
                    app.add_option("--wait", opt->wait_s, "listen this long, s")
                        ->capture_default_str()
                        ->check(CLI::PositiveNumber);
                    app.add_flag("--json", opt->json, "one JSON object");
                    return [opt] { return run_status(*opt); };
                  });

}  // namespace
