// Opens cosim recordings with @mcap/core, the TypeScript reader Foxglove and Lichtblick use, and
// checks what a viewer relies on: chunk and data CRCs, every message decodes against its schema
// (protobuf descriptors for the cosim.* exchanges that have that form and the foxglove.* viewer
// types, JSON for the other cosim.* channels), per-channel
// counts equal the summary statistics, log_time == publish_time, sequence numbers increase, and a
// foxglove payload's timestamp equals its log time.
//
// usage: node check.mjs RUN.mcap [RUN2.mcap ...]   (exit 1 on any problem; 2 with no file given)
import { open } from "node:fs/promises";

const USAGE = "usage: node check.mjs RUN.mcap [RUN2.mcap ...]   (exit 1 on any problem)";
const args = process.argv.slice(2);
if (args.includes("-h") || args.includes("--help")) {
  console.log(USAGE);
  console.log("Opens cosim recordings with @mcap/core and checks CRCs, decoding, counts against the summary, times and sequences.");
  process.exit(0);
}
const paths = args.filter((a) => a !== "--");
const unknown = args.find((a, k) => a.startsWith("-") && a !== "--" && !args.slice(0, k).includes("--"));
if (unknown !== undefined || paths.length === 0) {
  console.error(USAGE);
  console.error(unknown !== undefined ? `check.mjs: unknown option ${unknown}` : "check.mjs: no recording given");
  process.exit(2);
}

// loaded once the arguments are known, so --help and a usage error work before `npm install`
const { McapIndexedReader } = await import("@mcap/core");
const { decompress } = await import("fzstd");
const protobuf = (await import("protobufjs")).default;
const descriptor = (await import("protobufjs/ext/descriptor/index.js")).default;

function fileReadable(handle, size) {
  return {
    size: async () => BigInt(size),
    read: async (offset, length) => {
      const buf = new Uint8Array(Number(length));
      await handle.read(buf, 0, Number(length), Number(offset));
      return buf;
    },
  };
}

function protobufDecoder(schema) {
  const set = descriptor.FileDescriptorSet.decode(schema.data);
  const root = protobuf.Root.fromDescriptor(set);
  const type = root.lookupType(schema.name);
  return (data) => type.toObject(type.decode(data), { longs: String });
}

function stampNs(ts) {
  if (!ts) return null;
  return BigInt(ts.seconds ?? 0) * 1000000000n + BigInt(ts.nanos ?? 0);
}

async function check(path) {
  const problems = [];
  const handle = await open(path, "r");
  const { size } = await handle.stat();
  const reader = await McapIndexedReader.Initialize({
    readable: fileReadable(handle, size),
    decompressHandlers: { zstd: (buf, decompressedSize) => decompress(buf, new Uint8Array(Number(decompressedSize))) },
  });
  const decoders = new Map();
  for (const [id, channel] of reader.channelsById) {
    const schema = reader.schemasById.get(channel.schemaId);
    if (channel.messageEncoding === "json") {
      decoders.set(id, (data) => JSON.parse(new TextDecoder().decode(data)));
    } else if (channel.messageEncoding === "protobuf" && schema) {
      decoders.set(id, protobufDecoder(schema));
    } else {
      problems.push(`${channel.topic}: unsupported encoding ${channel.messageEncoding}`);
    }
  }
  const counts = new Map();
  const lastSeq = new Map();
  let total = 0;
  for await (const msg of reader.readMessages({ validateCrcs: true })) {
    const channel = reader.channelsById.get(msg.channelId);
    total++;
    counts.set(msg.channelId, (counts.get(msg.channelId) ?? 0) + 1);
    if (msg.logTime !== msg.publishTime) problems.push(`${channel.topic}: log_time != publish_time at ${msg.logTime}`);
    const prev = lastSeq.get(msg.channelId);
    if (prev !== undefined && msg.sequence <= prev) problems.push(`${channel.topic}: sequence not increasing at ${msg.logTime}`);
    lastSeq.set(msg.channelId, msg.sequence);
    let value;
    try {
      value = decoders.get(msg.channelId)?.(msg.data);
    } catch (err) {
      problems.push(`${channel.topic}: message at ${msg.logTime} does not decode: ${err.message}`);
      continue;
    }
    const schema = reader.schemasById.get(channel.schemaId);
    if (schema?.name.startsWith("foxglove.") && value) {
      const stamps = [];
      if (value.timestamp) stamps.push(stampNs(value.timestamp));
      for (const key of ["transforms", "entities"]) for (const item of value[key] ?? []) if (item.timestamp) stamps.push(stampNs(item.timestamp));
      for (const s of stamps) if (s !== msg.logTime) problems.push(`${channel.topic}: payload timestamp ${s} != log_time ${msg.logTime}`);
    }
  }
  const stats = reader.statistics;
  if (!stats) problems.push("no statistics record in the summary");
  else {
    if (BigInt(total) !== stats.messageCount) problems.push(`read ${total} messages, summary says ${stats.messageCount}`);
    for (const [id, expected] of stats.channelMessageCounts) {
      const got = BigInt(counts.get(id) ?? 0);
      if (got !== expected) problems.push(`${reader.channelsById.get(id)?.topic}: read ${got}, summary says ${expected}`);
    }
  }
  await handle.close();
  return { total, channels: reader.channelsById.size, problems };
}

let failed = 0;
let passed = 0;
for (const path of paths) {
  try {
    const { total, channels, problems } = await check(path);
    if (problems.length) {
      failed++;
      console.log(`FAIL ${path}: ${problems.length} problems`);
      for (const p of problems.slice(0, 20)) console.log(`  ${p}`);
    } else {
      passed++;
      console.log(`ok ${path}: ${total} messages on ${channels} channels, CRCs valid, all decoded, counts match the summary`);
    }
  } catch (err) {
    failed++;
    console.log(`FAIL ${path}: ${err.message}`);
  }
}
console.log(`mcap-check: ${passed} passed, ${failed} failed`);
process.exit(failed ? 1 : 0);
