#include "tap.hpp"

#include <dds/dds.h>

#include <chrono>
#include <cstring>
#include <fstream>
#include <functional>
#include <istream>
#include <map>
#include <ostream>
#include <stdexcept>
#include <thread>

#include <nlohmann/json.hpp>

#include "thermovis/common.h"
#include "thermovis/frames.h"
#include "thermovis/health.h"
#include "thermovis/json/fields.hpp"
#include "thermovis/perception.h"

namespace thermovis::tap {

namespace {

using nlohmann::json;
namespace tj = thermovis::json;

json to_json(const thermovis_Box2D& box) {
  return {{"x", box.x}, {"y", box.y}, {"width", box.width}, {"height", box.height}};
}

json to_json(const thermovis_PipelineStamps& stamps) {
  json out = json::array();
  for (const auto& s : stamps.stamps) {
    if (s.stage == thermovis_STAGE_NONE) break;  // first unused entry ends the list
    out.push_back({{"stage", s.stage}, {"duration_us", s.duration_us}, {"end_ns", s.end_ns}});
  }
  return out;
}

json range_array(const void* sample) {
  const auto& r = *static_cast<const thermovis_RangeArray*>(sample);
  json targets = json::array();
  for (std::uint32_t i = 0; i < r.targets._length; ++i) {
    const auto& t = r.targets._buffer[i];
    targets.push_back({{"target_id", t.target_id},
                       {"label", t.label},
                       {"distance_m", t.distance_m},
                       {"sigma_m", t.sigma_m},
                       {"x_m", t.x_m},
                       {"y_m", t.y_m},
                       {"z_m", t.z_m},
                       {"box", to_json(t.box)},
                       {"point_count", t.point_count},
                       {"band", t.band}});
  }
  return {{"frame_seq", r.frame_seq},
          {"capture_time_ns", r.capture_time_ns},
          {"targets", targets},
          {"stamps", to_json(r.stamps)}};
}

json detection_array(const void* sample) {
  const auto& d = *static_cast<const thermovis_DetectionArray*>(sample);
  json detections = json::array();
  for (std::uint32_t i = 0; i < d.detections._length; ++i) {
    const auto& t = d.detections._buffer[i];
    detections.push_back({{"target_id", t.target_id},
                          {"label", t.label},
                          {"score", t.score},
                          {"box", to_json(t.box)}});
  }
  return {{"frame_seq", d.frame_seq},
          {"capture_time_ns", d.capture_time_ns},
          {"detections", detections},
          {"stamps", to_json(d.stamps)}};
}

json match_array(const void* sample) {
  const auto& m = *static_cast<const thermovis_MatchArray*>(sample);
  json targets = json::array();
  for (std::uint32_t i = 0; i < m.targets._length; ++i) {
    const auto& t = m.targets._buffer[i];
    json points = json::array();
    for (std::uint32_t k = 0; k < t.points._length; ++k) {
      const auto& p = t.points._buffer[k];
      points.push_back({p.left_x, p.left_y, p.right_x, p.right_y});
    }
    targets.push_back({{"target_id", t.target_id},
                       {"label", t.label},
                       {"box", to_json(t.box)},
                       {"points", points}});
  }
  return {{"frame_seq", m.frame_seq},
          {"capture_time_ns", m.capture_time_ns},
          {"targets", targets},
          {"stamps", to_json(m.stamps)}};
}

json frame_timing(const void* sample) {
  const auto& t = *static_cast<const thermovis_FrameTiming*>(sample);
  return {{"frame_seq", t.frame_seq},
          {"capture_time_ns", t.capture_time_ns},
          {"output_time_ns", t.output_time_ns},
          {"stamps", to_json(t.stamps)}};
}

// FNV-1a over `bytes`: the sample's pixels in one number, to compare with the writer's.
std::uint64_t fnv1a(const std::uint8_t* bytes, std::uint32_t length) {
  std::uint64_t h = 1469598103934665603ull;
  for (std::uint32_t i = 0; i < length; ++i) h = (h ^ bytes[i]) * 1099511628211ull;
  return h;
}

// A frame topic's packed twin: the header, and each eye's byte count and hash (not the pixels).
json packed_frame(const void* sample) {
  const auto& f = *static_cast<const thermovis_PackedStereoFrame*>(sample);
  return {{"seq", f.seq},
          {"capture_time_ns", f.capture_time_ns},
          {"pixel_format", f.pixel_format},
          {"width", f.width},
          {"height", f.height},
          {"step", f.step},
          {"eyes", f.eyes},
          {"geometry_id", f.geometry_id},
          {"left_bytes", f.left._length},
          {"right_bytes", f.right._length},
          {"left_fnv1a", fnv1a(f.left._buffer, f.left._length)},
          {"right_fnv1a", fnv1a(f.right._buffer, f.right._length)},
          {"stamps", to_json(f.stamps)}};
}

json health(const void* sample) {
  const auto& h = *static_cast<const thermovis_Health*>(sample);
  static const char* states[] = {"starting", "ok", "degraded", "failed", "stopping"};
  json topics = json::array();
  for (std::uint32_t i = 0; i < h.topics._length; ++i) {
    const auto& t = h.topics._buffer[i];
    topics.push_back({{"topic", t.topic},
                      {"samples", t.samples},
                      {"requested_deadline_missed", t.requested_deadline_missed},
                      {"offered_deadline_missed", t.offered_deadline_missed}});
  }
  return {{"service", h.service},
          {"state", h.state <= thermovis_HEALTH_STOPPING ? states[h.state] : "unknown"},
          {"time_ns", h.time_ns},
          {"frames_processed", h.frames_processed},
          {"errors", h.errors},
          {"message", h.message},
          {"topics", topics}};
}

struct TypeInfo {
  const dds_topic_descriptor_t* descriptor;
  std::function<json(const void*)> to_json;
  bool state = false;   // health-like: TRANSIENT_LOCAL, so a late tap sees the last states
  bool frames = false;  // images: the last two kept, not 64
};

const std::map<std::string, TypeInfo>& types() {
  static const std::map<std::string, TypeInfo> table = {
      {"thermovis::RangeArray", {&thermovis_RangeArray_desc, range_array}},
      {"thermovis::DetectionArray", {&thermovis_DetectionArray_desc, detection_array}},
      {"thermovis::MatchArray", {&thermovis_MatchArray_desc, match_array}},
      {"thermovis::FrameTiming", {&thermovis_FrameTiming_desc, frame_timing}},
      {"thermovis::Health", {&thermovis_Health_desc, health, true}},
      {"thermovis::PackedStereoFrame",
       {&thermovis_PackedStereoFrame_desc, packed_frame, false, true}},
  };
  return table;
}

// The pipeline's topics (common/transport topics.hpp) that carry small, tappable types, and the
// frame topics' packed twins (their plain types are for data-sharing among Fast DDS processes).
const std::map<std::string, std::string>& topic_types() {
  static const std::map<std::string, std::string> table = {
      {"thermovis/ranges", "thermovis::RangeArray"},
      {"thermovis/detections", "thermovis::DetectionArray"},
      {"thermovis/matches", "thermovis::MatchArray"},
      {"thermovis/timing", "thermovis::FrameTiming"},
      {"thermovis/health", "thermovis::Health"},
      {"thermovis/frames/visible/packed", "thermovis::PackedStereoFrame"},
      {"thermovis/frames/infrared/packed", "thermovis::PackedStereoFrame"},
      {"thermovis/rectified/visible/packed", "thermovis::PackedStereoFrame"},
      {"thermovis/rectified/infrared/packed", "thermovis::PackedStereoFrame"},
      {"thermovis/fused/packed", "thermovis::PackedStereoFrame"},
      {"thermovis/display/packed", "thermovis::PackedStereoFrame"},
  };
  return table;
}

std::string join(const std::vector<std::string>& names) {
  std::string out;
  for (const auto& n : names) out += (out.empty() ? "" : ", ") + n;
  return out;
}

// Owns a DDS entity (deleting a participant deletes everything in it).
struct Entity {
  dds_entity_t handle;
  explicit Entity(dds_entity_t h, const char* what) : handle(h) {
    if (h < 0) throw std::runtime_error(std::string(what) + ": " + dds_strretcode(h));
  }
  ~Entity() { dds_delete(handle); }
  Entity(const Entity&) = delete;
  Entity& operator=(const Entity&) = delete;
};

// JSON (the format run_tap prints) -> C samples for --publish. Each throws
// thermovis::json::JsonInputError naming the entry (`where`) and the field at fault.
thermovis_Box2D box_from_json(const json& j, const std::string& where) {
  tj::require_object(j, where);
  return {tj::field<float>(j, "x", where), tj::field<float>(j, "y", where),
          tj::field<float>(j, "width", where), tj::field<float>(j, "height", where)};
}

void stamps_from_json(const json& j, thermovis_PipelineStamps& out, const std::string& where) {
  std::memset(&out, 0, sizeof out);  // every entry STAGE_NONE
  if (j.is_null()) return;
  if (!j.is_array() || j.size() > thermovis_MAX_STAGE_STAMPS) {
    throw tj::JsonInputError(where + ": field 'stamps' must be an array of at most " +
                             std::to_string(thermovis_MAX_STAGE_STAMPS) + " entries");
  }
  for (std::size_t i = 0; i < j.size(); ++i) {
    const std::string at = where + " stamps " + std::to_string(i);
    out.stamps[i].stage = tj::field<std::uint32_t>(j[i], "stage", at);
    out.stamps[i].duration_us = tj::field<std::uint32_t>(j[i], "duration_us", at);
    out.stamps[i].end_ns = tj::field<std::int64_t>(j[i], "end_ns", at);
  }
}

// A DetectionArray whose detections live in `storage` (the sample does not own them). `where`
// names the input line, e.g. "detections.jsonl line 3".
thermovis_DetectionArray detection_array_from_json(const json& j,
                                                   std::vector<thermovis_Detection>& storage,
                                                   const std::string& where) {
  thermovis_DetectionArray out{};
  out.frame_seq = tj::field<std::uint64_t>(j, "frame_seq", where);
  out.capture_time_ns = tj::field<std::int64_t>(j, "capture_time_ns", where);
  if (!j.contains("detections")) throw tj::JsonInputError(where + ": field 'detections' missing");
  const json& detections = j.at("detections");
  if (!detections.is_array() || detections.size() > thermovis_MAX_TARGETS) {
    throw tj::JsonInputError(where + ": field 'detections' must be an array of at most " +
                             std::to_string(thermovis_MAX_TARGETS) + " entries");
  }
  storage.assign(detections.size(), thermovis_Detection{});
  for (std::size_t i = 0; i < detections.size(); ++i) {
    const json& d = detections[i];
    const std::string at = where + " detection " + std::to_string(i);
    thermovis_Detection& t = storage[i];
    t.target_id = tj::field<std::uint32_t>(d, "target_id", at);
    const std::string label = tj::field<std::string>(d, "label", at);
    if (label.size() > thermovis_MAX_LABEL_LENGTH) {
      throw tj::JsonInputError(at + ": field 'label' ('" + label + "') longer than " +
                               std::to_string(thermovis_MAX_LABEL_LENGTH) + " characters");
    }
    std::memcpy(t.label, label.c_str(), label.size() + 1);
    t.score = tj::field<float>(d, "score", at);
    if (!d.contains("box")) throw tj::JsonInputError(at + ": field 'box' missing");
    t.box = box_from_json(d.at("box"), at + " box");
  }
  out.detections._buffer = storage.data();
  out.detections._length = out.detections._maximum = static_cast<std::uint32_t>(storage.size());
  out.detections._release = false;
  stamps_from_json(j.contains("stamps") ? j["stamps"] : json(), out.stamps, where);
  return out;
}

}  // namespace

std::vector<std::string> publishable_topics() { return {"thermovis/detections"}; }

std::uint64_t run_publisher(const PublishOptions& options, const std::atomic<bool>& stop,
                            std::istream& in, std::ostream& log) {
  if (options.topic != "thermovis/detections") {
    throw std::runtime_error("cannot publish on '" + options.topic +
                             "' (publishable: " + join(publishable_topics()) + ")");
  }
  const Entity participant(dds_create_participant(options.domain, nullptr, nullptr),
                           "cannot create a DDS participant (check CYCLONEDDS_URI)");
  const Entity topic(dds_create_topic(participant.handle, &thermovis_DetectionArray_desc,
                                      options.topic.c_str(), nullptr, nullptr),
                     "cannot create topic");
  // The pipeline's event QoS: RELIABLE, VOLATILE; a deeper history so a burst is not replaced.
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
  dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, 64);
  const dds_entity_t writer = dds_create_writer(participant.handle, topic.handle, qos, nullptr);
  dds_delete_qos(qos);
  if (writer < 0)
    throw std::runtime_error(std::string("cannot create writer: ") + dds_strretcode(writer));

  const auto until =
      std::chrono::steady_clock::now() + std::chrono::duration<double>(options.wait_s);
  for (;;) {
    dds_publication_matched_status_t status{};
    dds_get_publication_matched_status(writer, &status);
    if (status.current_count >= options.wait_readers || stop) break;
    if (std::chrono::steady_clock::now() > until) {
      throw std::runtime_error("no reader of " + options.topic + " within " +
                               std::to_string(options.wait_s) + " s (" +
                               std::to_string(status.current_count) + " of " +
                               std::to_string(options.wait_readers) + " matched)");
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }

  std::uint64_t published = 0, line_number = 0;
  std::vector<thermovis_Detection> storage;
  for (std::string line; !stop && std::getline(in, line);) {
    ++line_number;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    thermovis_DetectionArray sample;
    const std::string where = options.source + " line " + std::to_string(line_number);
    try {
      json j;
      try {
        j = json::parse(line);
      } catch (const json::exception& e) {
        throw tj::JsonInputError(where + ": not JSON (" + e.what() + ")");
      }
      sample = detection_array_from_json(j, storage, where);
    } catch (const tj::JsonInputError& e) {
      log << "thermovis-tap: not a DetectionArray: " << e.what() << " (skipped)\n" << std::flush;
      continue;
    }
    const dds_return_t rc = dds_write(writer, &sample);
    if (rc != DDS_RETCODE_OK)
      throw std::runtime_error(std::string("write failed: ") + dds_strretcode(rc));
    ++published;
  }
  // Every reader has the samples before the participant goes.
  dds_wait_for_acks(writer, DDS_SECS(10));
  return published;
}

std::vector<std::string> known_topics() {
  std::vector<std::string> names;
  for (const auto& [name, type] : topic_types()) names.push_back(name);
  return names;
}

std::vector<std::string> known_types() {
  std::vector<std::string> names;
  for (const auto& [name, info] : types()) names.push_back(name);
  return names;
}

std::uint64_t run_tap(const TapOptions& options, const std::atomic<bool>& stop, std::ostream& out) {
  std::string type_name = options.type;
  if (type_name.empty()) {
    const auto it = topic_types().find(options.topic);
    if (it == topic_types().end()) {
      throw std::runtime_error("unknown topic '" + options.topic +
                               "' (known: " + join(known_topics()) + "; or give --type)");
    }
    type_name = it->second;
  }
  const auto type_it = types().find(type_name);
  if (type_it == types().end()) {
    throw std::runtime_error("unknown type '" + type_name + "' (known: " + join(known_types()) +
                             ")");
  }
  const TypeInfo& type = type_it->second;

  std::ofstream record;
  if (!options.record.empty()) {
    record.open(options.record);
    if (!record) throw std::runtime_error("cannot write record file " + options.record.string());
  }

  const Entity participant(dds_create_participant(options.domain, nullptr, nullptr),
                           "cannot create a DDS participant (check CYCLONEDDS_URI)");
  const Entity topic(dds_create_topic(participant.handle, type.descriptor, options.topic.c_str(),
                                      nullptr, nullptr),
                     "cannot create topic");
  // The QoS the pipeline's writers offer: RELIABLE; state topics also TRANSIENT_LOCAL.
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
  dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, type.frames ? 2 : 64);
  if (type.state) dds_qset_durability(qos, DDS_DURABILITY_TRANSIENT_LOCAL);
  const dds_entity_t reader_handle =
      dds_create_reader(participant.handle, topic.handle, qos, nullptr);
  dds_delete_qos(qos);
  if (reader_handle < 0) {
    throw std::runtime_error(std::string("cannot create reader: ") + dds_strretcode(reader_handle));
  }
  const Entity waitset(dds_create_waitset(participant.handle), "cannot create waitset");
  const dds_entity_t readable = dds_create_readcondition(reader_handle, DDS_ANY_STATE);
  dds_waitset_attach(waitset.handle, readable, 0);

  constexpr std::size_t kBatch = 16;
  std::uint64_t printed = 0;
  while (!stop && (options.count == 0 || printed < options.count)) {
    // Wake up regularly to notice a stop request.
    const dds_return_t woken = dds_waitset_wait(waitset.handle, nullptr, 0, DDS_MSECS(100));
    if (woken < 0) throw std::runtime_error(std::string("wait failed: ") + dds_strretcode(woken));
    void* samples[kBatch] = {};
    dds_sample_info_t infos[kBatch];
    const dds_return_t n = dds_take(reader_handle, samples, infos, kBatch, kBatch);
    if (n < 0) throw std::runtime_error(std::string("take failed: ") + dds_strretcode(n));
    for (dds_return_t i = 0; i < n; ++i) {
      if (!infos[i].valid_data) continue;
      if (options.count != 0 && printed >= options.count) break;
      const std::string line = type.to_json(samples[i]).dump();
      out << line << "\n" << std::flush;
      if (record.is_open()) record << line << "\n" << std::flush;
      ++printed;
    }
    if (n > 0) dds_return_loan(reader_handle, samples, n);
  }
  return printed;
}

}  // namespace thermovis::tap
