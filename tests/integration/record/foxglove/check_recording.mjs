// An independent reader of a thermovis recording: the MCAP reader, IDL parser and CDR decoder
// that Foxglove itself uses (npm packages, not thermovis code). For every channel it parses the
// schema and decodes every message, then prints one JSON object:
//   {"channels": [{"topic", "schema", "schema_encoding", "message_encoding", "messages"}],
//    "messages": [{"topic", "log_time", "message"}]}
// where each decoded message has its byte and number arrays of more than 16 elements replaced
// by {"length": n} (frames are megabytes). The pictures of foxglove.CompressedImage messages
// are decoded from base64 as Foxglove does and written to IMAGE_DIR/<n>.<format>, whose path
// replaces "data". Exits non-zero, naming the channel, when a schema does not parse or a message
// does not decode.
// Usage: node check_recording.mjs FILE.mcap IMAGE_DIR
import { mkdir, open, writeFile } from "node:fs/promises";
import { McapIndexedReader } from "@mcap/core";
import { loadDecompressHandlers } from "@mcap/support";
import { parseIDL } from "@foxglove/omgidl-parser";
import { MessageReader } from "@foxglove/omgidl-serialization";

const [file, imageDir] = process.argv.slice(2);
if (!file || !imageDir) {
  console.error("usage: node check_recording.mjs FILE.mcap IMAGE_DIR");
  process.exit(2);
}
await mkdir(imageDir, { recursive: true });

const handle = await open(file, "r");
const readable = {
  size: async () => BigInt((await handle.stat()).size),
  read: async (offset, length) => {
    const buffer = new Uint8Array(Number(length));
    await handle.read(buffer, 0, buffer.length, Number(offset));
    return buffer;
  },
};
const reader = await McapIndexedReader.Initialize({
  readable,
  decompressHandlers: await loadDecompressHandlers(),
});

// A decoder per channel, made from its schema as Foxglove makes it.
function decoderOf(channel, schema) {
  const where = `channel ${channel.id} (${channel.topic}), schema ${schema?.name}`;
  if (!schema) throw new Error(`${where}: no schema`);
  const text = new TextDecoder().decode(schema.data);
  if (schema.encoding === "omgidl" && channel.messageEncoding === "cdr") {
    let definitions;
    try {
      definitions = parseIDL(text);
    } catch (e) {
      throw new Error(`${where}: the IDL does not parse: ${e.message}`);
    }
    const messageReader = new MessageReader(schema.name, definitions);
    return (data) => messageReader.readMessage(data);
  }
  if (schema.encoding === "jsonschema" && channel.messageEncoding === "json") {
    JSON.parse(text);
    return (data) => JSON.parse(new TextDecoder().decode(data));
  }
  throw new Error(`${where}: unexpected encodings ${schema.encoding} / ${channel.messageEncoding}`);
}

// Decoded values as JSON: bigints as numbers, long arrays as their length.
function summarise(value) {
  if (typeof value === "bigint") return Number(value);
  if (ArrayBuffer.isView(value) || Array.isArray(value)) {
    if (value.length > 16) return { length: value.length };
    return Array.from(value, summarise);
  }
  if (value && typeof value === "object") {
    const out = {};
    for (const [k, v] of Object.entries(value)) out[k] = summarise(v);
    return out;
  }
  if (typeof value === "string" && value.length > 256) return { length: value.length };
  return value;
}

const decoders = new Map();
const channels = [];
for (const channel of reader.channelsById.values()) {
  decoders.set(channel.id, decoderOf(channel, reader.schemasById.get(channel.schemaId)));
  channels.push({
    id: channel.id,
    topic: channel.topic,
    schema: reader.schemasById.get(channel.schemaId).name,
    schema_encoding: reader.schemasById.get(channel.schemaId).encoding,
    message_encoding: channel.messageEncoding,
    messages: 0,
  });
}
const messages = [];
for await (const message of reader.readMessages()) {
  const channel = channels.find((c) => c.id === message.channelId);
  let decoded;
  try {
    decoded = decoders.get(message.channelId)(message.data);
  } catch (e) {
    throw new Error(`channel ${channel.topic}, message ${message.sequence}: ${e.message}`);
  }
  ++channel.messages;
  if (channel.schema === "foxglove.CompressedImage") {
    const path = `${imageDir}/${messages.length}.${decoded.format}`;
    await writeFile(path, Buffer.from(decoded.data, "base64"));
    decoded.data = path;
  }
  messages.push({ topic: channel.topic, log_time: Number(message.logTime), message: summarise(decoded) });
}
await handle.close();
process.stdout.write(JSON.stringify({ channels, messages }) + "\n");
