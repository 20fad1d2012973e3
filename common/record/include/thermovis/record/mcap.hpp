#pragma once
// MCAP files (https://mcap.dev/spec, major version 0): the log format of Foxglove and of ROS 2
// bags. A writer that streams messages into zstd-compressed chunks with message indexes, and
// writes the summary section (schemas, channels, chunk indexes, statistics, summary offsets)
// and CRCs that indexed readers use; a reader that checks the whole structure as it goes.
//
// Times are uint64 nanoseconds (thermovis uses the Unix epoch, transport/clock.hpp). Message
// bytes are opaque here: thermovis writes the CDR serialized payload of a DDS sample (message
// encoding "cdr", schema encoding "omgidl" with the IDL text of the type).
//
// No DDS in this library: the recorder and the replayer (services/thermovis) bring the samples.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace thermovis::record {

// A malformed, truncated or unreadable file, or a writer misuse. what() names the file, what is
// wrong and where (byte offset) when it is about file contents.
class McapError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct McapSchema {
  std::uint16_t id = 0;  // 1.. (0 is "no schema")
  std::string name;      // e.g. "thermovis::RangeArray"
  std::string encoding;  // e.g. "omgidl"
  std::string data;      // e.g. the IDL text
};

struct McapChannel {
  std::uint16_t id = 0;
  std::uint16_t schema_id = 0;
  std::string topic;
  std::string message_encoding;  // e.g. "cdr"
  std::map<std::string, std::string> metadata;
};

// One message as the reader hands it out; `data` is valid during the callback only.
struct McapMessageView {
  std::uint16_t channel_id = 0;
  std::uint32_t sequence = 0;
  std::uint64_t log_time = 0;      // when the recorder received it, ns
  std::uint64_t publish_time = 0;  // when its publisher wrote it, ns
  const std::uint8_t* data = nullptr;
  std::size_t size = 0;
};

struct McapStatistics {
  std::uint64_t message_count = 0;
  std::uint16_t schema_count = 0;
  std::uint32_t channel_count = 0;
  std::uint32_t attachment_count = 0;
  std::uint32_t metadata_count = 0;
  std::uint32_t chunk_count = 0;
  std::uint64_t message_start_time = 0;  // earliest log_time, 0 without messages
  std::uint64_t message_end_time = 0;    // latest log_time
  std::map<std::uint16_t, std::uint64_t> channel_message_counts;
};

struct McapChunkIndex {
  std::uint64_t message_start_time = 0;
  std::uint64_t message_end_time = 0;
  std::uint64_t chunk_start_offset = 0;  // file offset of the Chunk record
  std::uint64_t chunk_length = 0;        // whole record: opcode, length and content
  std::map<std::uint16_t, std::uint64_t> message_index_offsets;  // channel -> file offset
  std::uint64_t message_index_length = 0;
  std::string compression;
  std::uint64_t compressed_size = 0;
  std::uint64_t uncompressed_size = 0;
};

enum class McapCompression { none, zstd };

struct McapWriterOptions {
  std::string profile;  // Header profile: "" (none of the well-known ones)
  std::string library = "thermovis";
  McapCompression compression = McapCompression::zstd;
  int zstd_level = 1;  // 1: fastest; raw frames are 6-15 MB each
  // A chunk is closed once its uncompressed records reach this size (a message bigger than it
  // gets a chunk of its own).
  std::size_t chunk_size = 4u << 20;
};

// Writes one MCAP file. Not thread-safe: one thread writes. Messages should come in log_time
// order (readers play them back in file order).
class McapWriter {
 public:
  // Creates (truncates) the file and writes the magic and the Header. Throws McapError.
  McapWriter(const std::filesystem::path& path, const McapWriterOptions& options = {});
  // Closes the file if close() was not called; errors are then lost (call close()).
  ~McapWriter();
  McapWriter(const McapWriter&) = delete;
  McapWriter& operator=(const McapWriter&) = delete;

  // Records a schema and returns its id (1, 2, ...). The record goes into the data section at
  // once and is repeated in the summary.
  std::uint16_t add_schema(const std::string& name, const std::string& encoding,
                           const std::string& data);
  // Records a channel (schema_id 0 or an id from add_schema) and returns its id (0, 1, ...).
  std::uint16_t add_channel(std::uint16_t schema_id, const std::string& topic,
                            const std::string& message_encoding,
                            const std::map<std::string, std::string>& metadata = {});
  // Appends a message on a channel from add_channel. Throws McapError on an unknown channel or a
  // write error.
  void write(std::uint16_t channel_id, std::uint32_t sequence, std::uint64_t log_time,
             std::uint64_t publish_time, const void* data, std::size_t size);
  // Flushes the open chunk and writes Data End (with the data section's CRC), the summary
  // section, the summary offsets, the Footer (with the summary's CRC) and the closing magic.
  // Throws McapError on a write error. Idempotent.
  void close();

  const std::filesystem::path& path() const { return path_; }
  // Bytes in the file so far (the open chunk not included).
  std::uint64_t bytes_written() const { return offset_; }
  const McapStatistics& statistics() const { return stats_; }

 private:
  void put(const void* bytes, std::size_t size);  // to the file, updating offset and CRC
  void put_record(std::uint8_t opcode, const std::vector<std::uint8_t>& content);
  void flush_chunk();
  [[noreturn]] void fail(const std::string& what) const;

  std::filesystem::path path_;
  McapWriterOptions options_;
  std::FILE* file_ = nullptr;
  std::uint64_t offset_ = 0;
  std::uint32_t data_crc_ = 0;     // running CRC32 of the data section
  std::uint32_t summary_crc_ = 0;  // running CRC32 from the summary through the Footer's offsets
  bool data_ended_ = false;
  bool in_summary_ = false;
  bool closed_ = false;
  std::vector<McapSchema> schemas_;
  std::vector<McapChannel> channels_;
  McapStatistics stats_;
  std::vector<McapChunkIndex> chunk_indexes_;
  // The open chunk: its uncompressed records and, per channel, (log_time, offset in them).
  std::vector<std::uint8_t> chunk_;
  std::map<std::uint16_t, std::vector<std::pair<std::uint64_t, std::uint64_t>>> chunk_index_;
  std::uint64_t chunk_start_time_ = 0, chunk_end_time_ = 0;
  std::vector<std::uint8_t> compressed_;  // reused between chunks
  struct ZstdContext;
  std::unique_ptr<ZstdContext> zstd_;
};

// What McapReader::validate() found (it throws McapError on the first structural error).
struct McapValidation {
  std::uint64_t messages = 0;
  std::uint64_t chunks = 0;
  std::uint64_t message_indexes = 0;  // Message Index records checked against their chunk
  bool data_crc_checked = false;      // Data End carried a CRC and it matched
  bool summary_crc_checked = false;   // the Footer carried a CRC and it matched
};

// Reads an MCAP file written by McapWriter or any other conforming writer (uncompressed or
// zstd chunks; lz4 chunks are reported as unsupported). Opening reads the magic at both ends,
// the Footer and the summary section (schemas, channels, statistics, chunk indexes), checking
// the summary CRC. Every error is an McapError naming the file, what is wrong and the offset.
class McapReader {
 public:
  explicit McapReader(const std::filesystem::path& path);
  ~McapReader();
  McapReader(const McapReader&) = delete;
  McapReader& operator=(const McapReader&) = delete;

  const std::filesystem::path& path() const { return path_; }
  std::uint64_t file_size() const { return size_; }
  const std::string& profile() const { return profile_; }
  const std::string& library() const { return library_; }
  // From the summary section (empty when the file has none).
  const std::map<std::uint16_t, McapSchema>& schemas() const { return schemas_; }
  const std::map<std::uint16_t, McapChannel>& channels() const { return channels_; }
  const std::vector<McapChunkIndex>& chunk_indexes() const { return chunk_indexes_; }
  bool has_statistics() const { return has_statistics_; }
  const McapStatistics& statistics() const { return statistics_; }
  // The channel on `topic`, or nullptr.
  const McapChannel* channel(const std::string& topic) const;

  // Reads the data section in file order and calls `on_message` for every message (return
  // false to stop). Schemas and channels met in the data section are added to schemas() and
  // channels(). Checks record framing, chunk sizes and CRCs and, when reading to the end, the
  // data section's CRC.
  void read_messages(const std::function<bool(const McapMessageView&)>& on_message);

  // Reads the whole file and checks it against its own indexes: the data section as in
  // read_messages, every Message Index against the messages of its chunk, every Chunk Index
  // against the chunk and message indexes it points to, the Statistics against the counted
  // messages, channels, schemas and chunks, and that the summary repeats every schema and
  // channel. Throws McapError on the first mismatch.
  McapValidation validate();

 private:
  struct Scan;
  class DataPass;  // one pass over the data section, a handler per record type
  void scan(const std::function<bool(const McapMessageView&)>& on_message, Scan* check);
  void read_at(std::uint64_t offset, void* into, std::size_t size) const;
  [[noreturn]] void fail(const std::string& what, std::uint64_t offset) const;
  void read_summary(std::uint64_t summary_start, std::uint64_t summary_end);

  std::filesystem::path path_;
  std::FILE* file_ = nullptr;
  std::uint64_t size_ = 0;
  std::uint64_t footer_offset_ = 0;
  std::uint64_t summary_start_ = 0;
  std::string profile_, library_;
  std::map<std::uint16_t, McapSchema> schemas_;
  std::map<std::uint16_t, McapChannel> channels_;
  std::map<std::uint16_t, McapSchema> summary_schemas_;
  std::map<std::uint16_t, McapChannel> summary_channels_;
  std::vector<McapChunkIndex> chunk_indexes_;
  bool has_statistics_ = false;
  McapStatistics statistics_;
  bool summary_crc_checked_ = false;
};

}  // namespace thermovis::record
