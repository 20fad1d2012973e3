// The MCAP writer and reader: round trips in both chunk encodings, the byte layout of the
// specification (magic, records, Footer, CRCs) checked against an independent encoding in this
// file, and clear errors for truncated, corrupt and foreign files.
#include <gtest/gtest.h>
#include <zlib.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "thermovis/record/mcap.hpp"
#include "thermovis/test/data.hpp"

namespace {

namespace fs = std::filesystem;
using thermovis::record::McapCompression;
using thermovis::record::McapError;
using thermovis::record::McapMessageView;
using thermovis::record::McapReader;
using thermovis::record::McapWriter;
using thermovis::record::McapWriterOptions;

using Bytes = std::vector<std::uint8_t>;

struct Written {
  std::uint16_t channel;
  std::uint32_t sequence;
  std::uint64_t log_time, publish_time;
  Bytes data;
};

Bytes random_bytes(std::size_t n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  Bytes b(n);
  for (auto& v : b) v = static_cast<std::uint8_t>(rng());
  return b;
}

Bytes read_file(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return Bytes(std::istreambuf_iterator<char>(in), {});
}

void write_file(const fs::path& path, const Bytes& bytes) {
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()),
             static_cast<std::streamsize>(bytes.size()));
}

std::uint64_t u64_at(const Bytes& b, std::size_t at) {
  std::uint64_t v = 0;
  for (int i = 7; i >= 0; --i) v = (v << 8) | b[at + static_cast<std::size_t>(i)];
  return v;
}
std::uint32_t u32_at(const Bytes& b, std::size_t at) {
  std::uint32_t v = 0;
  for (int i = 3; i >= 0; --i) v = (v << 8) | b[at + static_cast<std::size_t>(i)];
  return v;
}

std::vector<Written> read_all(McapReader& reader) {
  std::vector<Written> out;
  reader.read_messages([&](const McapMessageView& m) {
    out.push_back(
        {m.channel_id, m.sequence, m.log_time, m.publish_time, Bytes(m.data, m.data + m.size)});
    return true;
  });
  return out;
}

// Expects `body` to throw an McapError whose message holds the file name and `words`.
template <class F>
void expect_error(F&& body, const fs::path& file, const std::string& words) {
  try {
    body();
    ADD_FAILURE() << "no error for " << file << " (expected '" << words << "')";
  } catch (const McapError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(file.string()), std::string::npos) << what;
    EXPECT_NE(what.find(words), std::string::npos) << what;
  }
}

class Mcap : public ::testing::TestWithParam<McapCompression> {
 protected:
  void SetUp() override { dir_ = thermovis::test::temp_dir("mcap"); }
  void TearDown() override { fs::remove_all(dir_); }

  // Three channels on two schemas: small messages, an empty one, and "frames" larger than the
  // chunk size; log times increasing.
  std::vector<Written> write_sample(const fs::path& path) {
    McapWriterOptions options;
    options.compression = GetParam();
    options.chunk_size = 64 * 1024;
    McapWriter writer(path, options);
    const auto s1 = writer.add_schema("thermovis::RangeArray", "omgidl", "module thermovis {};");
    const auto s2 = writer.add_schema("thermovis::VisibleStereoFrame", "omgidl", "struct X {};");
    const auto ranges = writer.add_channel(s1, "thermovis/ranges", "cdr", {{"k", "v"}});
    const auto frames = writer.add_channel(s2, "thermovis/frames/visible", "cdr");
    const auto raw = writer.add_channel(0, "no/schema", "cdr");
    std::vector<Written> written;
    std::uint64_t t = 1'700'000'000'000'000'000ull;
    for (std::uint32_t i = 0; i < 40; ++i) {
      t += 1'000'000 + i;
      written.push_back({ranges, i, t, t - 500, random_bytes(40 + i * 7, i)});
      if (i % 10 == 3)
        written.push_back({frames, i / 10, t + 1, t, random_bytes(150'000, 100 + i)});
      if (i == 17) written.push_back({raw, 0, t + 2, t + 2, {}});
    }
    for (const Written& w : written)
      writer.write(w.channel, w.sequence, w.log_time, w.publish_time, w.data.data(), w.data.size());
    writer.close();
    EXPECT_EQ(writer.statistics().message_count, written.size());
    EXPECT_GE(writer.statistics().chunk_count, 5u);
    return written;
  }

  fs::path dir_;
};

TEST_P(Mcap, RoundTripGivesBackEveryMessageAndTheSummary) {
  const fs::path path = dir_ / "run.mcap";
  const auto written = write_sample(path);
  McapReader reader(path);
  EXPECT_EQ(reader.library(), "thermovis");
  ASSERT_EQ(reader.schemas().size(), 2u);
  EXPECT_EQ(reader.schemas().at(1).name, "thermovis::RangeArray");
  EXPECT_EQ(reader.schemas().at(1).encoding, "omgidl");
  EXPECT_EQ(reader.schemas().at(1).data, "module thermovis {};");
  ASSERT_EQ(reader.channels().size(), 3u);
  ASSERT_NE(reader.channel("thermovis/ranges"), nullptr);
  EXPECT_EQ(reader.channel("thermovis/ranges")->metadata.at("k"), "v");
  EXPECT_EQ(reader.channel("thermovis/frames/visible")->schema_id, 2);
  EXPECT_EQ(reader.channel("nothing"), nullptr);
  ASSERT_TRUE(reader.has_statistics());
  EXPECT_EQ(reader.statistics().message_count, written.size());
  EXPECT_EQ(reader.statistics().channel_message_counts.at(1), 4u);
  EXPECT_EQ(reader.statistics().message_start_time, written.front().log_time);
  EXPECT_EQ(reader.statistics().chunk_count, reader.chunk_indexes().size());
  for (const auto& index : reader.chunk_indexes())
    EXPECT_EQ(index.compression, GetParam() == McapCompression::zstd ? "zstd" : "");

  const auto read = read_all(reader);
  ASSERT_EQ(read.size(), written.size());
  for (std::size_t i = 0; i < read.size(); ++i) {
    SCOPED_TRACE(i);
    EXPECT_EQ(read[i].channel, written[i].channel);
    EXPECT_EQ(read[i].sequence, written[i].sequence);
    EXPECT_EQ(read[i].log_time, written[i].log_time);
    EXPECT_EQ(read[i].publish_time, written[i].publish_time);
    EXPECT_EQ(read[i].data, written[i].data);
  }
  const auto check = reader.validate();
  EXPECT_EQ(check.messages, written.size());
  EXPECT_EQ(check.chunks, reader.chunk_indexes().size());
  EXPECT_GE(check.message_indexes, check.chunks);
  EXPECT_TRUE(check.data_crc_checked);
  EXPECT_TRUE(check.summary_crc_checked);

  // Stopping early is allowed and reads no further.
  int seen = 0;
  reader.read_messages([&](const McapMessageView&) { return ++seen < 3; });
  EXPECT_EQ(seen, 3);
}

// The bytes themselves, as the specification lays them out.
TEST_P(Mcap, TheFileFollowsTheSpecificationLayout) {
  const fs::path path = dir_ / "layout.mcap";
  write_sample(path);
  const Bytes b = read_file(path);
  const std::uint8_t magic[8] = {0x89, 'M', 'C', 'A', 'P', 0x30, '\r', '\n'};
  ASSERT_GT(b.size(), 100u);
  EXPECT_EQ(std::memcmp(b.data(), magic, 8), 0);
  EXPECT_EQ(std::memcmp(b.data() + b.size() - 8, magic, 8), 0);
  EXPECT_EQ(b[8], 0x01) << "Header first";
  // Footer: opcode 2, length 20, then summary_start, summary_offset_start, summary_crc.
  const std::size_t footer = b.size() - 8 - 29;
  EXPECT_EQ(b[footer], 0x02);
  EXPECT_EQ(u64_at(b, footer + 1), 20u);
  const std::uint64_t summary_start = u64_at(b, footer + 9);
  const std::uint64_t summary_offset_start = u64_at(b, footer + 17);
  ASSERT_GT(summary_start, 0u);
  ASSERT_GT(summary_offset_start, summary_start);
  ASSERT_LT(summary_offset_start, footer);
  // Data End (opcode 0x0F, 4 bytes) right before the summary, carrying the CRC32 of every byte
  // before it; the summary CRC runs from the summary through summary_offset_start.
  const std::size_t data_end = summary_start - 13;
  EXPECT_EQ(b[data_end], 0x0F);
  EXPECT_EQ(u64_at(b, data_end + 1), 4u);
  EXPECT_EQ(u32_at(b, data_end + 9), ::crc32_z(0, b.data(), data_end));
  EXPECT_EQ(u32_at(b, footer + 25),
            ::crc32_z(0, b.data() + summary_start, footer + 25 - summary_start));
  // The summary offset section: Summary Offset records (0x0E) of 17 bytes each.
  for (std::size_t at = summary_offset_start; at < footer; at += 9 + 17) {
    EXPECT_EQ(b[at], 0x0E);
    EXPECT_EQ(u64_at(b, at + 1), 17u);
    const std::uint64_t group_start = u64_at(b, at + 10);
    EXPECT_EQ(b[group_start], b[at + 9]) << "group starts with its opcode";
  }
}

TEST_P(Mcap, TruncatedFilesAreReportedAsTruncated) {
  const fs::path path = dir_ / "whole.mcap";
  write_sample(path);
  const Bytes b = read_file(path);
  for (const std::size_t keep : {b.size() - 1, b.size() / 2, std::size_t{100}, std::size_t{20}}) {
    SCOPED_TRACE(keep);
    const fs::path cut = dir_ / ("cut_" + std::to_string(keep) + ".mcap");
    write_file(cut, Bytes(b.begin(), b.begin() + static_cast<std::ptrdiff_t>(keep)));
    expect_error([&] { McapReader r(cut); }, cut, "truncated");
  }
  const fs::path empty = dir_ / "empty.mcap";
  write_file(empty, {});
  expect_error([&] { McapReader r(empty); }, empty, "not an MCAP file");
  const fs::path text = dir_ / "text.mcap";
  write_file(text, Bytes(200, 'x'));
  expect_error([&] { McapReader r(text); }, text, "not an MCAP file");
  expect_error([&] { McapReader r(dir_ / "absent.mcap"); }, dir_ / "absent.mcap", "cannot open");
}

TEST_P(Mcap, CorruptBytesAreCaughtByTheCrcs) {
  const fs::path path = dir_ / "good.mcap";
  write_sample(path);
  const Bytes good = read_file(path);
  McapReader reader(path);
  const auto& chunk = reader.chunk_indexes().at(2);
  const std::uint64_t summary_start = u64_at(good, good.size() - 8 - 29 + 9);

  // A byte inside a chunk's records.
  Bytes bad = good;
  bad[chunk.chunk_start_offset + chunk.chunk_length - 10] ^= 0x5A;
  const fs::path bad_chunk = dir_ / "bad_chunk.mcap";
  write_file(bad_chunk, bad);
  McapReader chunk_reader(bad_chunk);  // the summary is intact
  expect_error([&] { read_all(chunk_reader); }, bad_chunk,
               GetParam() == McapCompression::zstd ? "Chunk" : "Chunk CRC mismatch");

  // A letter of the Header's library name: only the data section's CRC covers it (a schema or
  // channel would also differ from its copy in the summary).
  bad = good;
  const std::size_t library = 8 + 9 + 4 + 4;  // after the empty profile and the length
  ASSERT_EQ(good[library], 't');
  bad[library] = 'T';
  const fs::path bad_data = dir_ / "bad_data.mcap";
  write_file(bad_data, bad);
  McapReader data_reader(bad_data);
  expect_error([&] { read_all(data_reader); }, bad_data, "data section CRC mismatch");

  // A byte of the summary.
  bad = good;
  bad[summary_start + 20] ^= 0x01;
  const fs::path bad_summary = dir_ / "bad_summary.mcap";
  write_file(bad_summary, bad);
  expect_error([&] { McapReader r(bad_summary); }, bad_summary, "summary CRC mismatch");

  // A record length pointing past the end of the data section.
  bad = good;
  for (int i = 0; i < 8; ++i)
    bad[chunk.chunk_start_offset + 1 + static_cast<std::size_t>(i)] = 0x7F;
  const fs::path bad_length = dir_ / "bad_length.mcap";
  write_file(bad_length, bad);
  McapReader length_reader(bad_length);
  expect_error([&] { read_all(length_reader); }, bad_length, "truncated or corrupt");
}

INSTANTIATE_TEST_SUITE_P(Compression, Mcap,
                         ::testing::Values(McapCompression::zstd, McapCompression::none),
                         [](const ::testing::TestParamInfo<McapCompression>& param) {
                           return param.param == McapCompression::zstd ? "zstd" : "none";
                         });

TEST(McapEmpty, AFileWithoutMessagesIsValid) {
  const fs::path dir = thermovis::test::temp_dir("mcap_empty");
  {
    McapWriter writer(dir / "empty.mcap");
    writer.add_channel(0, "t", "cdr");
    writer.close();
  }
  McapReader reader(dir / "empty.mcap");
  EXPECT_EQ(reader.statistics().message_count, 0u);
  EXPECT_EQ(reader.statistics().channel_count, 1u);
  EXPECT_TRUE(read_all(reader).empty());
  EXPECT_EQ(reader.validate().messages, 0u);
  fs::remove_all(dir);
}

// A file encoded here by hand from the specification (unchunked message, no summary, CRCs 0):
// the reader does not depend on this writer's choices.
TEST(McapForeign, AnUnchunkedFileWithoutSummaryReads) {
  Bytes content;  // the record being built
  const auto uint = [&](std::uint64_t v, int n) {
    for (int i = 0; i < n; ++i) content.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
  };
  const auto str = [&](const std::string& s) {
    uint(s.size(), 4);
    content.insert(content.end(), s.begin(), s.end());
  };
  const Bytes magic{0x89, 'M', 'C', 'A', 'P', 0x30, '\r', '\n'};
  Bytes b = magic;
  const auto record = [&](std::uint8_t opcode) {
    b.push_back(opcode);
    for (int i = 0; i < 8; ++i) b.push_back(static_cast<std::uint8_t>(content.size() >> (8 * i)));
    b.insert(b.end(), content.begin(), content.end());
    content.clear();
  };
  str("ros2"), str("lib");
  record(0x01);  // Header
  uint(7, 2), str("T"), str("omgidl"), str("{}");
  record(0x03);  // Schema 7
  uint(3, 2), uint(7, 2), str("/a"), str("cdr"), uint(0, 4);
  record(0x04);  // Channel 3 on schema 7, no metadata
  uint(3, 2), uint(9, 4), uint(1000, 8), uint(900, 8);
  content.insert(content.end(), {1, 2, 3});
  record(0x05);  // Message outside any chunk
  uint(0, 4);
  record(0x0F);  // Data End without CRC
  uint(0, 8), uint(0, 8), uint(0, 4);
  record(0x02);  // Footer: no summary
  b.insert(b.end(), magic.begin(), magic.end());

  const fs::path dir = thermovis::test::temp_dir("mcap_foreign");
  write_file(dir / "foreign.mcap", b);
  McapReader reader(dir / "foreign.mcap");
  EXPECT_EQ(reader.profile(), "ros2");
  EXPECT_FALSE(reader.has_statistics());
  const auto read = read_all(reader);
  ASSERT_EQ(read.size(), 1u);
  EXPECT_EQ(read[0].channel, 3);
  EXPECT_EQ(read[0].sequence, 9u);
  EXPECT_EQ(read[0].log_time, 1000u);
  EXPECT_EQ(read[0].publish_time, 900u);
  EXPECT_EQ(read[0].data, (Bytes{1, 2, 3}));
  ASSERT_NE(reader.channel("/a"), nullptr);
  EXPECT_EQ(reader.schemas().at(7).encoding, "omgidl");
  const auto check = reader.validate();
  EXPECT_EQ(check.messages, 1u);
  EXPECT_FALSE(check.data_crc_checked);
  fs::remove_all(dir);
}

}  // namespace
