// Foxglove's message types as record/foxglove.hpp writes them: pictures that decode back to the
// image (exactly for 16-bit infrared), base64 by RFC 4648's test vectors, and JSON messages whose
// fields hold what was given.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <stdexcept>

#include "thermovis/record/foxglove.hpp"

namespace {

namespace rec = thermovis::record;

TEST(FoxgloveBase64, Rfc4648TestVectors) {
  const auto b64 = [](const std::string& s) {
    return rec::base64(reinterpret_cast<const std::uint8_t*>(s.data()), s.size());
  };
  EXPECT_EQ(b64(""), "");
  EXPECT_EQ(b64("f"), "Zg==");
  EXPECT_EQ(b64("fo"), "Zm8=");
  EXPECT_EQ(b64("foo"), "Zm9v");
  EXPECT_EQ(b64("foob"), "Zm9vYg==");
  EXPECT_EQ(b64("fooba"), "Zm9vYmE=");
  EXPECT_EQ(b64("foobar"), "Zm9vYmFy");
}

TEST(FoxgloveImage, RawInfraredIsALossless16BitPng) {
  cv::Mat counts(48, 64, CV_16UC1);
  cv::randu(counts, 0, 65536);
  const rec::EncodedImage png = rec::encode_image(counts, 80);
  EXPECT_EQ(png.format, "png");
  const cv::Mat back = cv::imdecode(png.data, cv::IMREAD_UNCHANGED);
  ASSERT_EQ(back.type(), CV_16UC1);
  EXPECT_EQ(cv::norm(back, counts, cv::NORM_INF), 0.0);
}

TEST(FoxgloveImage, EightBitImagesAreJpegAtTheGivenQuality) {
  cv::Mat colour(48, 64, CV_8UC3);
  for (int y = 0; y < colour.rows; ++y)
    for (int x = 0; x < colour.cols; ++x)
      colour.at<cv::Vec3b>(y, x) = {static_cast<std::uint8_t>(4 * x),
                                    static_cast<std::uint8_t>(5 * y), 90};
  const rec::EncodedImage high = rec::encode_image(colour, 95);
  const rec::EncodedImage low = rec::encode_image(colour, 10);
  EXPECT_EQ(high.format, "jpeg");
  EXPECT_LT(low.data.size(), high.data.size());
  const cv::Mat back = cv::imdecode(high.data, cv::IMREAD_COLOR);
  ASSERT_EQ(back.size(), colour.size());
  EXPECT_LT(cv::norm(back, colour, cv::NORM_L1) / static_cast<double>(colour.total() * 3), 3.0);
  EXPECT_EQ(rec::encode_image(cv::Mat(8, 8, CV_8UC1, cv::Scalar(7)), 80).format, "jpeg");
}

TEST(FoxgloveImage, OtherTypesAndQualitiesAreRefused) {
  EXPECT_THROW(rec::encode_image(cv::Mat(), 80), std::invalid_argument);
  EXPECT_THROW(rec::encode_image(cv::Mat(8, 8, CV_32FC1), 80), std::invalid_argument);
  EXPECT_THROW(rec::encode_image(cv::Mat(8, 8, CV_8UC1), 0), std::invalid_argument);
  EXPECT_THROW(rec::encode_image(cv::Mat(8, 8, CV_8UC1), 101), std::invalid_argument);
}

TEST(FoxgloveMessages, CompressedImageCarriesTimeFrameFormatAndBytes) {
  const rec::EncodedImage image{"png", {'f', 'o', 'o'}};
  const auto j = nlohmann::json::parse(
      rec::compressed_image_json(1'700'000'000'123'456'789, "infrared.left", image));
  EXPECT_EQ(j["timestamp"]["sec"], 1'700'000'000);
  EXPECT_EQ(j["timestamp"]["nsec"], 123'456'789);
  EXPECT_EQ(j["frame_id"], "infrared.left");
  EXPECT_EQ(j["format"], "png");
  EXPECT_EQ(j["data"], "Zm9v");
}

TEST(FoxgloveMessages, SceneUpdateReplacesEveryEntityByTheBoxes) {
  rec::SceneBox box;
  box.id = "target 3";
  box.label = "person \"A\" 12.5 m";
  box.centre_m = {1.5, -0.25, 12.0};
  box.size_m = {0.6, 1.75, 0.6};
  const auto j =
      nlohmann::json::parse(rec::scene_update_json(2'000'000'001, "visible.left", {box, box}));
  ASSERT_EQ(j["deletions"].size(), 1U);
  EXPECT_EQ(j["deletions"][0]["type"], 1);  // ALL
  ASSERT_EQ(j["entities"].size(), 2U);
  const auto& e = j["entities"][0];
  EXPECT_EQ(e["timestamp"]["sec"], 2);
  EXPECT_EQ(e["timestamp"]["nsec"], 1);
  EXPECT_EQ(e["frame_id"], "visible.left");
  EXPECT_EQ(e["id"], "target 3");
  const auto& cube = e["cubes"][0];
  EXPECT_DOUBLE_EQ(cube["pose"]["position"]["x"].get<double>(), 1.5);
  EXPECT_DOUBLE_EQ(cube["pose"]["position"]["y"].get<double>(), -0.25);
  EXPECT_DOUBLE_EQ(cube["pose"]["position"]["z"].get<double>(), 12.0);
  EXPECT_DOUBLE_EQ(cube["pose"]["orientation"]["w"].get<double>(), 1.0);
  EXPECT_DOUBLE_EQ(cube["size"]["y"].get<double>(), 1.75);
  EXPECT_EQ(e["texts"][0]["text"], "person \"A\" 12.5 m");
  // The label above the box (-y is up in the camera frame).
  EXPECT_LT(e["texts"][0]["pose"]["position"]["y"].get<double>(), -0.25 - 1.75 / 2);
}

TEST(FoxgloveMessages, FrameTransformsCarryEachPose) {
  rec::FrameTransform t{"rig", "infrared.left", {0.0, 0.06, 0.0}, {0.0, 0.0, 0.7071, 0.7071}};
  const auto j = nlohmann::json::parse(rec::frame_transforms_json(5, {t}));
  ASSERT_EQ(j["transforms"].size(), 1U);
  const auto& out = j["transforms"][0];
  EXPECT_EQ(out["parent_frame_id"], "rig");
  EXPECT_EQ(out["child_frame_id"], "infrared.left");
  EXPECT_DOUBLE_EQ(out["translation"]["y"].get<double>(), 0.06);
  EXPECT_DOUBLE_EQ(out["rotation"]["z"].get<double>(), 0.7071);
  EXPECT_EQ(out["timestamp"]["nsec"], 5);
}

TEST(FoxgloveSchemas, AreJsonSchemasNamedAsFoxgloveNamesThem) {
  for (const auto* schema : {&rec::compressed_image_schema(), &rec::scene_update_schema(),
                             &rec::frame_transforms_schema()}) {
    const auto j = nlohmann::json::parse(schema->json_schema);
    EXPECT_EQ(j["title"], schema->name);
    EXPECT_EQ(j["type"], "object");
  }
  EXPECT_EQ(rec::compressed_image_schema().name, "foxglove.CompressedImage");
  EXPECT_TRUE(
      nlohmann::json::parse(rec::compressed_image_schema().json_schema)["properties"].contains(
          "data"));
}

}  // namespace
