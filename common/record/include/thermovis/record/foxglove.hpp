#pragma once
// Foxglove's well-known message types, written as JSON (MCAP schema encoding "jsonschema",
// message encoding "json"): the channels Foxglove shows as pictures (foxglove.CompressedImage)
// and in its 3-D panel (foxglove.SceneUpdate, foxglove.FrameTransforms). The schemas are the
// subset of Foxglove's published JSON schemas that these messages fill; Foxglove picks its
// panels by the schema name.
//
// Times are int64 nanoseconds since the Unix epoch, written as Foxglove's {sec, nsec}. Lengths
// are metres. 3-D frames follow the cameras' convention (x right, y down, z forward, as
// TargetRange's x_m, y_m, z_m), which is also Foxglove's camera-frame convention.
#include <array>
#include <cstdint>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

namespace thermovis::record {

struct FoxgloveSchema {
  std::string name;         // e.g. "foxglove.CompressedImage"
  std::string json_schema;  // the MCAP schema data
};
const FoxgloveSchema& compressed_image_schema();
const FoxgloveSchema& scene_update_schema();
const FoxgloveSchema& frame_transforms_schema();

// An image in one of the formats foxglove.CompressedImage names.
struct EncodedImage {
  std::string format;  // "jpeg" or "png"
  std::vector<std::uint8_t> data;
};
// JPEG at `jpeg_quality` (1..100) for 8-bit images (CV_8UC1; CV_8UC3 in BGR order), and a
// lossless 16-bit PNG for raw infrared counts (CV_16UC1), whose 14 or 16 bits a JPEG would
// lose. Throws std::invalid_argument for an empty image, another type or a quality outside
// 1..100.
EncodedImage encode_image(const cv::Mat& image, int jpeg_quality);

// A foxglove.CompressedImage message; `frame_id` is the camera frame the image was taken in.
std::string compressed_image_json(std::int64_t time_ns, const std::string& frame_id,
                                  const EncodedImage& image);

// One target of a 3-D scene: a box centred on (x_m, y_m, z_m) in the scene's frame, of
// size_m along its axes, labelled with `label` (e.g. "person 12.4 m").
struct SceneBox {
  std::string id;  // stable across messages for the same target, so Foxglove replaces it
  std::string label;
  std::array<double, 3> centre_m{};
  std::array<double, 3> size_m{};
  std::array<double, 4> rgba{1.0, 0.5, 0.0, 0.5};  // 0..1
};
// A foxglove.SceneUpdate that replaces every entity of its channel by `boxes` (a deletion of
// all entities first, so targets of the frame before disappear), each a cube with a text.
std::string scene_update_json(std::int64_t time_ns, const std::string& frame_id,
                              const std::vector<SceneBox>& boxes);

// The pose of `child` in `parent`: p_parent = rotation * p_child + translation_m.
struct FrameTransform {
  std::string parent, child;
  std::array<double, 3> translation_m{};
  std::array<double, 4> rotation_xyzw{0.0, 0.0, 0.0, 1.0};  // unit quaternion
};
std::string frame_transforms_json(std::int64_t time_ns,
                                  const std::vector<FrameTransform>& transforms);

// RFC 4648 base64 (with padding), as JSON messages carry bytes.
std::string base64(const std::uint8_t* data, std::size_t size);

}  // namespace thermovis::record
