// An independent reader of a ROS 2 bag folder (`thermovis record --ros2 DIR`), with the code ROS 2
// tools outside ROS use (npm packages, not thermovis code): metadata.yaml parsed by the yaml
// package, every MCAP file it lists read by @mcap/core, every channel's ros2msg schema parsed by
// @foxglove/rosmsg and every message decoded from CDR by @foxglove/rosmsg2-serialization. Prints
// one JSON object:
//   {"metadata": <rosbag2_bagfile_information, each offered_qos_profiles string parsed>,
//    "profile": <the MCAP header profile of the first file>,
//    "channels": [{"file", "topic", "schema", "schema_encoding", "message_encoding",
//                  "offered_qos_profiles" (parsed), "messages"}],
//    "messages": [{"topic", "log_time", "message"}]}
//    "files": [{"file", "messages", "message_start_time", "message_end_time"}] (from its messages),
// where each decoded message has its arrays of more than 16 elements replaced by
// {"length": n, "head": [first 16]}, and integers beyond 2^53 (nanosecond times) are strings. Exits non-zero, naming the file or channel, when something
// does not parse or decode.
// Usage: node check_ros2_bag.mjs DIR
import { open, readFile } from "node:fs/promises";
import { McapIndexedReader } from "@mcap/core";
import { loadDecompressHandlers } from "@mcap/support";
import { parse as parseMessageDefinition } from "@foxglove/rosmsg";
import { MessageReader } from "@foxglove/rosmsg2-serialization";
import YAML from "yaml";

const [dir] = process.argv.slice(2);
if (!dir) {
  console.error("usage: node check_ros2_bag.mjs DIR");
  process.exit(2);
}

const metadataFile = `${dir}/metadata.yaml`;
const metadata = YAML.parse(await readFile(metadataFile, "utf8"), { intAsBigInt: true })
  ?.rosbag2_bagfile_information;
if (!metadata) throw new Error(`${metadataFile}: no rosbag2_bagfile_information`);
for (const entry of metadata.topics_with_message_count ?? []) {
  const topic = entry.topic_metadata;
  topic.offered_qos_profiles = YAML.parse(topic.offered_qos_profiles, { intAsBigInt: true });
}

function summarise(value) {
  if (ArrayBuffer.isView(value) || Array.isArray(value)) {
    if (value.length > 16)
      return { length: value.length, head: Array.from(value.slice(0, 16), summarise) };
    return Array.from(value, summarise);
  }
  if (value && typeof value === "object") {
    const out = {};
    for (const [k, v] of Object.entries(value)) out[k] = summarise(v);
    return out;
  }
  return value;
}

const channels = [];
const messages = [];
const files = [];
let profile;
for (const relative of metadata.relative_file_paths ?? []) {
  const file = `${dir}/${relative}`;
  const handle = await open(file, "r");
  const reader = await McapIndexedReader.Initialize({
    readable: {
      size: async () => BigInt((await handle.stat()).size),
      read: async (offset, length) => {
        const buffer = new Uint8Array(Number(length));
        await handle.read(buffer, 0, buffer.length, Number(offset));
        return buffer;
      },
    },
    decompressHandlers: await loadDecompressHandlers(),
  });
  profile ??= reader.header.profile;
  const decoders = new Map();
  const byId = new Map();
  for (const channel of reader.channelsById.values()) {
    const schema = reader.schemasById.get(channel.schemaId);
    const where = `${file}: channel ${channel.id} (${channel.topic}), schema ${schema?.name}`;
    if (!schema) throw new Error(`${where}: no schema`);
    if (schema.encoding !== "ros2msg" || channel.messageEncoding !== "cdr")
      throw new Error(`${where}: encodings ${schema.encoding} / ${channel.messageEncoding}`);
    let definitions;
    try {
      definitions = parseMessageDefinition(new TextDecoder().decode(schema.data), { ros2: true });
    } catch (e) {
      throw new Error(`${where}: the ros2msg schema does not parse: ${e.message}`);
    }
    const messageReader = new MessageReader(definitions);
    decoders.set(channel.id, (data) => messageReader.readMessage(data));
    const entry = {
      file: relative,
      topic: channel.topic,
      schema: schema.name,
      schema_encoding: schema.encoding,
      message_encoding: channel.messageEncoding,
      offered_qos_profiles: YAML.parse(channel.metadata.get("offered_qos_profiles") ?? "null", {
        intAsBigInt: true,
      }),
      messages: 0,
    };
    byId.set(channel.id, entry);
    channels.push(entry);
  }
  const counted = { file: relative, messages: 0, message_start_time: 0n, message_end_time: 0n };
  files.push(counted);
  for await (const message of reader.readMessages()) {
    if (counted.messages === 0 || message.logTime < counted.message_start_time)
      counted.message_start_time = message.logTime;
    if (message.logTime > counted.message_end_time) counted.message_end_time = message.logTime;
    ++counted.messages;
    const channel = byId.get(message.channelId);
    let decoded;
    try {
      decoded = decoders.get(message.channelId)(message.data);
    } catch (e) {
      throw new Error(`${file}: channel ${channel.topic}, message ${message.sequence}: ${e.message}`);
    }
    ++channel.messages;
    messages.push({ topic: channel.topic, log_time: message.logTime, message: summarise(decoded) });
  }
  await handle.close();
}
// Integers as JSON numbers while exact in a double, else as strings.
const exact = (key, value) =>
  typeof value === "bigint"
    ? value <= BigInt(Number.MAX_SAFE_INTEGER) && value >= -BigInt(Number.MAX_SAFE_INTEGER)
      ? Number(value)
      : value.toString()
    : value;
process.stdout.write(JSON.stringify({ metadata, profile, channels, files, messages }, exact) + "\n");
