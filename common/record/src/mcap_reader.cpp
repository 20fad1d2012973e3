#include <zstd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <set>
#include <sstream>

#include "mcap_format.hpp"
#include "thermovis/record/mcap.hpp"

namespace thermovis::record {

namespace fmt = mcap_format;

namespace {

// A chunk is decompressed whole: a corrupt uncompressed_size must not ask for terabytes.
constexpr std::uint64_t kMaxChunkBytes = 4ull << 30;

std::string hex32(std::uint32_t v) {
  std::ostringstream s;
  s << "0x" << std::hex << v;
  return s.str();
}

McapSchema parse_schema(fmt::In& in) {
  McapSchema s;
  s.id = in.u16();
  s.name = in.string("schema name");
  s.encoding = in.string("schema encoding");
  s.data = in.string("schema data");
  return s;
}

McapChannel parse_channel(fmt::In& in) {
  McapChannel c;
  c.id = in.u16();
  c.schema_id = in.u16();
  c.topic = in.string("channel topic");
  c.message_encoding = in.string("channel message encoding");
  c.metadata = in.string_map("channel metadata");
  return c;
}

McapChunkIndex parse_chunk_index(fmt::In& in) {
  McapChunkIndex c;
  c.message_start_time = in.u64();
  c.message_end_time = in.u64();
  c.chunk_start_offset = in.u64();
  c.chunk_length = in.u64();
  c.message_index_offsets = in.u16_u64_map("message index offsets");
  c.message_index_length = in.u64();
  c.compression = in.string("compression");
  c.compressed_size = in.u64();
  c.uncompressed_size = in.u64();
  return c;
}

bool same(const McapSchema& a, const McapSchema& b) {
  return a.id == b.id && a.name == b.name && a.encoding == b.encoding && a.data == b.data;
}
bool same(const McapChannel& a, const McapChannel& b) {
  return a.id == b.id && a.schema_id == b.schema_id && a.topic == b.topic &&
         a.message_encoding == b.message_encoding && a.metadata == b.metadata;
}

}  // namespace

// Bookkeeping of validate(): what the data section holds, to compare with its indexes.
struct McapReader::Scan {
  McapValidation result;
  McapStatistics counted;
  std::set<std::uint16_t> schema_ids;
  std::set<std::uint16_t> channel_ids;
  std::vector<McapChunkIndex> chunks;  // as found in the data section
  bool after_chunk = false;            // only Message Index records since the last chunk
  // Messages of the last chunk: channel -> offset in its records -> log_time.
  std::map<std::uint16_t, std::map<std::uint64_t, std::uint64_t>> chunk_messages;
};

McapReader::McapReader(const std::filesystem::path& path) : path_(path) {
  file_ = std::fopen(path_.c_str(), "rb");
  if (file_ == nullptr) throw McapError(path_.string() + ": cannot open: " + std::strerror(errno));
  std::error_code ec;
  size_ = std::filesystem::file_size(path_, ec);
  if (ec) throw McapError(path_.string() + ": cannot read its size: " + ec.message());
  constexpr std::uint64_t kMinimum =
      2 * sizeof(fmt::kMagic) + fmt::kRecordHeaderSize + 8 + fmt::kFooterRecordSize;
  std::uint8_t magic[8];
  if (size_ >= 8) read_at(0, magic, 8);
  if (size_ < 8 || std::memcmp(magic, fmt::kMagic, 5) != 0)
    fail("not an MCAP file (it does not start with the MCAP magic)", 0);
  if (magic[5] != fmt::kMagic[5] || std::memcmp(magic + 6, fmt::kMagic + 6, 2) != 0)
    fail("MCAP major version '" + std::string(1, static_cast<char>(magic[5])) +
             "' is not supported (only '0')",
         5);
  if (size_ < kMinimum) {
    fail("truncated: " + std::to_string(size_) + " bytes, less than the smallest MCAP file (" +
             std::to_string(kMinimum) + ")",
         size_);
  }
  read_at(size_ - 8, magic, 8);
  if (std::memcmp(magic, fmt::kMagic, 8) != 0) {
    fail(
        "truncated: the file does not end with the MCAP magic (a recording that was not closed, "
        "or a partial copy)",
        size_ - 8);
  }
  // Header, first record after the magic.
  std::uint8_t head[fmt::kRecordHeaderSize];
  read_at(8, head, sizeof(head));
  if (head[0] != fmt::kHeader)
    fail(std::string("the first record is a ") + fmt::opcode_name(head[0]) + ", not a Header", 8);
  const std::uint64_t header_length = fmt::load_u64(head + 1);
  if (header_length > size_ - 8 - fmt::kRecordHeaderSize - fmt::kFooterRecordSize - 8)
    fail("Header record length " + std::to_string(header_length) + " runs past the Footer", 8);
  std::vector<std::uint8_t> content(header_length);
  read_at(8 + fmt::kRecordHeaderSize, content.data(), content.size());
  try {
    fmt::In in(content.data(), content.size());
    profile_ = in.string("profile");
    library_ = in.string("library");
  } catch (const fmt::ShortRecord& e) {
    fail(std::string("Header: ") + e.what(), 8);
  }
  // Footer, last record before the closing magic.
  footer_offset_ = size_ - 8 - fmt::kFooterRecordSize;
  std::uint8_t footer[fmt::kFooterRecordSize];
  read_at(footer_offset_, footer, sizeof(footer));
  if (footer[0] != fmt::kFooter || fmt::load_u64(footer + 1) != fmt::kFooterContentSize) {
    fail("no Footer record before the closing magic (corrupt end of file)", footer_offset_);
  }
  fmt::In in(footer + fmt::kRecordHeaderSize, fmt::kFooterContentSize);
  summary_start_ = in.u64();
  const std::uint64_t summary_offset_start = in.u64();
  const std::uint32_t summary_crc = in.u32();
  const std::uint64_t data_start = 8 + fmt::kRecordHeaderSize + header_length;
  if (summary_start_ != 0 && (summary_start_ < data_start || summary_start_ > footer_offset_))
    fail("Footer: summary_start " + std::to_string(summary_start_) + " outside the file's records",
         footer_offset_);
  if (summary_offset_start != 0 && (summary_offset_start < std::max(data_start, summary_start_) ||
                                    summary_offset_start > footer_offset_)) {
    fail("Footer: summary_offset_start " + std::to_string(summary_offset_start) +
             " outside the summary",
         footer_offset_);
  }
  if (summary_crc != 0) {
    // From the start of the summary (or of what follows the data section) through the Footer's
    // summary_offset_start field.
    std::uint64_t from = summary_start_ != 0         ? summary_start_
                         : summary_offset_start != 0 ? summary_offset_start
                                                     : footer_offset_;
    const std::uint64_t to = footer_offset_ + fmt::kRecordHeaderSize + 16;
    std::uint32_t crc = 0;
    std::vector<std::uint8_t> block(1u << 20);
    while (from < to) {
      const std::size_t n =
          static_cast<std::size_t>(std::min<std::uint64_t>(block.size(), to - from));
      read_at(from, block.data(), n);
      crc = fmt::crc32(crc, block.data(), n);
      from += n;
    }
    if (crc != summary_crc) {
      fail("summary CRC mismatch (Footer says " + hex32(summary_crc) + ", the bytes give " +
               hex32(crc) + "): the summary section is corrupt",
           summary_start_);
    }
    summary_crc_checked_ = true;
  }
  if (summary_start_ != 0) {
    read_summary(summary_start_, summary_offset_start != 0 ? summary_offset_start : footer_offset_);
  }
  // Summary Offset records: each names a group of summary records by opcode.
  if (summary_offset_start != 0) {
    std::uint64_t at = summary_offset_start;
    while (at < footer_offset_) {
      if (footer_offset_ - at < fmt::kRecordHeaderSize)
        fail("record header runs into the Footer", at);
      read_at(at, head, sizeof(head));
      const std::uint64_t length = fmt::load_u64(head + 1);
      if (head[0] != fmt::kSummaryOffset)
        fail(
            std::string("a ") + fmt::opcode_name(head[0]) + " record in the summary offset section",
            at);
      if (length < 17 || length > footer_offset_ - at - fmt::kRecordHeaderSize)
        fail("Summary Offset record of " + std::to_string(length) + " bytes", at);
      std::uint8_t body[17];
      read_at(at + fmt::kRecordHeaderSize, body, sizeof(body));
      fmt::In so(body, sizeof(body));
      const std::uint8_t group_opcode = so.u8();
      const std::uint64_t group_start = so.u64(), group_length = so.u64();
      std::uint8_t first = 0;
      if (group_start < summary_start_ || group_start + group_length > summary_offset_start ||
          group_length < fmt::kRecordHeaderSize ||
          (read_at(group_start, &first, 1), first) != group_opcode) {
        fail(std::string("Summary Offset for the ") + fmt::opcode_name(group_opcode) +
                 " group points at bytes " + std::to_string(group_start) + "+" +
                 std::to_string(group_length) + ", which do not start such a group",
             at);
      }
      at += fmt::kRecordHeaderSize + length;
    }
  }
  schemas_ = summary_schemas_;
  channels_ = summary_channels_;
}

McapReader::~McapReader() {
  if (file_ != nullptr) std::fclose(file_);
}

void McapReader::fail(const std::string& what, std::uint64_t offset) const {
  throw McapError(path_.string() + ": " + what + " (at byte " + std::to_string(offset) + ")");
}

void McapReader::read_at(std::uint64_t offset, void* into, std::size_t size) const {
  if (offset > size_ || size > size_ - offset) {
    fail("unexpected end of file: " + std::to_string(size) + " bytes needed, " +
             std::to_string(offset > size_ ? 0 : size_ - offset) + " left (truncated)",
         offset);
  }
  if (fseeko(file_, static_cast<off_t>(offset), SEEK_SET) != 0 ||
      std::fread(into, 1, size, file_) != size) {
    fail(std::string("read error: ") + std::strerror(errno), offset);
  }
}

void McapReader::read_summary(std::uint64_t summary_start, std::uint64_t summary_end) {
  std::set<std::uint8_t> groups_done;
  std::uint8_t group = 0;
  std::vector<std::uint8_t> content;
  for (std::uint64_t at = summary_start; at < summary_end;) {
    if (summary_end - at < fmt::kRecordHeaderSize) fail("summary ends inside a record header", at);
    std::uint8_t head[fmt::kRecordHeaderSize];
    read_at(at, head, sizeof(head));
    const std::uint8_t opcode = head[0];
    const std::uint64_t length = fmt::load_u64(head + 1);
    if (length > summary_end - at - fmt::kRecordHeaderSize) {
      fail(std::string(fmt::opcode_name(opcode)) + " record of " + std::to_string(length) +
               " bytes runs past the end of the summary section",
           at);
    }
    if (opcode != group) {
      if (groups_done.count(opcode) != 0)
        fail("summary records are not grouped by opcode (a second group of " +
                 std::string(fmt::opcode_name(opcode)) + " records)",
             at);
      groups_done.insert(group);
      group = opcode;
    }
    content.resize(length);
    read_at(at + fmt::kRecordHeaderSize, content.data(), content.size());
    fmt::In in(content.data(), content.size());
    try {
      switch (opcode) {
        case fmt::kSchema: {
          McapSchema s = parse_schema(in);
          if (s.id != 0) summary_schemas_[s.id] = std::move(s);
          break;
        }
        case fmt::kChannel: {
          McapChannel c = parse_channel(in);
          if (c.schema_id != 0 && summary_schemas_.count(c.schema_id) == 0)
            fail("summary Channel " + std::to_string(c.id) + " refers to schema " +
                     std::to_string(c.schema_id) + ", absent from the summary",
                 at);
          summary_channels_[c.id] = std::move(c);
          break;
        }
        case fmt::kChunkIndex:
          chunk_indexes_.push_back(parse_chunk_index(in));
          break;
        case fmt::kStatistics: {
          if (has_statistics_) fail("a second Statistics record", at);
          has_statistics_ = true;
          McapStatistics& s = statistics_;
          s.message_count = in.u64();
          s.schema_count = in.u16();
          s.channel_count = in.u32();
          s.attachment_count = in.u32();
          s.metadata_count = in.u32();
          s.chunk_count = in.u32();
          s.message_start_time = in.u64();
          s.message_end_time = in.u64();
          s.channel_message_counts = in.u16_u64_map("channel message counts");
          break;
        }
        case fmt::kAttachmentIndex:
        case fmt::kMetadataIndex:
          break;  // this reader does not use attachments or metadata
        default:
          if (opcode < 0x10)
            fail(std::string("a ") + fmt::opcode_name(opcode) + " record in the summary section",
                 at);
          break;  // a future or private record: skipped
      }
    } catch (const fmt::ShortRecord& e) {
      fail(std::string(fmt::opcode_name(opcode)) + " record: " + e.what(), at);
    }
    at += fmt::kRecordHeaderSize + length;
  }
}

const McapChannel* McapReader::channel(const std::string& topic) const {
  for (const auto& [id, c] : channels_) {
    if (c.topic == topic) return &c;
  }
  return nullptr;
}

void McapReader::read_messages(const std::function<bool(const McapMessageView&)>& on_message) {
  scan(on_message, nullptr);
}

// One pass over the data section, in file order. run() frames each record and hands it to the
// handler of its opcode; a handler that returns false ends the pass (the caller wants no more
// messages). Offsets (`at`) are bytes from the start of the file and name the record in errors.
class McapReader::DataPass {
 public:
  DataPass(McapReader& reader, const std::function<bool(const McapMessageView&)>& on_message,
           Scan* check)
      : r_(reader), on_message_(on_message), check_(check) {}
  ~DataPass() { ZSTD_freeDCtx(dctx_); }
  DataPass(const DataPass&) = delete;
  DataPass& operator=(const DataPass&) = delete;

  void run();

 private:
  // `content` is the record's body, `length` its size in bytes (without the record header).
  bool dispatch(std::uint8_t opcode, fmt::In& content, std::uint64_t at, std::uint64_t length,
                bool was_after_chunk);
  void on_data_end(fmt::In& content, std::uint64_t at, std::uint64_t length);
  // A Schema or Channel record, in the data section or inside a chunk; false for any other.
  bool on_definition(std::uint8_t opcode, fmt::In& content, std::uint64_t at);
  void on_schema(McapSchema s, std::uint64_t at);
  void on_channel(McapChannel c, std::uint64_t at);
  bool on_message(fmt::In& content, std::uint64_t at);
  bool on_chunk(fmt::In& content, std::uint64_t at, std::uint64_t length);
  // The chunk's records, uncompressed (in place when stored uncompressed).
  const std::uint8_t* chunk_records(const McapChunkIndex& chunk, const std::uint8_t* stored,
                                    std::uint64_t at);
  // One record inside a chunk; `inner_at` is its offset in the uncompressed records.
  bool on_chunk_record(std::uint8_t opcode, fmt::In& record, const McapChunkIndex& chunk,
                       std::uint64_t inner_at, std::uint64_t at);
  void on_message_index(fmt::In& content, std::uint64_t at, std::uint64_t length,
                        bool was_after_chunk);

  McapReader& r_;
  const std::function<bool(const McapMessageView&)>& on_message_;
  Scan* check_;            // nullptr when only reading messages
  std::uint32_t crc_ = 0;  // of the data section so far, from the start of the file
  std::vector<std::uint8_t> content_, records_;
  ZSTD_DCtx* dctx_ = nullptr;
};

void McapReader::DataPass::run() {
  std::uint8_t head[fmt::kRecordHeaderSize];
  r_.read_at(8, head, sizeof(head));
  std::uint64_t at = 8 + fmt::kRecordHeaderSize + fmt::load_u64(head + 1);
  std::vector<std::uint8_t> prefix(at);
  r_.read_at(0, prefix.data(), prefix.size());
  crc_ = fmt::crc32(0, prefix.data(), prefix.size());
  const std::uint64_t footer = r_.footer_offset_;
  for (;;) {
    if (at >= footer || footer - at < fmt::kRecordHeaderSize)
      r_.fail("no Data End record: the data section runs into the Footer", at);
    r_.read_at(at, head, sizeof(head));
    const std::uint8_t opcode = head[0];
    const std::uint64_t length = fmt::load_u64(head + 1);
    const char* name = fmt::opcode_name(opcode);
    if (length > footer - at - fmt::kRecordHeaderSize) {
      r_.fail(std::string(name) + " record claims " + std::to_string(length) + " bytes, only " +
                  std::to_string(footer - at - fmt::kRecordHeaderSize) +
                  " remain before the Footer: truncated or corrupt",
              at);
    }
    content_.resize(length);
    r_.read_at(at + fmt::kRecordHeaderSize, content_.data(), content_.size());
    fmt::In in(content_.data(), content_.size());
    if (opcode == fmt::kDataEnd) {
      on_data_end(in, at, length);
      return;
    }
    // The Data End record itself is outside the data section's CRC.
    crc_ = fmt::crc32(crc_, head, sizeof(head));
    crc_ = fmt::crc32(crc_, content_.data(), content_.size());
    const bool was_after_chunk = check_ != nullptr && check_->after_chunk;
    if (check_ != nullptr && opcode != fmt::kMessageIndex) check_->after_chunk = false;
    try {
      if (!dispatch(opcode, in, at, length, was_after_chunk)) return;
    } catch (const fmt::ShortRecord& e) {
      r_.fail(std::string(name) + " record: " + e.what(), at);
    }
    at += fmt::kRecordHeaderSize + length;
  }
}

bool McapReader::DataPass::dispatch(std::uint8_t opcode, fmt::In& content, std::uint64_t at,
                                    std::uint64_t length, bool was_after_chunk) {
  if (on_definition(opcode, content, at)) return true;
  switch (opcode) {
    case fmt::kMessage:
      return on_message(content, at);
    case fmt::kChunk:
      return on_chunk(content, at, length);
    case fmt::kMessageIndex:
      if (check_ != nullptr) on_message_index(content, at, length, was_after_chunk);
      return true;
    case fmt::kAttachment:
      if (check_ != nullptr) ++check_->counted.attachment_count;
      return true;
    case fmt::kMetadata:
      if (check_ != nullptr) ++check_->counted.metadata_count;
      return true;
    default:
      if (opcode < 0x10)
        r_.fail(std::string("a ") + fmt::opcode_name(opcode) + " record in the data section", at);
      return true;  // a future or private record: skipped
  }
}

void McapReader::DataPass::on_data_end(fmt::In& content, std::uint64_t at, std::uint64_t length) {
  std::uint32_t recorded = 0;
  try {
    recorded = content.u32();
  } catch (const fmt::ShortRecord& e) {
    r_.fail(std::string("Data End: ") + e.what(), at);
  }
  if (recorded != 0) {
    if (recorded != crc_)
      r_.fail("data section CRC mismatch (Data End says " + hex32(recorded) + ", the bytes give " +
                  hex32(crc_) + "): the data section is corrupt",
              at);
    if (check_ != nullptr) check_->result.data_crc_checked = true;
  }
  const std::uint64_t end = at + fmt::kRecordHeaderSize + length;
  if (r_.summary_start_ != 0 && end != r_.summary_start_)
    r_.fail("the data section ends at byte " + std::to_string(end) +
                " but the Footer starts the summary at byte " + std::to_string(r_.summary_start_),
            at);
}

bool McapReader::DataPass::on_definition(std::uint8_t opcode, fmt::In& content, std::uint64_t at) {
  if (opcode == fmt::kSchema) {
    on_schema(parse_schema(content), at);
  } else if (opcode == fmt::kChannel) {
    on_channel(parse_channel(content), at);
  } else {
    return false;
  }
  return true;
}

void McapReader::DataPass::on_schema(McapSchema s, std::uint64_t at) {
  if (s.id == 0) return;  // invalid by the specification: ignored
  const auto it = r_.schemas_.find(s.id);
  if (it != r_.schemas_.end() && !same(it->second, s))
    r_.fail("Schema " + std::to_string(s.id) + " recorded twice with different contents", at);
  if (check_ != nullptr) check_->schema_ids.insert(s.id);
  r_.schemas_[s.id] = std::move(s);
}

void McapReader::DataPass::on_channel(McapChannel c, std::uint64_t at) {
  if (c.schema_id != 0 && r_.schemas_.count(c.schema_id) == 0)
    r_.fail("Channel " + std::to_string(c.id) + " ('" + c.topic + "') refers to schema " +
                std::to_string(c.schema_id) + " before any Schema record defines it",
            at);
  const auto it = r_.channels_.find(c.id);
  if (it != r_.channels_.end() && !same(it->second, c))
    r_.fail("Channel " + std::to_string(c.id) + " recorded twice with different contents", at);
  if (check_ != nullptr) check_->channel_ids.insert(c.id);
  r_.channels_[c.id] = std::move(c);
}

bool McapReader::DataPass::on_message(fmt::In& content, std::uint64_t at) {
  McapMessageView m;
  m.channel_id = content.u16();
  m.sequence = content.u32();
  m.log_time = content.u64();
  m.publish_time = content.u64();
  m.size = content.remaining();
  m.data = content.bytes(m.size, "message data");
  if (r_.channels_.count(m.channel_id) == 0)
    r_.fail("Message on channel " + std::to_string(m.channel_id) +
                " before any Channel record defines it",
            at);
  if (check_ != nullptr) {
    McapStatistics& s = check_->counted;
    if (s.message_count == 0) s.message_start_time = s.message_end_time = m.log_time;
    ++s.message_count;
    s.message_start_time = std::min(s.message_start_time, m.log_time);
    s.message_end_time = std::max(s.message_end_time, m.log_time);
    ++s.channel_message_counts[m.channel_id];
  }
  return on_message_ ? on_message_(m) : true;
}

bool McapReader::DataPass::on_chunk(fmt::In& content, std::uint64_t at, std::uint64_t length) {
  McapChunkIndex found;
  found.chunk_start_offset = at;
  found.chunk_length = fmt::kRecordHeaderSize + length;
  found.message_start_time = content.u64();
  found.message_end_time = content.u64();
  found.uncompressed_size = content.u64();
  const std::uint32_t uncompressed_crc = content.u32();
  found.compression = content.string("compression");
  const std::uint64_t records_size = content.u64();
  if (records_size != content.remaining())
    r_.fail("Chunk records field says " + std::to_string(records_size) +
                " bytes, the record holds " + std::to_string(content.remaining()),
            at);
  found.compressed_size = records_size;
  const std::uint8_t* stored = content.bytes(records_size, "chunk records");
  const std::uint8_t* plain = chunk_records(found, stored, at);
  if (uncompressed_crc != 0) {
    const std::uint32_t actual = fmt::crc32(0, plain, found.uncompressed_size);
    if (actual != uncompressed_crc)
      r_.fail("Chunk CRC mismatch (the chunk says " + hex32(uncompressed_crc) +
                  ", its records give " + hex32(actual) + "): the chunk is corrupt",
              at);
  }
  if (check_ != nullptr) {
    check_->chunk_messages.clear();
    check_->after_chunk = true;
    ++check_->result.chunks;
    ++check_->counted.chunk_count;
  }
  fmt::In inner(plain, found.uncompressed_size);
  while (inner.remaining() > 0) {
    const std::uint64_t inner_at = inner.position();
    const std::uint8_t inner_opcode = inner.u8();
    const std::uint64_t inner_length = inner.u64();
    if (inner_length > inner.remaining())
      r_.fail("a " + std::string(fmt::opcode_name(inner_opcode)) +
                  " record inside the chunk runs past its end (chunk byte " +
                  std::to_string(inner_at) + ")",
              at);
    fmt::In record(inner.bytes(inner_length, "record"), inner_length);
    if (!on_chunk_record(inner_opcode, record, found, inner_at, at)) return false;
  }
  if (check_ != nullptr) check_->chunks.push_back(std::move(found));
  return true;
}

const std::uint8_t* McapReader::DataPass::chunk_records(const McapChunkIndex& chunk,
                                                        const std::uint8_t* stored,
                                                        std::uint64_t at) {
  if (chunk.uncompressed_size > kMaxChunkBytes)
    r_.fail("Chunk claims " + std::to_string(chunk.uncompressed_size) +
                " uncompressed bytes: corrupt (more than 4 GiB)",
            at);
  if (chunk.compression.empty()) {
    if (chunk.compressed_size != chunk.uncompressed_size)
      r_.fail("uncompressed Chunk of " + std::to_string(chunk.compressed_size) + " bytes says " +
                  std::to_string(chunk.uncompressed_size),
              at);
    return stored;
  }
  if (chunk.compression != "zstd")
    r_.fail("Chunk compression '" + chunk.compression +
                "' is not supported by this reader (zstd or none)",
            at);
  if (dctx_ == nullptr) dctx_ = ZSTD_createDCtx();
  records_.resize(chunk.uncompressed_size);
  const std::size_t n =
      ZSTD_decompressDCtx(dctx_, records_.data(), records_.size(), stored, chunk.compressed_size);
  if (ZSTD_isError(n))
    r_.fail(std::string("Chunk: zstd cannot decompress its records: ") + ZSTD_getErrorName(n), at);
  if (n != chunk.uncompressed_size)
    r_.fail("Chunk: decompressed " + std::to_string(n) + " bytes, the chunk says " +
                std::to_string(chunk.uncompressed_size),
            at);
  return records_.data();
}

bool McapReader::DataPass::on_chunk_record(std::uint8_t opcode, fmt::In& record,
                                           const McapChunkIndex& chunk, std::uint64_t inner_at,
                                           std::uint64_t at) {
  if (on_definition(opcode, record, at)) return true;
  switch (opcode) {
    case fmt::kMessage: {
      fmt::In peek = record;
      const std::uint16_t channel = peek.u16();
      peek.u32();
      const std::uint64_t log_time = peek.u64();
      if (log_time < chunk.message_start_time || log_time > chunk.message_end_time)
        r_.fail("a message logged at " + std::to_string(log_time) +
                    " lies outside its chunk's time range",
                at);
      if (check_ != nullptr) check_->chunk_messages[channel][inner_at] = log_time;
      return on_message(record, at);
    }
    default:
      r_.fail(std::string("a ") + fmt::opcode_name(opcode) +
                  " record inside a chunk (chunks hold Schema, Channel and Message records)",
              at);
  }
}

void McapReader::DataPass::on_message_index(fmt::In& content, std::uint64_t at,
                                            std::uint64_t length, bool was_after_chunk) {
  if (!was_after_chunk) r_.fail("a Message Index that does not follow a Chunk", at);
  const std::uint16_t channel = content.u16();
  const std::uint32_t bytes = content.u32();
  if (bytes % 16 != 0 || bytes != content.remaining())
    r_.fail("Message Index entries of " + std::to_string(bytes) + " bytes", at);
  auto& messages = check_->chunk_messages[channel];
  std::size_t entries = 0;
  while (content.remaining() > 0) {
    const std::uint64_t log_time = content.u64();
    const std::uint64_t offset = content.u64();
    const auto it = messages.find(offset);
    if (it == messages.end() || it->second != log_time)
      r_.fail("Message Index of channel " + std::to_string(channel) + " points at chunk byte " +
                  std::to_string(offset) + ", where no message of that channel and time is",
              at);
    ++entries;
  }
  if (entries != messages.size())
    r_.fail("Message Index of channel " + std::to_string(channel) + " lists " +
                std::to_string(entries) + " messages, its chunk holds " +
                std::to_string(messages.size()),
            at);
  McapChunkIndex& chunk = check_->chunks.back();
  chunk.message_index_offsets[channel] = at;
  chunk.message_index_length += fmt::kRecordHeaderSize + length;
  check_->after_chunk = true;
  ++check_->result.message_indexes;
}

void McapReader::scan(const std::function<bool(const McapMessageView&)>& on_message, Scan* check) {
  DataPass(*this, on_message, check).run();
}

McapValidation McapReader::validate() {
  Scan check;
  scan({}, &check);
  check.result.messages = check.counted.message_count;
  check.result.summary_crc_checked = summary_crc_checked_;
  const auto mismatch = [&](const std::string& what) {
    throw McapError(path_.string() + ": " + what);
  };
  if (has_statistics_) {
    const McapStatistics& s = statistics_;
    const McapStatistics& c = check.counted;
    const auto expect = [&](const char* field, std::uint64_t recorded, std::uint64_t counted) {
      if (recorded != counted)
        mismatch(std::string("Statistics ") + field + " is " + std::to_string(recorded) +
                 ", the data section has " + std::to_string(counted));
    };
    expect("message_count", s.message_count, c.message_count);
    expect("schema_count", s.schema_count, check.schema_ids.size());
    expect("channel_count", s.channel_count, check.channel_ids.size());
    expect("chunk_count", s.chunk_count, c.chunk_count);
    expect("attachment_count", s.attachment_count, c.attachment_count);
    expect("metadata_count", s.metadata_count, c.metadata_count);
    expect("message_start_time", s.message_start_time, c.message_start_time);
    expect("message_end_time", s.message_end_time, c.message_end_time);
    if (!s.channel_message_counts.empty()) {
      for (const auto& [id, n] : c.channel_message_counts)
        if (s.channel_message_counts.count(id) == 0 || s.channel_message_counts.at(id) != n)
          mismatch("Statistics count of channel " + std::to_string(id) + " differs from its " +
                   std::to_string(n) + " messages");
      if (s.channel_message_counts.size() != c.channel_message_counts.size())
        mismatch("Statistics counts messages on channels that have none");
    }
  }
  if (!chunk_indexes_.empty() || summary_start_ != 0) {
    if (chunk_indexes_.size() != check.chunks.size() && !chunk_indexes_.empty())
      mismatch("the summary indexes " + std::to_string(chunk_indexes_.size()) +
               " chunks, the data section has " + std::to_string(check.chunks.size()));
    for (std::size_t i = 0; i < chunk_indexes_.size(); ++i) {
      const McapChunkIndex& a = chunk_indexes_[i];
      const McapChunkIndex& b = check.chunks[i];
      const bool indexes_match =
          a.message_index_offsets.empty() || (a.message_index_offsets == b.message_index_offsets &&
                                              a.message_index_length == b.message_index_length);
      if (a.chunk_start_offset != b.chunk_start_offset || a.chunk_length != b.chunk_length ||
          a.message_start_time != b.message_start_time ||
          a.message_end_time != b.message_end_time || a.compression != b.compression ||
          a.compressed_size != b.compressed_size || a.uncompressed_size != b.uncompressed_size ||
          !indexes_match)
        mismatch("Chunk Index " + std::to_string(i) + " does not describe the chunk at byte " +
                 std::to_string(b.chunk_start_offset));
    }
    // The summary repeats every schema and channel that messages use.
    for (const auto& [id, n] : check.counted.channel_message_counts) {
      (void)n;
      const auto it = summary_channels_.find(id);
      if (it == summary_channels_.end() || !same(it->second, channels_.at(id)))
        mismatch("the summary does not repeat channel " + std::to_string(id) + " ('" +
                 channels_.at(id).topic + "')");
      const std::uint16_t schema = it->second.schema_id;
      if (schema != 0 && (summary_schemas_.count(schema) == 0 ||
                          !same(summary_schemas_.at(schema), schemas_.at(schema))))
        mismatch("the summary does not repeat schema " + std::to_string(schema));
    }
  }
  return check.result;
}

}  // namespace thermovis::record
