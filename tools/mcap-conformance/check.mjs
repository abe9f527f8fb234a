// Reads fowt-hil run logs with TypeScript @mcap/core (not the Python mcap package the bench
// writes with) and validates every message: a JSON one against its channel's JSON Schema
// with ajv, a CDR one (ros2msg schema) by a decoder written here from the ROS 2 message
// definition in the file (XCDR1 little endian: 4-byte encapsulation header 00 01 00 00,
// each primitive aligned to its size from the header's end): its length, its header, and
// every field finite and within the range its definition's comment states
// ("# ... range LO..HI").
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

const CDR_SIZES = { uint8: 1, uint32: 4, int64: 8, uint64: 8, float64: 8 };

// A validator of a ros2msg definition's CDR payloads (raw bytes in, true/false out, the
// reasons in .errors as ajv's validators have them).
function cdrValidator(text) {
  const fields = [];
  let pos = 0;
  for (const line of text.split("\n")) {
    const hash = line.indexOf("#");
    const body = (hash < 0 ? line : line.slice(0, hash)).trim();
    if (!body) continue;
    const [type, name, ...rest] = body.split(/\s+/);
    const size = CDR_SIZES[type];
    if (!size || !name || rest.length) throw new Error(`ros2msg line ${JSON.stringify(line)}`);
    const range = hash < 0 ? null : /range (\S+?)\.\.(\S+)/.exec(line.slice(hash));
    pos = Math.ceil(pos / size) * size;
    fields.push({ type, name, offset: 4 + pos, lo: range && Number(range[1]), hi: range && Number(range[2]) });
    pos += size;
  }
  const length = 4 + pos;
  const validate = (bytes) => {
    validate.errors = null;
    if (bytes.byteLength !== length) {
      validate.errors = [`${bytes.byteLength} bytes, the definition's payload is ${length}`];
      return false;
    }
    if (bytes[0] !== 0 || bytes[1] !== 1 || bytes[2] !== 0 || bytes[3] !== 0) {
      validate.errors = ["encapsulation header is not CDR_LE 00 01 00 00"];
      return false;
    }
    const view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
    const errors = [];
    for (const f of fields) {
      let v;
      if (f.type === "float64") v = view.getFloat64(f.offset, true);
      else if (f.type === "uint8") v = view.getUint8(f.offset);
      else if (f.type === "uint32") v = view.getUint32(f.offset, true);
      else if (f.type === "int64") v = view.getBigInt64(f.offset, true);
      else v = view.getBigUint64(f.offset, true);
      if (typeof v === "number" && !Number.isFinite(v)) {
        errors.push(`${f.name} = ${v}`);
        continue;
      }
      if (f.lo === null) continue;
      const x = Number(v); // a 64-bit integer compared as a double: the bounds are doubles too
      if (x < f.lo || x > f.hi) errors.push(`${f.name} = ${v} outside ${f.lo}..${f.hi}`);
    }
    validate.errors = errors.length ? errors : null;
    return errors.length === 0;
  };
  return validate;
}

function makeValidators(schemasById, channelsById) {
  const ajv = new Ajv2020({ allErrors: false, strict: true });
  const declared = new Set();
  const validators = new Map();
  for (const [id, channel] of channelsById) {
    const schema = schemasById.get(channel.schemaId);
    if (channel.messageEncoding === "cdr" && schema && schema.encoding === "ros2msg") {
      validators.set(id, cdrValidator(decoder.decode(schema.data)));
      continue;
    }
    if (channel.messageEncoding !== "json" || !schema || schema.encoding !== "jsonschema") {
      throw new Error(`channel ${channel.topic}: neither JSON with a jsonschema schema nor CDR with ros2msg`);
    }
    const doc = JSON.parse(decoder.decode(schema.data));
    for (const k of extensionKeywords(doc)) {
      if (!declared.has(k)) ajv.addKeyword(k);
      declared.add(k);
    }
    const check = ajv.compile(doc);
    const validate = (bytes) => {
      const ok = check(JSON.parse(decoder.decode(bytes)));
      validate.errors = check.errors;
      return ok;
    };
    validators.set(id, validate);
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
      if (!validate(msg.data) && schemaErrors.length < 5) {
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
