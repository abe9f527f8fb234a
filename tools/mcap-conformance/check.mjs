// Reads fowt-hil run logs with TypeScript @mcap/core (not the Python mcap package the bench
// writes with) and validates every JSON message against its channel's JSON Schema with ajv.
//
//   node check.mjs FILE.mcap [...]      prints one JSON object per file on stdout
//
// For each file:
//   indexed: McapIndexedReader (needs the summary, Footer and closing magic): header
//            profile, statistics, chunk index count, messages per topic, schema errors;
//   stream:  McapStreamReader fed the whole file: messages per topic, whether it parsed a
//            complete file (done) and, for a truncated file, the error it stopped on.
// Exit status 0 when every file was read by both readers and every message validated,
// 1 otherwise (a truncated file: indexed.error is set, stream.done is false).
import { open, readFile } from "node:fs/promises";
import { McapIndexedReader, McapStreamReader } from "@mcap/core";
import { FileHandleReadable } from "@mcap/nodejs";
import { loadDecompressHandlers } from "@mcap/support";
import Ajv2020 from "ajv/dist/2020.js";

const decompressHandlers = await loadDecompressHandlers();
const decoder = new TextDecoder();

// JSON Schema 2020-12 lets a schema carry annotation keywords of its own; ajv's strict mode
// wants them declared, so every "x-..." key is declared as an annotation (no validation).
function extensionKeywords(node, found = new Set()) {
  if (Array.isArray(node)) node.forEach((v) => extensionKeywords(v, found));
  else if (node && typeof node === "object") {
    for (const [k, v] of Object.entries(node)) {
      if (k.startsWith("x-")) found.add(k);
      extensionKeywords(v, found);
    }
  }
  return found;
}

function makeValidators(schemasById, channelsById) {
  const ajv = new Ajv2020({ allErrors: false, strict: true });
  const declared = new Set();
  const validators = new Map();
  for (const [id, channel] of channelsById) {
    const schema = schemasById.get(channel.schemaId);
    if (channel.messageEncoding !== "json" || !schema || schema.encoding !== "jsonschema") {
      throw new Error(`channel ${channel.topic}: not JSON with a jsonschema schema`);
    }
    const doc = JSON.parse(decoder.decode(schema.data));
    for (const k of extensionKeywords(doc)) {
      if (!declared.has(k)) ajv.addKeyword(k);
      declared.add(k);
    }
    validators.set(id, ajv.compile(doc));
  }
  return validators;
}

async function indexed(path) {
  const handle = await open(path, "r");
  try {
    const reader = await McapIndexedReader.Initialize({
      readable: new FileHandleReadable(handle),
      decompressHandlers,
    });
    const validators = makeValidators(reader.schemasById, reader.channelsById);
    const perTopic = {};
    const schemaErrors = [];
    for await (const msg of reader.readMessages({ validateCrcs: true })) {
      const channel = reader.channelsById.get(msg.channelId);
      perTopic[channel.topic] = (perTopic[channel.topic] ?? 0) + 1;
      const validate = validators.get(msg.channelId);
      if (!validate(JSON.parse(decoder.decode(msg.data))) && schemaErrors.length < 5) {
        schemaErrors.push({ topic: channel.topic, errors: validate.errors });
      }
    }
    const stats = reader.statistics;
    const statsPerTopic = {};
    for (const [id, n] of stats?.channelMessageCounts ?? []) {
      if (n > 0n) statsPerTopic[reader.channelsById.get(id).topic] = Number(n);
    }
    const metadata = [];
    for await (const m of reader.readMetadata()) metadata.push(m.name);
    return {
      profile: reader.header.profile,
      messageCount: stats ? Number(stats.messageCount) : null,
      chunkCount: stats ? Number(stats.chunkCount) : null,
      chunkIndexes: reader.chunkIndexes.length,
      statsPerTopic,
      perTopic,
      metadata,
      schemaErrors,
    };
  } catch (err) {
    return { error: String(err) };
  } finally {
    await handle.close();
  }
}

async function stream(path) {
  const reader = new McapStreamReader({ decompressHandlers, validateCrcs: true });
  reader.append(await readFile(path));
  const channels = new Map();
  const perTopic = {};
  let lastLogTimeNs = null;
  let error = null;
  try {
    for (let rec; (rec = reader.nextRecord()); ) {
      if (rec.type === "Channel") channels.set(rec.id, rec.topic);
      else if (rec.type === "Message") {
        const topic = channels.get(rec.channelId);
        perTopic[topic] = (perTopic[topic] ?? 0) + 1;
        if (lastLogTimeNs === null || rec.logTime > lastLogTimeNs) lastLogTimeNs = rec.logTime;
      }
    }
  } catch (err) {
    error = String(err);
  }
  return {
    done: reader.done(),
    bytesRemaining: reader.bytesRemaining(),
    perTopic,
    lastLogTimeNs: lastLogTimeNs === null ? null : lastLogTimeNs.toString(),
    error,
  };
}

let ok = true;
for (const path of process.argv.slice(2)) {
  const result = { path, indexed: await indexed(path), stream: await stream(path) };
  const good =
    !result.indexed.error &&
    result.indexed.schemaErrors.length === 0 &&
    result.stream.done &&
    !result.stream.error;
  ok &&= good;
  process.stdout.write(JSON.stringify(result) + "\n");
}
process.exit(ok ? 0 : 1);
