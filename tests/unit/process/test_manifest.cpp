// The pipeline manifest: start order, substitution and clear errors for broken files.
#include <gtest/gtest.h>

#include "thermovis/process/manifest_io.hpp"
#include "thermovis/runtime/yaml_util.hpp"
#include "thermovis/test/data.hpp"

namespace tp = thermovis::process;

namespace {

std::string error_of(const std::string& text) {
  try {
    tp::parse_manifest(text, "m.yaml");
  } catch (const thermovis::runtime::ConfigError& e) {
    return e.what();
  }
  return "accepted";
}

TEST(Manifest, StartOrderPutsDependenciesFirst) {
  const auto m = tp::parse_manifest(R"(
name: test
services:
  - {name: range, command: [a], depends_on: [match]}
  - {name: match, command: [b], depends_on: [bridge]}
  - {name: bridge, command: [c], restart: always}
)",
                                    "m.yaml");
  EXPECT_EQ(tp::start_order(m), (std::vector<std::string>{"bridge", "match", "range"}));
  EXPECT_EQ(m.services[2].restart, tp::RestartPolicy::always);
  EXPECT_EQ(m.services[0].restart, tp::RestartPolicy::on_failure);
}

TEST(Manifest, ReadsABestEffortServicesScheduling) {
  const auto m = tp::parse_manifest(
      "services:\n  - {name: view, command: [a], nice: 10}\n  - {name: page, command: [b], "
      "idle: true}\n",
      "m.yaml");
  EXPECT_EQ(m.services[0].nice, 10);
  EXPECT_FALSE(m.services[0].idle);
  EXPECT_TRUE(m.services[1].idle);
  EXPECT_NE(error_of("services:\n  - {name: a, command: [x], nice: 30}\n").find("a.nice: 30"),
            std::string::npos);
}

TEST(Manifest, ReadsAFramePathStagesRealtimePriority) {
  const auto m = tp::parse_manifest(
      "services:\n  - {name: match, command: [a], realtime: 10}\n  - {name: b, command: [b]}\n",
      "m.yaml");
  EXPECT_EQ(m.services[0].realtime, 10);
  EXPECT_EQ(m.services[1].realtime, 0);
  EXPECT_NE(error_of("services:\n  - {name: a, command: [x], realtime: 100}\n")
                .find("a.realtime: 100 is not in [0, 99]"),
            std::string::npos);
  EXPECT_NE(error_of("services:\n  - {name: a, command: [x], realtime: -1}\n").find("m.yaml:2"),
            std::string::npos);
  EXPECT_NE(error_of("services:\n  - {name: a, command: [x], realtime: 5, idle: true}\n")
                .find("realtime excludes idle"),
            std::string::npos);
}

TEST(Manifest, SubstitutesKnownVariablesOnly) {
  EXPECT_EQ(tp::substitute("${bin}/x --d ${domain} ${other}", {{"bin", "/b"}, {"domain", "7"}}),
            "/b/x --d 7 ${other}");
}

TEST(Manifest, BrokenFilesNameTheProblem) {
  EXPECT_NE(error_of("services:\n  - {name: a, comand: [x]}\n").find("unknown key 'comand'"),
            std::string::npos);
  EXPECT_NE(
      error_of("services:\n  - {name: a, command: [x], restart: sometimes}\n").find("sometimes"),
      std::string::npos);
  EXPECT_NE(error_of("services:\n  - {name: a, command: [x], depends_on: [b]}\n")
                .find("unknown service 'b'"),
            std::string::npos);
  EXPECT_NE(error_of("services:\n  - {name: a, command: [x], depends_on: [b]}\n  - {name: b, "
                     "command: [y], depends_on: [a]}\n")
                .find("cycle"),
            std::string::npos);
  EXPECT_NE(error_of("services:\n  - {name: a, command: []}\n").find("m.yaml:2"),
            std::string::npos);
  EXPECT_NE(error_of("services: [").find("m.yaml"), std::string::npos);
  EXPECT_THROW(tp::load_manifest("/nonexistent/pipeline.yaml"), thermovis::runtime::ConfigError);
}

}  // namespace
