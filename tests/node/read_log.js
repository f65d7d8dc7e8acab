// Read a coordarm log with Foxglove's own TypeScript libraries (run by tests/test_node_readers.py):
// @mcap/core's indexed reader (summary, chunk indexes, CRCs), @foxglove/rosmsg (ROS 2 .msg parser) and
// @foxglove/rosmsg2-serialization (CDR decoder). Prints JSON: per topic the message count and, for CDR
// channels, each field's float64 values as base64 of their little-endian bytes (exact, -0 kept).
"use strict";
const fs = require("fs");
const { McapIndexedReader } = require("@mcap/core");
const { loadDecompressHandlers } = require("@mcap/support");
const { parse } = require("@foxglove/rosmsg");
const { MessageReader } = require("@foxglove/rosmsg2-serialization");

async function main(path) {
  const fd = fs.openSync(path, "r");
  const readable = {
    size: async () => BigInt(fs.fstatSync(fd).size),
    read: async (offset, size) => {
      const buf = Buffer.alloc(Number(size));
      fs.readSync(fd, buf, 0, Number(size), Number(offset));
      return buf;
    },
  };
  const reader = await McapIndexedReader.Initialize({ readable, decompressHandlers: await loadDecompressHandlers() });
  const decoders = new Map();
  const out = {};
  for (const [id, ch] of reader.channelsById) {
    const schema = reader.schemasById.get(ch.schemaId);
    if (schema.encoding === "ros2msg") {
      const definitions = parse(new TextDecoder().decode(schema.data), { ros2: true });
      decoders.set(id, { reader: new MessageReader(definitions), fields: definitions[0].definitions });
    } else if (schema.encoding === "jsonschema") {
      JSON.parse(new TextDecoder().decode(schema.data));
    } else {
      throw new Error(`unexpected schema encoding ${schema.encoding}`);
    }
    out[ch.topic] = { count: 0, fields: {} };
  }
  const values = {};
  for await (const msg of reader.readMessages({ validateCrcs: true })) {
    const topic = reader.channelsById.get(msg.channelId).topic;
    out[topic].count += 1;
    const dec = decoders.get(msg.channelId);
    if (!dec) {
      JSON.parse(new TextDecoder().decode(msg.data));
      continue;
    }
    const m = dec.reader.readMessage(msg.data);
    for (const f of dec.fields) {
      const key = `${topic}|${f.name}`;
      (values[key] = values[key] || []).push(...(f.isArray ? Array.from(m[f.name]) : [m[f.name]]));
    }
  }
  for (const [key, list] of Object.entries(values)) {
    const [topic, name] = key.split("|");
    out[topic].fields[name] = Buffer.from(new Float64Array(list).buffer).toString("base64");
  }
  const stats = reader.statistics;
  process.stdout.write(JSON.stringify({
    topics: out,
    statistics: Object.fromEntries([...stats.channelMessageCounts].map(([id, n]) => [reader.channelsById.get(id).topic, Number(n)])),
  }));
}

main(process.argv[2]).catch((err) => { console.error(err); process.exit(1); });
