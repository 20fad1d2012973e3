#pragma once
// A DDS domain participant created from an XML profile (deploy/dds/), with the one publisher
// and one subscriber its writers and readers share.
//
// Lifetime: writers and readers keep the participant's state alive, so destroying a Participant
// before its endpoints is safe; the DDS participant goes when the last of them goes.
#include <filesystem>
#include <memory>
#include <string>

namespace eprosima::fastdds::dds {
class DomainParticipant;
class Publisher;
class Subscriber;
class Topic;
class TypeSupport;
}  // namespace eprosima::fastdds::dds

namespace thermovis::transport {

// Names of the participant profiles shipped in deploy/dds/.
inline constexpr const char* kHostProfile = "thermovis_host";          // host.xml
inline constexpr const char* kLoopbackProfile = "thermovis_loopback";  // loopback.xml
// Across hosts (udp.xml): UDPv4 with large-sample settings between machines, shared memory within
// one; simple (multicast) discovery, or a discovery server named by $ROS_DISCOVERY_SERVER.
inline constexpr const char* kUdpProfile = "thermovis_udp";
inline constexpr const char* kUdpPacedProfile = "thermovis_udp_paced";  // frames flow-controlled
inline constexpr const char* kDiscoveryProfile = "thermovis_discovery";
// DDS Security (secure.xml): identity files from $THERMOVIS_SECURITY_DIR by participant name.
inline constexpr const char* kSecureProfile = "thermovis_secure";

// Which wire a participant's frame readers (FrameReader, frames.hpp) take frames from: the plain
// frame topics, delivered by data-sharing without a copy on the writer's host, or their packed
// twins (<topic>/packed: the pixels only, serialised), for a process on another host.
enum class FrameTransport { plain, packed };

struct ParticipantConfig {
  int domain_id = 0;                    // 0..232 (UDP port arithmetic of the RTPS spec)
  std::filesystem::path profiles_file;  // empty: profile_dir() / "host.xml"
  std::string profile = kHostProfile;   // participant profile name in that file
  std::string name;                     // participant name seen by discovery tools
  FrameTransport frame_transport = FrameTransport::plain;
};

// Folder of the shipped profiles: $THERMOVIS_DDS_PROFILE_DIR if set, else deploy/dds of the
// source tree the library was built from.
std::filesystem::path profile_dir();

// The profile file for a profile name shipped in profile_dir() ("thermovis_loopback" ->
// loopback.xml). Throws std::invalid_argument for an unknown name.
std::filesystem::path shipped_profile_file(const std::string& profile);

class Participant {
 public:
  // Loads the profile file (once per process) and creates the participant. Throws
  // std::runtime_error naming the file, profile and domain when any step fails.
  explicit Participant(const ParticipantConfig& config);
  ~Participant();
  Participant(const Participant&) = delete;
  Participant& operator=(const Participant&) = delete;

  int domain_id() const;
  eprosima::fastdds::dds::DomainParticipant& native();

  struct State;  // shared with the endpoints
  const std::shared_ptr<State>& state() const { return state_; }

 private:
  std::shared_ptr<State> state_;
};

// The pieces of a participant that endpoints use. Thread-safe.
struct Participant::State {
  eprosima::fastdds::dds::DomainParticipant* participant = nullptr;
  eprosima::fastdds::dds::Publisher* publisher = nullptr;
  eprosima::fastdds::dds::Subscriber* subscriber = nullptr;
  int domain_id = 0;
  std::string profile;  // the participant profile it was made from
  // Flow controller frame writers publish through (asynchronously), or empty: frames are sent
  // by the writing thread. Set by a profile's properties thermovis.frames.max_bytes_per_period
  // and thermovis.frames.period_ms (udp.xml: large frames to other hosts).
  std::string frame_flow_controller;
  FrameTransport frame_transport = FrameTransport::plain;  // ParticipantConfig's
  // IPv4 multicast group (its last byte chosen per topic) that readers of packed frame twins
  // receive on, so that one sample on the wire serves every reader of a host (detect and match
  // both read the infrared pair); empty: unicast per reader. Set by a profile's property
  // thermovis.packed.multicast_group (udp.xml).
  std::string packed_multicast_group;

  // The topic of that name, created (and its type registered) on first use. Throws when the
  // name is already used with another type.
  eprosima::fastdds::dds::Topic* topic(const std::string& name,
                                       const eprosima::fastdds::dds::TypeSupport& type);
  ~State();
};

}  // namespace thermovis::transport
