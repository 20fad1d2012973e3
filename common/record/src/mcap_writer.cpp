#include <zstd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "mcap_format.hpp"
#include "thermovis/record/mcap.hpp"

namespace thermovis::record {

namespace fmt = mcap_format;

struct McapWriter::ZstdContext {
  ZSTD_CCtx* cctx = ZSTD_createCCtx();
  ~ZstdContext() { ZSTD_freeCCtx(cctx); }
};

McapWriter::McapWriter(const std::filesystem::path& path, const McapWriterOptions& options)
    : path_(path), options_(options) {
  if (options_.chunk_size == 0) fail("chunk size must be positive");
  if (options_.compression == McapCompression::zstd) {
    if (options_.zstd_level < 1 || options_.zstd_level > ZSTD_maxCLevel()) {
      fail("zstd level " + std::to_string(options_.zstd_level) + " out of range 1.." +
           std::to_string(ZSTD_maxCLevel()));
    }
    zstd_ = std::make_unique<ZstdContext>();
    if (zstd_->cctx == nullptr) fail("cannot create a zstd context");
  }
  file_ = std::fopen(path_.c_str(), "wb");
  if (file_ == nullptr) fail(std::string("cannot create: ") + std::strerror(errno));
  // Frames are megabytes: a large stdio buffer saves system calls for the small records.
  std::setvbuf(file_, nullptr, _IOFBF, 1u << 20);
  put(fmt::kMagic, sizeof(fmt::kMagic));
  std::vector<std::uint8_t> header;
  fmt::Out out(header);
  out.string(options_.profile);
  out.string(options_.library);
  put_record(fmt::kHeader, header);
}

McapWriter::~McapWriter() {
  try {
    close();
  } catch (const McapError&) {
    // Reported by an explicit close(); a destructor must not throw.
  }
  if (file_ != nullptr) std::fclose(file_);
}

void McapWriter::fail(const std::string& what) const {
  throw McapError(path_.string() + ": " + what);
}

void McapWriter::put(const void* bytes, std::size_t size) {
  if (size == 0) return;
  if (std::fwrite(bytes, 1, size, file_) != size)
    fail("write failed at byte " + std::to_string(offset_) + ": " + std::strerror(errno));
  offset_ += size;
  if (!data_ended_) data_crc_ = fmt::crc32(data_crc_, bytes, size);
  if (in_summary_) summary_crc_ = fmt::crc32(summary_crc_, bytes, size);
}

void McapWriter::put_record(std::uint8_t opcode, const std::vector<std::uint8_t>& content) {
  std::vector<std::uint8_t> head;
  fmt::Out out(head);
  out.u8(opcode);
  out.u64(content.size());
  put(head.data(), head.size());
  put(content.data(), content.size());
}

namespace {

std::vector<std::uint8_t> schema_content(const McapSchema& schema) {
  std::vector<std::uint8_t> content;
  fmt::Out out(content);
  out.u16(schema.id);
  out.string(schema.name);
  out.string(schema.encoding);
  out.string(schema.data);  // uint32 length-prefixed bytes: the same layout as a string
  return content;
}

std::vector<std::uint8_t> channel_content(const McapChannel& channel) {
  std::vector<std::uint8_t> content;
  fmt::Out out(content);
  out.u16(channel.id);
  out.u16(channel.schema_id);
  out.string(channel.topic);
  out.string(channel.message_encoding);
  out.string_map(channel.metadata);
  return content;
}

}  // namespace

std::uint16_t McapWriter::add_schema(const std::string& name, const std::string& encoding,
                                     const std::string& data) {
  if (closed_) fail("add_schema after close");
  if (schemas_.size() >= 0xFFFE) fail("too many schemas");
  McapSchema schema{static_cast<std::uint16_t>(schemas_.size() + 1), name, encoding, data};
  // Outside any chunk, before every chunk that can refer to it (the open chunk is written later).
  put_record(fmt::kSchema, schema_content(schema));
  schemas_.push_back(schema);
  return schema.id;
}

std::uint16_t McapWriter::add_channel(std::uint16_t schema_id, const std::string& topic,
                                      const std::string& message_encoding,
                                      const std::map<std::string, std::string>& metadata) {
  if (closed_) fail("add_channel after close");
  if (schema_id > schemas_.size())
    fail("channel '" + topic + "': unknown schema id " + std::to_string(schema_id));
  if (channels_.size() >= 0xFFFF) fail("too many channels");
  McapChannel channel{static_cast<std::uint16_t>(channels_.size()), schema_id, topic,
                      message_encoding, metadata};
  put_record(fmt::kChannel, channel_content(channel));
  channels_.push_back(channel);
  return channel.id;
}

void McapWriter::write(std::uint16_t channel_id, std::uint32_t sequence, std::uint64_t log_time,
                       std::uint64_t publish_time, const void* data, std::size_t size) {
  if (closed_) fail("write after close");
  if (channel_id >= channels_.size())
    fail("message on unknown channel " + std::to_string(channel_id));
  if (!chunk_.empty() && chunk_.size() + fmt::kRecordHeaderSize + fmt::kMessagePrefixSize + size >
                             options_.chunk_size) {
    flush_chunk();
  }
  if (chunk_index_.empty()) {
    chunk_start_time_ = log_time;
    chunk_end_time_ = log_time;
  }
  chunk_start_time_ = std::min(chunk_start_time_, log_time);
  chunk_end_time_ = std::max(chunk_end_time_, log_time);
  chunk_index_[channel_id].emplace_back(log_time, chunk_.size());
  chunk_.reserve(chunk_.size() + fmt::kRecordHeaderSize + fmt::kMessagePrefixSize + size);
  fmt::Out out(chunk_);
  out.u8(fmt::kMessage);
  out.u64(fmt::kMessagePrefixSize + size);
  out.u16(channel_id);
  out.u32(sequence);
  out.u64(log_time);
  out.u64(publish_time);
  out.raw(data, size);

  if (stats_.message_count == 0) {
    stats_.message_start_time = log_time;
    stats_.message_end_time = log_time;
  }
  ++stats_.message_count;
  stats_.message_start_time = std::min(stats_.message_start_time, log_time);
  stats_.message_end_time = std::max(stats_.message_end_time, log_time);
  ++stats_.channel_message_counts[channel_id];
  if (chunk_.size() >= options_.chunk_size) flush_chunk();
}

void McapWriter::flush_chunk() {
  if (chunk_index_.empty()) return;
  McapChunkIndex index;
  index.message_start_time = chunk_start_time_;
  index.message_end_time = chunk_end_time_;
  index.uncompressed_size = chunk_.size();
  const std::uint32_t uncompressed_crc = fmt::crc32(0, chunk_.data(), chunk_.size());
  const std::uint8_t* records = chunk_.data();
  std::size_t records_size = chunk_.size();
  if (options_.compression == McapCompression::zstd) {
    index.compression = "zstd";
    compressed_.resize(ZSTD_compressBound(chunk_.size()));
    const std::size_t n = ZSTD_compressCCtx(zstd_->cctx, compressed_.data(), compressed_.size(),
                                            chunk_.data(), chunk_.size(), options_.zstd_level);
    if (ZSTD_isError(n)) fail(std::string("zstd compression failed: ") + ZSTD_getErrorName(n));
    records = compressed_.data();
    records_size = n;
  }
  index.compressed_size = records_size;

  std::vector<std::uint8_t> head;
  fmt::Out out(head);
  out.u64(index.message_start_time);
  out.u64(index.message_end_time);
  out.u64(index.uncompressed_size);
  out.u32(uncompressed_crc);
  out.string(index.compression);
  out.u64(records_size);
  const std::uint64_t content_size = head.size() + records_size;
  index.chunk_start_offset = offset_;
  std::vector<std::uint8_t> record_head;
  fmt::Out rh(record_head);
  rh.u8(fmt::kChunk);
  rh.u64(content_size);
  put(record_head.data(), record_head.size());
  put(head.data(), head.size());
  put(records, records_size);
  index.chunk_length = offset_ - index.chunk_start_offset;

  // One Message Index per channel of the chunk, right after it.
  const std::uint64_t indexes_start = offset_;
  for (const auto& [channel, entries] : chunk_index_) {
    index.message_index_offsets[channel] = offset_;
    std::vector<std::uint8_t> content;
    fmt::Out mi(content);
    mi.u16(channel);
    mi.u32(static_cast<std::uint32_t>(entries.size() * 16));
    for (const auto& [log_time, at] : entries) {
      mi.u64(log_time);
      mi.u64(at);
    }
    put_record(fmt::kMessageIndex, content);
  }
  index.message_index_length = offset_ - indexes_start;
  chunk_indexes_.push_back(std::move(index));
  ++stats_.chunk_count;
  chunk_.clear();
  chunk_index_.clear();
}

void McapWriter::close() {
  if (closed_) return;
  closed_ = true;
  flush_chunk();
  // Data End carries the CRC of every byte before it (magic and Header included).
  const std::uint32_t data_crc = data_crc_;
  data_ended_ = true;
  std::vector<std::uint8_t> data_end;
  fmt::Out(data_end).u32(data_crc);
  put_record(fmt::kDataEnd, data_end);

  stats_.schema_count = static_cast<std::uint16_t>(schemas_.size());
  stats_.channel_count = static_cast<std::uint32_t>(channels_.size());
  const std::uint64_t summary_start = offset_;
  in_summary_ = true;
  struct Group {
    std::uint8_t opcode;
    std::uint64_t start, length;
  };
  std::vector<Group> groups;
  const auto group = [&](std::uint8_t opcode, const std::vector<std::vector<std::uint8_t>>& items) {
    if (items.empty()) return;
    const std::uint64_t start = offset_;
    for (const auto& content : items) put_record(opcode, content);
    groups.push_back({opcode, start, offset_ - start});
  };
  std::vector<std::vector<std::uint8_t>> items;
  for (const auto& schema : schemas_) items.push_back(schema_content(schema));
  group(fmt::kSchema, items);
  items.clear();
  for (const auto& channel : channels_) items.push_back(channel_content(channel));
  group(fmt::kChannel, items);
  items.clear();
  for (const auto& index : chunk_indexes_) {
    std::vector<std::uint8_t> content;
    fmt::Out out(content);
    out.u64(index.message_start_time);
    out.u64(index.message_end_time);
    out.u64(index.chunk_start_offset);
    out.u64(index.chunk_length);
    out.u16_u64_map(index.message_index_offsets);
    out.u64(index.message_index_length);
    out.string(index.compression);
    out.u64(index.compressed_size);
    out.u64(index.uncompressed_size);
    items.push_back(std::move(content));
  }
  group(fmt::kChunkIndex, items);
  items.clear();
  {
    std::vector<std::uint8_t> content;
    fmt::Out out(content);
    out.u64(stats_.message_count);
    out.u16(stats_.schema_count);
    out.u32(stats_.channel_count);
    out.u32(stats_.attachment_count);
    out.u32(stats_.metadata_count);
    out.u32(stats_.chunk_count);
    out.u64(stats_.message_start_time);
    out.u64(stats_.message_end_time);
    out.u16_u64_map(stats_.channel_message_counts);
    items.push_back(std::move(content));
  }
  group(fmt::kStatistics, items);

  const std::uint64_t summary_offset_start = offset_;
  for (const Group& g : groups) {
    std::vector<std::uint8_t> content;
    fmt::Out out(content);
    out.u8(g.opcode);
    out.u64(g.start);
    out.u64(g.length);
    put_record(fmt::kSummaryOffset, content);
  }
  // The summary CRC runs through the Footer's summary_offset_start field.
  std::vector<std::uint8_t> footer;
  fmt::Out out(footer);
  out.u8(fmt::kFooter);
  out.u64(fmt::kFooterContentSize);
  out.u64(summary_start);
  out.u64(summary_offset_start);
  put(footer.data(), footer.size());
  in_summary_ = false;
  std::vector<std::uint8_t> tail;
  fmt::Out(tail).u32(summary_crc_);
  put(tail.data(), tail.size());
  put(fmt::kMagic, sizeof(fmt::kMagic));
  const bool flushed = std::fflush(file_) == 0;
  const bool closed = std::fclose(file_) == 0;
  file_ = nullptr;
  if (!flushed || !closed) fail(std::string("closing failed: ") + std::strerror(errno));
}

}  // namespace thermovis::record
