// The fast pipeline mode on VIFB's 21 pairs under VIFB's protocol (quality-75 JPEG, per RGB
// channel): at least as good as VSM-WLS (VIFB's published averages) on Qabf and MI.
#include <gtest/gtest.h>

#include <filesystem>
#include <iostream>
#include <opencv2/imgcodecs.hpp>

#include "thermovis/fuse/fusion.hpp"
#include "thermovis/metrics/vifb_metrics.hpp"
#include "thermovis/metrics/vifb_tables.hpp"
#include "thermovis/test/data.hpp"

namespace {

namespace vm = thermovis::metrics;
namespace fu = thermovis::fuse;

TEST(FastFusion, AtLeastAsGoodAsVsmwlsOnQabfAndMiOverVifb) {
  THERMOVIS_REQUIRE_DATA(dir, "fusion/vifb");
  const auto vsmwls = vm::load_vifb_averages(dir / "vifb_metrics_average.csv").at("VSMWLS");
  double qabf = 0, mi = 0;
  int pairs = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir / "VI")) {
    const std::string name = e.path().stem().string();
    const cv::Mat vis = cv::imread(e.path().string(), cv::IMREAD_UNCHANGED);
    const cv::Mat ir = cv::imread((dir / "IR" / (name + ".jpg")).string(), cv::IMREAD_UNCHANGED);
    ASSERT_FALSE(vis.empty() || ir.empty()) << name;
    fu::FusionOptions o;
    o.method = fu::FusionMethod::fast;
    const cv::Mat scored = vm::jpeg_round_trip(fu::fuse(ir, vis, o));
    qabf += vm::vifb_metric(vm::Metric::Qabf, vis, ir, scored);
    mi += vm::vifb_metric(vm::Metric::MI, vis, ir, scored);
    ++pairs;
  }
  ASSERT_EQ(pairs, 21);
  qabf /= pairs;
  mi /= pairs;
  std::cout << "fast: Qabf " << qabf << " (VSMWLS " << vsmwls[vm::Metric::Qabf] << "), MI " << mi
            << " (VSMWLS " << vsmwls[vm::Metric::MI] << ")\n";
  EXPECT_GE(qabf, vsmwls[vm::Metric::Qabf]);
  EXPECT_GE(mi, vsmwls[vm::Metric::MI]);
}

}  // namespace
