#include "thermovis/transport/participant.hpp"

#include <cstdlib>
#include <map>
#include <mutex>
#include <set>
#include <stdexcept>

#include <fastdds/rtps/attributes/PropertyPolicy.h>
#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/Topic.hpp>
#include <fastdds/rtps/flowcontrol/FlowControllerDescriptor.hpp>

#include "thermovis/transport/shared_memory.hpp"

namespace thermovis::transport {

namespace dds = eprosima::fastdds::dds;

namespace {

// Fast DDS keeps loaded profiles for the whole process and refuses a second load of the same
// file (duplicate profile names), so each file is loaded once.
void load_profiles_once(const std::filesystem::path& file) {
  static std::mutex mutex;
  static std::set<std::string> loaded;
  const std::lock_guard lock(mutex);
  const std::string key = std::filesystem::absolute(file).lexically_normal().string();
  if (loaded.count(key) != 0) return;
  if (!std::filesystem::is_regular_file(file)) {
    throw std::runtime_error("DDS profile file not found: " + file.string());
  }
  if (dds::DomainParticipantFactory::get_instance()->load_XML_profiles_file(key) !=
      ReturnCode_t::RETCODE_OK) {
    throw std::runtime_error("DDS profile file could not be parsed: " + file.string() +
                             " (see the Fast DDS log above for the line)");
  }
  loaded.insert(key);
}

}  // namespace

std::filesystem::path profile_dir() {
  if (const char* env = std::getenv("THERMOVIS_DDS_PROFILE_DIR"); env != nullptr && *env != '\0') {
    return env;
  }
  return THERMOVIS_DDS_PROFILE_DIR;
}

std::filesystem::path shipped_profile_file(const std::string& profile) {
  static const std::map<std::string, std::string> files = {
      {kHostProfile, "host.xml"},     {kLoopbackProfile, "loopback.xml"},
      {kUdpProfile, "udp.xml"},       {kUdpPacedProfile, "udp.xml"},
      {kDiscoveryProfile, "udp.xml"}, {kSecureProfile, "secure.xml"}};
  const auto it = files.find(profile);
  if (it == files.end()) {
    throw std::invalid_argument("unknown DDS participant profile '" + profile +
                                "' (shipped: thermovis_host, thermovis_loopback, thermovis_udp, "
                                "thermovis_udp_paced, thermovis_discovery, thermovis_secure)");
  }
  return profile_dir() / it->second;
}

namespace {

// The value of a profile's property `name`, or null.
const std::string* find_property(const dds::DomainParticipantQos& qos, const std::string& name) {
  return eprosima::fastrtps::rtps::PropertyPolicyHelper::find_property(qos.properties(), name);
}

// Fast DDS 2.9 reads flow controllers from code only (its XML parser knows no
// flow_controller_descriptor_list), so a profile states the frame writers' bandwidth limit as
// properties and this registers the controller. Returns its name, or empty when not configured.
std::string register_frame_flow_controller(dds::DomainParticipantQos& qos,
                                           const std::string& profile) {
  const std::string* bytes = find_property(qos, "thermovis.frames.max_bytes_per_period");
  const std::string* period = find_property(qos, "thermovis.frames.period_ms");
  if (bytes == nullptr) return {};
  auto number = [&](const std::string* text, const char* what, long long low, long long high) {
    try {
      std::size_t used = 0;
      const long long value = std::stoll(*text, &used);
      if (used == text->size() && value >= low && value <= high) return value;
    } catch (const std::exception&) {
    }
    throw std::runtime_error("DDS profile '" + profile + "': property " + what + " = '" + *text +
                             "' is not a number in " + std::to_string(low) + ".." +
                             std::to_string(high));
  };
  static constexpr const char* kName = "thermovis_frames";
  auto descriptor = std::make_shared<eprosima::fastdds::rtps::FlowControllerDescriptor>();
  descriptor->name = kName;
  // Round robin: the rectified visible and infrared writers share the link in turns.
  descriptor->scheduler = eprosima::fastdds::rtps::FlowControllerSchedulerPolicy::ROUND_ROBIN;
  descriptor->max_bytes_per_period = static_cast<std::int32_t>(
      number(bytes, "thermovis.frames.max_bytes_per_period", 0, 2147483647));
  descriptor->period_ms = static_cast<std::uint64_t>(
      period == nullptr ? 100 : number(period, "thermovis.frames.period_ms", 1, 10000));
  qos.flow_controllers().push_back(descriptor);
  return kName;
}

// A profile that enables the DDS Security plugins gets this participant's identity files:
// $THERMOVIS_SECURITY_DIR/<name>.{cert,key}.pem and <name>.permissions.p7s, with the CA, the
// governance and, when there, the revocation list crl.pem of that folder
// (deploy/security/make-security.sh). identity_ca.cert.pem / permissions_ca.cert.pem, when there,
// stand for ca.cert.pem as the CA of the identities / of the signed documents.
bool is_secure(const dds::DomainParticipantQos& qos) {
  return find_property(qos, "dds.sec.auth.plugin") != nullptr;
}

void add_security_files(dds::DomainParticipantQos& qos, const ParticipantConfig& config) {
  if (!is_secure(qos)) return;
  const char* dir_env = std::getenv("THERMOVIS_SECURITY_DIR");
  if (dir_env == nullptr || *dir_env == '\0') {
    throw std::runtime_error("DDS profile '" + config.profile +
                             "' needs THERMOVIS_SECURITY_DIR (the folder written by "
                             "deploy/security/make-security.sh)");
  }
  if (config.name.empty()) {
    throw std::runtime_error("DDS profile '" + config.profile +
                             "': the participant needs a name (its security identity)");
  }
  const std::filesystem::path dir = std::filesystem::absolute(dir_env);
  auto file = [&](const std::string& leaf) {
    const auto path = dir / leaf;
    if (!std::filesystem::is_regular_file(path)) {
      throw std::runtime_error("DDS Security file missing: " + path.string() + " (identity '" +
                               config.name + "')");
    }
    return "file://" + path.string();
  };
  auto either = [&](const std::string& leaf, const std::string& otherwise) {
    return file(std::filesystem::is_regular_file(dir / leaf) ? leaf : otherwise);
  };
  auto& properties = qos.properties().properties();
  const std::string auth = "dds.sec.auth.builtin.PKI-DH.";
  const std::string access = "dds.sec.access.builtin.Access-Permissions.";
  properties.emplace_back(auth + "identity_ca", either("identity_ca.cert.pem", "ca.cert.pem"));
  properties.emplace_back(auth + "identity_certificate", file(config.name + ".cert.pem"));
  properties.emplace_back(auth + "private_key", file(config.name + ".key.pem"));
  if (std::filesystem::is_regular_file(dir / "crl.pem"))
    properties.emplace_back(auth + "identity_crl", file("crl.pem"));
  properties.emplace_back(access + "permissions_ca",
                          either("permissions_ca.cert.pem", "ca.cert.pem"));
  properties.emplace_back(access + "governance", file("governance.p7s"));
  properties.emplace_back(access + "permissions", file(config.name + ".permissions.p7s"));
}

}  // namespace

Participant::Participant(const ParticipantConfig& config) : state_(std::make_shared<State>()) {
  // Links the robust process-shared mutexes into every process with a participant.
  static_cast<void>(robust_mutexes());
  if (config.domain_id < 0 || config.domain_id > 232) {
    throw std::invalid_argument("DDS domain id " + std::to_string(config.domain_id) +
                                " out of range 0..232");
  }
  const std::filesystem::path file =
      config.profiles_file.empty() ? shipped_profile_file(config.profile) : config.profiles_file;
  load_profiles_once(file);

  auto* factory = dds::DomainParticipantFactory::get_instance();
  dds::DomainParticipantQos qos;
  if (factory->get_participant_qos_from_profile(config.profile, qos) != ReturnCode_t::RETCODE_OK) {
    throw std::runtime_error("DDS participant profile '" + config.profile + "' not found in " +
                             file.string());
  }
  if (!config.name.empty()) qos.name(config.name);
  if (config.profile == kDiscoveryProfile) {
    // Fast DDS makes the participant a client of these servers; without them it would fall
    // back to multicast discovery, which this profile is for networks without.
    const char* servers = std::getenv("ROS_DISCOVERY_SERVER");
    if (servers == nullptr || *servers == '\0') {
      throw std::runtime_error(
          "DDS profile 'thermovis_discovery' needs ROS_DISCOVERY_SERVER=IP:PORT (the address of "
          "a running `fastdds discovery -i 0 -l IP -p PORT`)");
    }
  }
  if (qos.wire_protocol().participant_id < 0) {
    // Ports no dead process left behind (fresh_participant_id); the secured profile announces
    // itself to the ports of ids 0..15, the others to 0..31 (their initial peers' range). The
    // ids this process's participants took are skipped too: a profile without the SHM transport
    // leaves no port file to tell them by, and Fast DDS refuses an id twice in one process.
    static std::mutex taken_mutex;
    static std::set<int> taken;
    const std::lock_guard<std::mutex> lock(taken_mutex);
    const auto& port = qos.wire_protocol().port;
    const int max_ids = is_secure(qos) ? 16 : 32;
    const int id = fresh_participant_id(
        [&](int candidate) {
          return port.portBase + port.domainIDGain * static_cast<std::uint32_t>(config.domain_id) +
                 port.offsetd1 + port.participantIDGain * static_cast<std::uint32_t>(candidate);
        },
        max_ids, taken);
    qos.wire_protocol().participant_id = id;
    if (id >= 0) taken.insert(id);
  }
  state_->domain_id = config.domain_id;
  state_->profile = config.profile;
  state_->frame_transport = config.frame_transport;
  if (const std::string* group = find_property(qos, "thermovis.packed.multicast_group"))
    state_->packed_multicast_group = *group;
  state_->frame_flow_controller = register_frame_flow_controller(qos, config.profile);
  add_security_files(qos, config);
  state_->participant = factory->create_participant(config.domain_id, qos);
  if (state_->participant == nullptr) {
    throw std::runtime_error("cannot create DDS participant on domain " +
                             std::to_string(config.domain_id) + " with profile '" + config.profile +
                             "' of " + file.string());
  }
  state_->publisher = state_->participant->create_publisher(dds::PUBLISHER_QOS_DEFAULT);
  state_->subscriber = state_->participant->create_subscriber(dds::SUBSCRIBER_QOS_DEFAULT);
  if (state_->publisher == nullptr || state_->subscriber == nullptr) {
    throw std::runtime_error("cannot create the DDS publisher/subscriber on domain " +
                             std::to_string(config.domain_id));
  }
}

Participant::~Participant() = default;

int Participant::domain_id() const { return state_->domain_id; }

dds::DomainParticipant& Participant::native() { return *state_->participant; }

dds::Topic* Participant::State::topic(const std::string& name, const dds::TypeSupport& type) {
  static std::mutex mutex;  // topics are created rarely; one lock for all participants
  const std::lock_guard lock(mutex);
  if (dds::TopicDescription* existing = participant->lookup_topicdescription(name)) {
    if (existing->get_type_name() != type.get_type_name()) {
      throw std::runtime_error("topic '" + name + "' already has type " +
                               existing->get_type_name() + ", not " + type.get_type_name());
    }
    return dynamic_cast<dds::Topic*>(existing);
  }
  if (participant->find_type(type.get_type_name()).empty()) {
    if (type.register_type(participant) != ReturnCode_t::RETCODE_OK) {
      throw std::runtime_error("cannot register DDS type " + type.get_type_name());
    }
  }
  dds::Topic* topic = participant->create_topic(name, type.get_type_name(), dds::TOPIC_QOS_DEFAULT);
  if (topic == nullptr) {
    throw std::runtime_error("cannot create DDS topic '" + name + "' of type " +
                             type.get_type_name());
  }
  return topic;
}

Participant::State::~State() {
  if (participant == nullptr) return;
  // Endpoints are gone (they hold this state); remove topics, publisher, subscriber.
  participant->delete_contained_entities();
  dds::DomainParticipantFactory::get_instance()->delete_participant(participant);
}

}  // namespace thermovis::transport
