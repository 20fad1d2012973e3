#include "mcap_format.hpp"

#include <zlib.h>

#include "thermovis/util/enum_names.hpp"

namespace thermovis::record::mcap_format {

namespace {

constexpr util::EnumName<std::uint8_t> kOpcodeNames[] = {{kHeader, "Header"},
                                                         {kFooter, "Footer"},
                                                         {kSchema, "Schema"},
                                                         {kChannel, "Channel"},
                                                         {kMessage, "Message"},
                                                         {kChunk, "Chunk"},
                                                         {kMessageIndex, "Message Index"},
                                                         {kChunkIndex, "Chunk Index"},
                                                         {kAttachment, "Attachment"},
                                                         {kAttachmentIndex, "Attachment Index"},
                                                         {kStatistics, "Statistics"},
                                                         {kMetadata, "Metadata"},
                                                         {kMetadataIndex, "Metadata Index"},
                                                         {kSummaryOffset, "Summary Offset"},
                                                         {kDataEnd, "Data End"}};

}  // namespace

const char* opcode_name(std::uint8_t opcode) {
  return util::name_of(kOpcodeNames, opcode, opcode >= 0x80 ? "private record" : "unknown record");
}

std::uint32_t crc32(std::uint32_t crc, const void* data, std::size_t size) {
  return static_cast<std::uint32_t>(::crc32_z(crc, static_cast<const Bytef*>(data), size));
}

void Out::string(const std::string& s) {
  u32(static_cast<std::uint32_t>(s.size()));
  raw(s.data(), s.size());
}

void Out::string_map(const std::map<std::string, std::string>& map) {
  std::uint32_t length = 0;
  for (const auto& [key, value] : map) length += 8 + key.size() + value.size();
  u32(length);
  for (const auto& [key, value] : map) {
    string(key);
    string(value);
  }
}

void Out::u16_u64_map(const std::map<std::uint16_t, std::uint64_t>& map) {
  u32(static_cast<std::uint32_t>(map.size() * 10));
  for (const auto& [key, value] : map) {
    u16(key);
    u64(value);
  }
}

std::uint64_t In::uint(std::size_t bytes, const char* what) {
  if (remaining() < bytes) {
    throw ShortRecord("record ends inside a " + std::string(what) + " field at content byte " +
                      std::to_string(at_));
  }
  std::uint64_t v = 0;
  for (std::size_t i = bytes; i-- > 0;) v = (v << 8) | data_[at_ + i];
  at_ += bytes;
  return v;
}

const std::uint8_t* In::bytes(std::size_t size, const char* field) {
  if (remaining() < size) {
    throw ShortRecord(std::string(field) + " needs " + std::to_string(size) +
                      " bytes, the record has " + std::to_string(remaining()) + " left");
  }
  const std::uint8_t* p = data_ + at_;
  at_ += size;
  return p;
}

std::string In::string(const char* field) {
  const std::uint32_t length = u32();
  const std::uint8_t* p = bytes(length, field);
  return std::string(reinterpret_cast<const char*>(p), length);
}

std::map<std::string, std::string> In::string_map(const char* field) {
  const std::uint32_t length = u32();
  In entries(bytes(length, field), length);
  std::map<std::string, std::string> out;
  while (entries.remaining() > 0) {
    std::string key = entries.string(field);
    out[key] = entries.string(field);
  }
  return out;
}

std::map<std::uint16_t, std::uint64_t> In::u16_u64_map(const char* field) {
  const std::uint32_t length = u32();
  if (length % 10 != 0) {
    throw ShortRecord(std::string(field) + " is " + std::to_string(length) +
                      " bytes, not a whole number of (uint16, uint64) entries");
  }
  In entries(bytes(length, field), length);
  std::map<std::uint16_t, std::uint64_t> out;
  while (entries.remaining() > 0) {
    const std::uint16_t key = entries.u16();
    out[key] = entries.u64();
  }
  return out;
}

}  // namespace thermovis::record::mcap_format
