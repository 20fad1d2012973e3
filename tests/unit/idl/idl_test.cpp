// The generated message types and the transport's QoS and bounds, without any DDS traffic.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <tuple>

#include "thermovis/transport/bounds.hpp"
#include "thermovis/transport/participant.hpp"
#include "thermovis/transport/qos.hpp"
#include "thermovis/transport/stamps.hpp"
#include "thermovis/transport/topic_types.hpp"

namespace {

namespace tt = thermovis::transport;
namespace dds = eprosima::fastdds::dds;
using namespace std::chrono_literals;

template <class Array>
constexpr std::size_t extent() {
  return std::tuple_size_v<std::remove_cvref_t<Array>>;
}

// The IDL writes array bounds as literals (a fastddsgen 2.3 limitation); they must equal the
// named constants the code uses.
TEST(IdlTypes, ArrayBoundsEqualTheirConstants) {
  using thermovis::GridStereoFrame;
  using thermovis::InfraredStereoFrame;
  using thermovis::VisibleStereoFrame;
  EXPECT_EQ(extent<decltype(std::declval<VisibleStereoFrame>().left())>(),
            thermovis::VISIBLE_IMAGE_BYTES);
  EXPECT_EQ(extent<decltype(std::declval<VisibleStereoFrame>().right())>(),
            thermovis::VISIBLE_IMAGE_BYTES);
  EXPECT_EQ(thermovis::VISIBLE_IMAGE_BYTES,
            thermovis::VISIBLE_WIDTH * thermovis::VISIBLE_HEIGHT * 3);
  EXPECT_EQ(extent<decltype(std::declval<InfraredStereoFrame>().left())>(),
            thermovis::INFRARED_IMAGE_PIXELS);
  EXPECT_EQ(extent<decltype(std::declval<InfraredStereoFrame>().right())>(),
            thermovis::INFRARED_IMAGE_PIXELS);
  EXPECT_EQ(extent<decltype(std::declval<GridStereoFrame>().left())>(),
            thermovis::GRID_IMAGE_BYTES);
  EXPECT_EQ(extent<decltype(std::declval<GridStereoFrame>().right())>(),
            thermovis::GRID_IMAGE_BYTES);
  EXPECT_EQ(extent<decltype(std::declval<thermovis::PipelineStamps>().stamps())>(),
            thermovis::MAX_STAGE_STAMPS);
  // The packed twin's sequences hold any plain frame's eye.
  thermovis::PackedStereoFramePubSubType packed;
  EXPECT_GE(packed.m_typeSize, 2u * thermovis::GRID_IMAGE_BYTES);
  EXPECT_LT(packed.m_typeSize, 2u * thermovis::GRID_IMAGE_BYTES + 1024u);
  EXPECT_EQ(std::remove_cvref_t<decltype(std::declval<thermovis::TargetRange>().label())>::max_size,
            thermovis::MAX_LABEL_LENGTH);
  EXPECT_EQ(std::remove_cvref_t<decltype(std::declval<thermovis::Obstacle>().label())>::max_size,
            thermovis::MAX_LABEL_LENGTH);
  EXPECT_EQ(extent<decltype(std::declval<thermovis::ObstacleArray>().ground_normal())>(), 3u);
  EXPECT_GE(thermovis::MAX_FREE_SPACE_COLUMNS, thermovis::GRID_WIDTH);
  EXPECT_EQ(std::remove_cvref_t<decltype(std::declval<thermovis::Health>().service())>::max_size,
            thermovis::MAX_SERVICE_NAME_LENGTH);
  EXPECT_EQ(std::remove_cvref_t<decltype(std::declval<thermovis::Health>().message())>::max_size,
            thermovis::MAX_HEALTH_MESSAGE_LENGTH);
}

// Zero-copy needs plain types: fastddsgen 2.3 makes a struct plain only without enum members,
// strings and sequences.
TEST(IdlTypes, FrameTypesArePlainAndSmallTypesAreNot) {
  EXPECT_TRUE(tt::is_plain_type<thermovis::VisibleStereoFrame>());
  EXPECT_TRUE(tt::is_plain_type<thermovis::InfraredStereoFrame>());
  EXPECT_TRUE(tt::is_plain_type<thermovis::GridStereoFrame>());
  EXPECT_FALSE(tt::is_plain_type<thermovis::PackedStereoFrame>());
  EXPECT_FALSE(tt::is_plain_type<thermovis::RangeArray>());
  EXPECT_FALSE(tt::is_plain_type<thermovis::Health>());
}

// Data-sharing lends the C++ object's memory, in a buffer fastddsgen sizes by the XCDR1 size
// (+ 4 bytes of encapsulation header). They must be equal: a struct with padding would be
// larger in memory than on the wire and a loaned frame would overrun its buffer.
TEST(IdlTypes, FrameMemoryLayoutEqualsWireLayout) {
  EXPECT_EQ(thermovis::VisibleStereoFramePubSubType().m_typeSize,
            sizeof(thermovis::VisibleStereoFrame) + 4);
  EXPECT_EQ(thermovis::InfraredStereoFramePubSubType().m_typeSize,
            sizeof(thermovis::InfraredStereoFrame) + 4);
  EXPECT_EQ(thermovis::GridStereoFramePubSubType().m_typeSize,
            sizeof(thermovis::GridStereoFrame) + 4);
  EXPECT_EQ(sizeof(thermovis::StageStamp), 16u);
  EXPECT_EQ(sizeof(thermovis::PipelineStamps), 16u * thermovis::MAX_STAGE_STAMPS);
}

TEST(TransportStamps, AppendUntilFull) {
  thermovis::PipelineStamps stamps;
  tt::clear_stamps(stamps);
  EXPECT_EQ(tt::stamp_count(stamps), 0u);
  EXPECT_TRUE(tt::append_stamp(stamps, thermovis::STAGE_BRIDGE, 1'000'000, 3'500'000));
  EXPECT_TRUE(tt::append_stamp(stamps, thermovis::STAGE_RECTIFY_FUSE, 3'600'000, 9'600'000));
  EXPECT_EQ(tt::stamp_count(stamps), 2u);
  EXPECT_EQ(stamps.stamps()[0].stage(), thermovis::STAGE_BRIDGE);
  EXPECT_EQ(stamps.stamps()[0].duration_us(), 2500u);
  EXPECT_EQ(stamps.stamps()[1].duration_us(), 6000u);
  EXPECT_EQ(stamps.stamps()[1].end_ns(), 9'600'000);
  EXPECT_TRUE(tt::append_stamp(stamps, thermovis::STAGE_DETECT, 10'000'000, 9'700'000));
  EXPECT_EQ(stamps.stamps()[2].duration_us(), 0u);  // ended before it started: no duration
  EXPECT_EQ(stamps.stamps()[2].end_ns(), 9'700'000);
  for (std::size_t i = 3; i < thermovis::MAX_STAGE_STAMPS; ++i) {
    EXPECT_TRUE(tt::append_stamp(stamps, thermovis::STAGE_DETECT, 0, 1000));
  }
  // Full: the first entries stay, the last slot takes the newest stage.
  EXPECT_FALSE(tt::append_stamp(stamps, thermovis::STAGE_RANGE, 30'000'000, 32'000'000));
  EXPECT_EQ(tt::stamp_count(stamps), thermovis::MAX_STAGE_STAMPS);
  EXPECT_EQ(stamps.stamps()[0].stage(), thermovis::STAGE_BRIDGE);
  EXPECT_EQ(stamps.stamps().back().stage(), thermovis::STAGE_RANGE);
  EXPECT_EQ(stamps.stamps().back().end_ns(), 32'000'000);
  EXPECT_EQ(stamps.stamps().back().duration_us(), 2000u);
  EXPECT_DOUBLE_EQ(tt::latency_ms(stamps, 1'000'000), 31.0);
}

TEST(TransportStamps, LatencyRunsFromCaptureToTheLatestStageEnd) {
  thermovis::PipelineStamps stamps;
  tt::clear_stamps(stamps);
  EXPECT_EQ(tt::latency_ms(stamps, 1'000'000), 0.0);
  tt::append_stamp(stamps, thermovis::STAGE_BRIDGE, 1'000'000, 3'500'000);
  tt::append_stamp(stamps, thermovis::STAGE_RANGE, 20'000'000, 26'000'000);
  EXPECT_DOUBLE_EQ(tt::latency_ms(stamps, 1'000'000), 25.0);
}

TEST(IdlTypes, PublicContractNames) {
  EXPECT_EQ(thermovis::RangeArrayPubSubType().getName(), std::string("thermovis::RangeArray"));
  EXPECT_EQ(thermovis::HealthPubSubType().getName(), std::string("thermovis::Health"));
  EXPECT_EQ(thermovis::ObstacleArrayPubSubType().getName(),
            std::string("thermovis::ObstacleArray"));
  // Health is keyed by service: one TRANSIENT_LOCAL instance per service.
  EXPECT_TRUE(thermovis::HealthPubSubType().m_isGetKeyDefined);
  EXPECT_FALSE(thermovis::RangeArrayPubSubType().m_isGetKeyDefined);
}

TEST(TransportBounds, OversizedSequencesAreRefused) {
  thermovis::RangeArray ranges;
  ranges.targets().resize(thermovis::MAX_TARGETS);
  EXPECT_NO_THROW(tt::check_bounds(ranges));
  ranges.targets().resize(thermovis::MAX_TARGETS + 1);
  try {
    tt::check_bounds(ranges);
    FAIL() << "65 targets accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("RangeArray.targets has 65 elements"), std::string::npos)
        << e.what();
  }
  thermovis::MatchArray matches;
  matches.targets().resize(1);
  matches.targets()[0].points().resize(thermovis::MAX_POINT_MATCHES + 1);
  EXPECT_THROW(tt::check_bounds(matches), std::invalid_argument);
  thermovis::ObstacleArray obstacles;
  obstacles.obstacles().resize(thermovis::MAX_OBSTACLES);
  obstacles.free_space_m().resize(thermovis::MAX_FREE_SPACE_COLUMNS);
  EXPECT_NO_THROW(tt::check_bounds(obstacles));
  obstacles.free_space_row().resize(thermovis::MAX_FREE_SPACE_COLUMNS + 1);
  EXPECT_THROW(tt::check_bounds(obstacles), std::invalid_argument);
  obstacles.free_space_row().clear();
  obstacles.obstacles().resize(thermovis::MAX_OBSTACLES + 1);
  EXPECT_THROW(tt::check_bounds(obstacles), std::invalid_argument);
}

TEST(TransportQos, FramePoolsAreSizedExactly) {
  const auto qos = tt::frame_topic_qos(20ms, 3, 2);
  const dds::DataWriterQos w = tt::writer_qos(qos);
  EXPECT_EQ(w.history().kind, dds::KEEP_LAST_HISTORY_QOS);
  EXPECT_EQ(w.history().depth, 3);
  EXPECT_EQ(w.resource_limits().max_samples, 3);
  EXPECT_EQ(w.resource_limits().allocated_samples, 3);
  EXPECT_EQ(w.resource_limits().max_samples_per_instance, 3);
  EXPECT_EQ(w.resource_limits().extra_samples, 3);  // readers + 1
  EXPECT_EQ(w.reliability().kind, dds::RELIABLE_RELIABILITY_QOS);
  EXPECT_EQ(w.deadline().period.to_ns(), 20'000'000);
  EXPECT_EQ(w.data_sharing().kind(), dds::DataSharingKind::AUTO);
  const dds::DataReaderQos r = tt::reader_qos(qos);
  EXPECT_EQ(r.resource_limits().max_samples, 3);
  EXPECT_EQ(r.resource_limits().allocated_samples, 3);
  EXPECT_EQ(r.deadline().period.to_ns(), 20'000'000);
  EXPECT_EQ(r.data_sharing().kind(), dds::DataSharingKind::AUTO);
}

TEST(TransportQos, SmallTopics) {
  const dds::DataWriterQos event = tt::writer_qos(tt::event_topic_qos());
  EXPECT_EQ(event.reliability().kind, dds::RELIABLE_RELIABILITY_QOS);
  EXPECT_EQ(event.durability().kind, dds::VOLATILE_DURABILITY_QOS);
  EXPECT_EQ(event.data_sharing().kind(), dds::DataSharingKind::OFF);
  EXPECT_EQ(event.deadline().period, eprosima::fastrtps::c_TimeInfinite);
  const dds::DataReaderQos state = tt::reader_qos(tt::state_topic_qos());
  EXPECT_EQ(state.durability().kind, dds::TRANSIENT_LOCAL_DURABILITY_QOS);
  EXPECT_EQ(state.history().depth, 1);
}

TEST(TransportQos, BadSettingsAreNamed) {
  auto message = [](const tt::TopicQos& qos) {
    try {
      tt::validate(qos);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(message(tt::frame_topic_qos(20ms, 1)).find("depth 1 out of range 2..4"),
            std::string::npos);
  EXPECT_NE(message(tt::frame_topic_qos(20ms, 8)).find("depth 8"), std::string::npos);
  EXPECT_NE(message(tt::frame_topic_qos(20ms, 2, 0)).find("max_readers"), std::string::npos);
  EXPECT_NE(message(tt::frame_topic_qos(-1ms)).find("deadline"), std::string::npos);
  EXPECT_EQ(message(tt::frame_topic_qos()), "");
}

TEST(TransportParticipant, ConfigErrorsNameTheCulprit) {
  auto message = [](const tt::ParticipantConfig& config) {
    try {
      tt::Participant participant(config);
    } catch (const std::exception& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(message({0, "/nonexistent/profiles.xml", tt::kLoopbackProfile, ""})
                .find("/nonexistent/profiles.xml"),
            std::string::npos);
  EXPECT_NE(message({0, {}, "no_such_profile", ""}).find("no_such_profile"), std::string::npos);
  EXPECT_NE(message({300, {}, tt::kLoopbackProfile, ""}).find("domain id 300"), std::string::npos);
  EXPECT_TRUE(std::filesystem::is_regular_file(tt::shipped_profile_file(tt::kHostProfile)));
  EXPECT_TRUE(std::filesystem::is_regular_file(tt::shipped_profile_file(tt::kLoopbackProfile)));
}

}  // namespace
