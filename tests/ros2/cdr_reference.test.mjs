// SPDX-License-Identifier: Apache-2.0
// The ROS 2 types library (plugin-api/ros2) and the interfaces the project ships
// (plugin-api/ros2/msgs) against the npm reference implementations, through ros2_cdr_tool:
// - every shipped message that @foxglove/rosmsg-msgs-common knows (ROS 2 Humble's definitions)
//   has the same fields, types, bounds, defaults and constants, read from the `ros2msg` schema
//   text the library writes (parsed by @foxglove/rosmsg, as Foxglove and MCAP readers do);
// - for every shipped type, seeded values of every field are written to the same CDR bytes by
//   the library and by @foxglove/rosmsg2-serialization's MessageWriter, and each side reads the
//   other's bytes back to the same value.
import assert from 'node:assert/strict';
import { spawn } from 'node:child_process';
import { createInterface } from 'node:readline';
import { after, before, test } from 'node:test';

import { webRequire } from '../web/harness.mjs';

const { parse } = webRequire('@foxglove/rosmsg');
const { MessageReader, MessageWriter } = webRequire('@foxglove/rosmsg2-serialization');
const { ros2humble } = webRequire('@foxglove/rosmsg-msgs-common');

const tool = process.env.ROS2_CDR_TOOL;
const msgs = process.env.ROS2_MSGS;

let child;
let pending = [];

// One request a line, answered in order.
function ask(request) {
  return new Promise((resolve) => {
    pending.push(resolve);
    child.stdin.write(`${JSON.stringify(request)}\n`);
  });
}

before(() => {
  assert.ok(tool && msgs, 'ROS2_CDR_TOOL and ROS2_MSGS name the tool and the shipped interfaces');
  child = spawn(tool, [msgs], { stdio: ['pipe', 'pipe', 'inherit'] });
  createInterface({ input: child.stdout }).on('line', (line) => pending.shift()(JSON.parse(line)));
});
after(() => child?.stdin.end());

// "pkg/msg/Name" -> "pkg/Name", the reference's key.
const shortName = (type) => type.replace('/msg/', '/');

async function definitionsOf(type) {
  const { schema, error } = await ask({ op: 'schema', type });
  assert.equal(error, undefined, `${type}: ${error}`);
  return parse(schema, { ros2: true });
}

// A field or constant as both sides describe it, with what may be absent made explicit.
function described(f) {
  if (f.isConstant) return { constant: f.name, type: f.type, value: Number(f.value) };
  return {
    name: f.name,
    type: f.type,
    isArray: Boolean(f.isArray),
    arrayLength: f.arrayLength ?? null,
    arrayUpperBound: f.arrayUpperBound ?? null,
    upperBound: f.upperBound ?? null,
    defaultValue: f.defaultValue ?? null,
  };
}

test('every shipped message the reference knows has its fields, bounds, defaults and constants', async () => {
  const { types } = await ask({ op: 'types' });
  const compared = [];
  for (const type of types.filter((t) => t.includes('/msg/'))) {
    const reference = ros2humble[shortName(type)];
    if (!reference) continue;
    const [ours] = await definitionsOf(type);
    // The reference names a type used within its package with the package ("std_msgs/Header").
    const fullType = (f) => (f.isComplex && !f.type.includes('/') ? `${type.split('/')[0]}/${f.type}` : f.type);
    assert.deepEqual(
      ours.definitions.map((f) => described({ ...f, type: fullType(f) })),
      reference.definitions.map(described),
      type,
    );
    compared.push(type);
  }
  // What the project ships beyond Humble's set in the reference: services and their packages.
  assert.ok(compared.length >= 95, `compared ${compared.length} messages`);
});

// Seeded values for every field of a type, from the reference parser's definitions.
function generator(type, definitions, seed) {
  let state = seed >>> 0;
  const rand = () => {
    state = (state * 1664525 + 1013904223) >>> 0;
    return state / 2 ** 32;
  };
  const int = (lo, hi) => lo + Math.floor(rand() * (hi - lo + 1));
  const byName = new Map(definitions.map((d) => [d.name, d]));
  // A type used within its package may be named without the package.
  const definitionOf = (f, within) => byName.get(f.type) ?? byName.get(`${within.split('/')[0]}/${f.type}`);
  const scalar = (f, within) => {
    switch (f.type) {
      case 'bool': return rand() < 0.5;
      case 'int8': return int(-128, 127);
      case 'uint8': case 'byte': case 'char': return int(0, 255);
      case 'int16': return int(-32768, 32767);
      case 'uint16': return int(0, 65535);
      case 'int32': return int(-2147483648, 2147483647);
      case 'uint32': return int(0, 4294967295);
      case 'int64': return BigInt(int(-(2 ** 40), 2 ** 40));
      case 'uint64': return BigInt(int(0, 2 ** 40));
      case 'float32': return int(-8000, 8000) / 8;  // exact in 32 bits
      case 'float64': return int(-1e9, 1e9) / 1024;
      // The reference reads builtin_interfaces/Time and Duration as its own time type.
      case 'time': case 'duration': return { sec: int(-2147483648, 2147483647), nanosec: int(0, 999999999) };
      case 'string': {
        const n = int(0, Math.min(9, f.upperBound ?? 9));
        return Array.from({ length: n }, () => String.fromCharCode(int(97, 122))).join('');
      }
      default: return message(definitionOf(f, within));
    }
  };
  const message = (def) => {
    const out = {};
    for (const f of def.definitions) {
      if (f.isConstant) continue;
      if (!f.isArray) {
        out[f.name] = scalar(f, def.name ?? type);
        continue;
      }
      // Lengths of every parity, so that each alignment after a sequence is met.
      const n = f.arrayLength ?? int(0, Math.min(5, f.arrayUpperBound ?? 5));
      out[f.name] = Array.from({ length: n }, () => scalar(f, def.name ?? type));
    }
    return out;
  };
  return () => message(definitions[0]);
}

// Values as JSON gives them back: 64-bit integers and byte arrays as plain numbers and arrays.
function plain(v) {
  if (typeof v === 'bigint') return Number(v);
  if (ArrayBuffer.isView(v)) return Array.from(v, plain);
  if (Array.isArray(v)) return v.map(plain);
  if (v && typeof v === 'object') return Object.fromEntries(Object.entries(v).map(([k, x]) => [k, plain(x)]));
  return v;
}

const hex = (bytes) => Buffer.from(bytes).toString('hex');

test('every shipped type is written to the reference bytes and read back both ways', async () => {
  const { types } = await ask({ op: 'types' });
  let samples = 0;
  for (const type of types) {
    const definitions = await definitionsOf(type);
    const writer = new MessageWriter(definitions);
    const reader = new MessageReader(definitions);
    const next = generator(type, definitions, samples + 1);
    for (let i = 0; i < 4; i += 1) {
      const value = next();
      const reference = writer.writeMessage(value);
      const ours = await ask({ op: 'encode', type, value: plain(value) });
      assert.equal(ours.error, undefined, `${type}: ${ours.error}`);
      assert.equal(ours.hex, hex(reference), `${type}: ${JSON.stringify(plain(value))}`);
      const decoded = await ask({ op: 'decode', type, hex: hex(reference) });
      assert.equal(decoded.error, undefined, `${type}: ${decoded.error}`);
      assert.deepEqual(decoded.value, plain(value), type);
      assert.deepEqual(plain(reader.readMessage(Buffer.from(ours.hex, 'hex'))), plain(value), type);
      samples += 1;
    }
  }
  assert.ok(samples >= 400, `${samples} samples`);
});

test('a sample cut short or a value that does not fit is refused, naming the field', async () => {
  const [image] = await definitionsOf('sensor_msgs/msg/Image');
  assert.ok(image);
  const good = await ask({ op: 'encode', type: 'sensor_msgs/msg/Image', value: { encoding: 'rgb8', data: [1, 2, 3] } });
  const cut = await ask({ op: 'decode', type: 'sensor_msgs/msg/Image', hex: good.hex.slice(0, -4) });
  assert.match(cut.error, /sensor_msgs\/msg\/Image\.data/);
  const wrong = await ask({ op: 'encode', type: 'geometry_msgs/msg/Twist', value: { linaer: { x: 1 } } });
  assert.match(wrong.error, /linaer: no such field in geometry_msgs\/msg\/Twist/);
});
