#include "thermovis/record/foxglove.hpp"

#include <charconv>
#include <opencv2/imgcodecs.hpp>
#include <stdexcept>

namespace thermovis::record {

namespace {

// ---- the JSON schemas, from pieces that several types share

const std::string kTime =
    R"({"type":"object","title":"time","properties":{"sec":{"type":"integer","minimum":0},)"
    R"("nsec":{"type":"integer","minimum":0,"maximum":999999999}}})";

std::string number_object(const std::string& title, const std::string& keys) {
  std::string properties;
  for (const char key : keys)
    properties +=
        std::string(properties.empty() ? "" : ",") + "\"" + key + "\":{\"type\":\"number\"}";
  return R"({"title":")" + title + R"(","type":"object","properties":{)" + properties + "}}";
}

std::string object_schema(const std::string& title, const std::string& properties) {
  return R"({"title":")" + title + R"(","type":"object","properties":{)" + properties + "}}";
}

std::string array_of(const std::string& items) {
  return R"({"type":"array","items":)" + items + "}";
}

const std::string kVector3 = number_object("foxglove.Vector3", "xyz");
const std::string kQuaternion = number_object("foxglove.Quaternion", "xyzw");
const std::string kColor = number_object("foxglove.Color", "rgba");
const std::string kPose =
    object_schema("foxglove.Pose", "\"position\":" + kVector3 + ",\"orientation\":" + kQuaternion);

// ---- JSON text

void append_string(std::string& out, const std::string& s) {
  out += '"';
  for (const char c : s) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      static const char* hex = "0123456789abcdef";
      out += "\\u00";
      out += hex[(c >> 4) & 0xf];
      out += hex[c & 0xf];
    } else {
      out += c;
    }
  }
  out += '"';
}

void append_number(std::string& out, double v) {
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, v);
  out.append(buffer, result.ptr);
}

void append_time(std::string& out, std::int64_t time_ns) {
  const std::int64_t clamped = time_ns < 0 ? 0 : time_ns;  // Foxglove's time is unsigned
  out += "{\"sec\":" + std::to_string(clamped / 1'000'000'000) +
         ",\"nsec\":" + std::to_string(clamped % 1'000'000'000) + "}";
}

template <std::size_t N>
void append_numbers(std::string& out, const char* keys, const std::array<double, N>& values) {
  out += '{';
  for (std::size_t i = 0; i < N; ++i) {
    out += std::string(i == 0 ? "" : ",") + "\"" + keys[i] + "\":";
    append_number(out, values[i]);
  }
  out += '}';
}

}  // namespace

const FoxgloveSchema& compressed_image_schema() {
  static const FoxgloveSchema schema{
      "foxglove.CompressedImage",
      object_schema("foxglove.CompressedImage",
                    "\"timestamp\":" + kTime +
                        R"(,"frame_id":{"type":"string"},)"
                        R"("data":{"type":"string","contentEncoding":"base64"},)"
                        R"("format":{"type":"string"})")};
  return schema;
}

const FoxgloveSchema& scene_update_schema() {
  const std::string deletion = object_schema(
      "foxglove.SceneEntityDeletion",
      "\"timestamp\":" + kTime + R"(,"type":{"type":"integer"},"id":{"type":"string"})");
  const std::string cube =
      object_schema("foxglove.CubePrimitive",
                    "\"pose\":" + kPose + ",\"size\":" + kVector3 + ",\"color\":" + kColor);
  const std::string text =
      object_schema("foxglove.TextPrimitive",
                    "\"pose\":" + kPose +
                        R"(,"billboard":{"type":"boolean"},"font_size":{"type":"number"},)"
                        R"("scale_invariant":{"type":"boolean"},"color":)" +
                        kColor + R"(,"text":{"type":"string"})");
  const std::string entity = object_schema(
      "foxglove.SceneEntity", "\"timestamp\":" + kTime +
                                  R"(,"frame_id":{"type":"string"},"id":{"type":"string"},)"
                                  R"("frame_locked":{"type":"boolean"},"cubes":)" +
                                  array_of(cube) + ",\"texts\":" + array_of(text));
  static const FoxgloveSchema schema{
      "foxglove.SceneUpdate",
      object_schema("foxglove.SceneUpdate",
                    "\"deletions\":" + array_of(deletion) + ",\"entities\":" + array_of(entity))};
  return schema;
}

const FoxgloveSchema& frame_transforms_schema() {
  const std::string transform = object_schema(
      "foxglove.FrameTransform",
      "\"timestamp\":" + kTime +
          R"(,"parent_frame_id":{"type":"string"},"child_frame_id":{"type":"string"},)"
          R"("translation":)" +
          kVector3 + ",\"rotation\":" + kQuaternion);
  static const FoxgloveSchema schema{
      "foxglove.FrameTransforms",
      object_schema("foxglove.FrameTransforms", "\"transforms\":" + array_of(transform))};
  return schema;
}

EncodedImage encode_image(const cv::Mat& image, int jpeg_quality) {
  if (image.empty()) throw std::invalid_argument("encode_image: empty image");
  if (jpeg_quality < 1 || jpeg_quality > 100)
    throw std::invalid_argument("encode_image: JPEG quality " + std::to_string(jpeg_quality) +
                                " is not in 1..100");
  EncodedImage out;
  if (image.type() == CV_8UC1 || image.type() == CV_8UC3) {
    out.format = "jpeg";
    cv::imencode(".jpg", image, out.data, {cv::IMWRITE_JPEG_QUALITY, jpeg_quality});
  } else if (image.type() == CV_16UC1) {
    out.format = "png";
    // Level 1: the fastest; 16-bit counts compress little more at higher levels.
    cv::imencode(".png", image, out.data, {cv::IMWRITE_PNG_COMPRESSION, 1});
  } else {
    throw std::invalid_argument("encode_image: no format for an image of OpenCV type " +
                                std::to_string(image.type()) + " (CV_8UC1, CV_8UC3 or CV_16UC1)");
  }
  return out;
}

std::string base64(const std::uint8_t* data, std::size_t size) {
  static const char* alphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((size + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 2 < size; i += 3) {
    const std::uint32_t v = (std::uint32_t{data[i]} << 16) | (std::uint32_t{data[i + 1]} << 8) |
                            std::uint32_t{data[i + 2]};
    out += alphabet[(v >> 18) & 63];
    out += alphabet[(v >> 12) & 63];
    out += alphabet[(v >> 6) & 63];
    out += alphabet[v & 63];
  }
  if (i < size) {
    const bool two = i + 1 < size;
    const std::uint32_t v =
        (std::uint32_t{data[i]} << 16) | (two ? std::uint32_t{data[i + 1]} << 8 : 0);
    out += alphabet[(v >> 18) & 63];
    out += alphabet[(v >> 12) & 63];
    out += two ? alphabet[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

std::string compressed_image_json(std::int64_t time_ns, const std::string& frame_id,
                                  const EncodedImage& image) {
  std::string out = "{\"timestamp\":";
  append_time(out, time_ns);
  out += ",\"frame_id\":";
  append_string(out, frame_id);
  out += ",\"format\":";
  append_string(out, image.format);
  out += ",\"data\":\"" + base64(image.data.data(), image.data.size()) + "\"}";
  return out;
}

std::string scene_update_json(std::int64_t time_ns, const std::string& frame_id,
                              const std::vector<SceneBox>& boxes) {
  static const std::array<double, 4> kIdentity{0.0, 0.0, 0.0, 1.0};
  static const std::array<double, 4> kWhite{1.0, 1.0, 1.0, 1.0};
  std::string out = "{\"deletions\":[{\"timestamp\":";
  append_time(out, time_ns);
  out += ",\"type\":1,\"id\":\"\"}],\"entities\":[";  // type 1: ALL
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    const SceneBox& b = boxes[i];
    const auto pose = [&](std::array<double, 3> position) {
      out += "\"pose\":{\"position\":";
      append_numbers(out, "xyz", position);
      out += ",\"orientation\":";
      append_numbers(out, "xyzw", kIdentity);
      out += '}';
    };
    out += i == 0 ? "{" : ",{";
    out += "\"timestamp\":";
    append_time(out, time_ns);
    out += ",\"frame_id\":";
    append_string(out, frame_id);
    out += ",\"id\":";
    append_string(out, b.id);
    out += ",\"frame_locked\":false,\"cubes\":[{";
    pose(b.centre_m);
    out += ",\"size\":";
    append_numbers(out, "xyz", b.size_m);
    out += ",\"color\":";
    append_numbers(out, "rgba", b.rgba);
    // The label above the box: -y is up in the camera frame.
    out += "}],\"texts\":[{";
    pose({b.centre_m[0], b.centre_m[1] - b.size_m[1] / 2 - 0.2, b.centre_m[2]});
    out += ",\"billboard\":true,\"font_size\":14,\"scale_invariant\":true,\"color\":";
    append_numbers(out, "rgba", kWhite);
    out += ",\"text\":";
    append_string(out, b.label);
    out += "}]}";
  }
  out += "]}";
  return out;
}

std::string frame_transforms_json(std::int64_t time_ns,
                                  const std::vector<FrameTransform>& transforms) {
  std::string out = "{\"transforms\":[";
  for (std::size_t i = 0; i < transforms.size(); ++i) {
    const FrameTransform& t = transforms[i];
    out += i == 0 ? "{" : ",{";
    out += "\"timestamp\":";
    append_time(out, time_ns);
    out += ",\"parent_frame_id\":";
    append_string(out, t.parent);
    out += ",\"child_frame_id\":";
    append_string(out, t.child);
    out += ",\"translation\":";
    append_numbers(out, "xyz", t.translation_m);
    out += ",\"rotation\":";
    append_numbers(out, "xyzw", t.rotation_xyzw);
    out += '}';
  }
  out += "]}";
  return out;
}

}  // namespace thermovis::record
