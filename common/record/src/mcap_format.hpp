#pragma once
// The byte-level pieces of the MCAP format shared by the writer and the reader: magic, opcodes,
// little-endian fields, strings, maps and the CRC32 of the specification (the zlib / IEEE one).
#include <cstdint>
#include <cstring>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

namespace thermovis::record::mcap_format {

inline constexpr std::uint8_t kMagic[8] = {0x89, 'M', 'C', 'A', 'P', '0', '\r', '\n'};
inline constexpr std::size_t kRecordHeaderSize = 1 + 8;  // opcode, content length
inline constexpr std::size_t kFooterContentSize = 8 + 8 + 4;
inline constexpr std::size_t kFooterRecordSize = kRecordHeaderSize + kFooterContentSize;

enum Opcode : std::uint8_t {
  kHeader = 0x01,
  kFooter = 0x02,
  kSchema = 0x03,
  kChannel = 0x04,
  kMessage = 0x05,
  kChunk = 0x06,
  kMessageIndex = 0x07,
  kChunkIndex = 0x08,
  kAttachment = 0x09,
  kAttachmentIndex = 0x0A,
  kStatistics = 0x0B,
  kMetadata = 0x0C,
  kMetadataIndex = 0x0D,
  kSummaryOffset = 0x0E,
  kDataEnd = 0x0F,
};

// Fixed part of a Message record before its data: channel, sequence, log and publish time.
inline constexpr std::size_t kMessagePrefixSize = 2 + 4 + 8 + 8;

const char* opcode_name(std::uint8_t opcode);

// CRC32 (polynomial 0xEDB88320, as zlib's crc32) continued from `crc` (0 to start).
std::uint32_t crc32(std::uint32_t crc, const void* data, std::size_t size);

// Appends little-endian fields to a byte vector.
class Out {
 public:
  explicit Out(std::vector<std::uint8_t>& bytes) : bytes_(bytes) {}
  void u8(std::uint8_t v) { bytes_.push_back(v); }
  void u16(std::uint16_t v) { uint(v, 2); }
  void u32(std::uint32_t v) { uint(v, 4); }
  void u64(std::uint64_t v) { uint(v, 8); }
  void raw(const void* data, std::size_t size) {
    const auto* p = static_cast<const std::uint8_t*>(data);
    bytes_.insert(bytes_.end(), p, p + size);
  }
  void string(const std::string& s);  // uint32 length + bytes
  void string_map(const std::map<std::string, std::string>& map);
  void u16_u64_map(const std::map<std::uint16_t, std::uint64_t>& map);

 private:
  void uint(std::uint64_t v, int bytes) {
    for (int i = 0; i < bytes; ++i) bytes_.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
  }
  std::vector<std::uint8_t>& bytes_;
};

// Thrown by In when a field runs past the end of its record; the reader adds file and offset.
struct ShortRecord : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Reads little-endian fields from a record's content.
class In {
 public:
  In(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  std::uint8_t u8() { return static_cast<std::uint8_t>(uint(1, "uint8")); }
  std::uint16_t u16() { return static_cast<std::uint16_t>(uint(2, "uint16")); }
  std::uint32_t u32() { return static_cast<std::uint32_t>(uint(4, "uint32")); }
  std::uint64_t u64() { return uint(8, "uint64"); }
  std::string string(const char* field);
  std::map<std::string, std::string> string_map(const char* field);
  std::map<std::uint16_t, std::uint64_t> u16_u64_map(const char* field);
  // `size` bytes in place (valid as long as the record's buffer).
  const std::uint8_t* bytes(std::size_t size, const char* field);
  std::size_t position() const { return at_; }
  std::size_t remaining() const { return size_ - at_; }

 private:
  std::uint64_t uint(std::size_t bytes, const char* what);
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t at_ = 0;
};

inline std::uint64_t load_u64(const std::uint8_t* p) {
  std::uint64_t v = 0;
  for (int i = 7; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}

}  // namespace thermovis::record::mcap_format
