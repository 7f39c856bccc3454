// SPDX-License-Identifier: Apache-2.0
// The JavaScript Variant codec against the vectors C++ checks too (vectors/variant.json,
// tests/flow/variant_vectors_test.cpp): byte-exact both ways, the same refusals; and the
// JavaScript type mapping (safe integers, BigInt, forced types, Map, views).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import {
  encodeVariant, decodeVariant, Variant, ProtocolError, MAX_DEPTH,
} from '../../satellite/js/src/node.js';
import { VALUES, DECODED } from './vectors/make_variant_values.mjs';

const vectors = JSON.parse(readFileSync(new URL('./vectors/variant.json', import.meta.url), 'utf8'));
const hex = (b) => Buffer.from(b).toString('hex');
const unhex = (h) => new Uint8Array(Buffer.from(h, 'hex'));

test('every good vector decodes to its value and that value encodes to the same bytes', () => {
  assert.deepEqual(vectors.good.map((v) => v.name).sort(), Object.keys(VALUES).sort());
  for (const v of vectors.good) {
    const decoded = decodeVariant(unhex(v.hex));
    const want = v.name in DECODED ? DECODED[v.name] : VALUES[v.name];
    assert.deepEqual(decoded, want, v.name);
    assert.equal(hex(encodeVariant(VALUES[v.name])), v.hex, `${v.name}: encoded`);
    assert.equal(hex(encodeVariant(decoded)), v.name === 'float_two' ? '020200000000000000' : v.hex, `${v.name}: re-encoded`);
  }
});

test('every bad vector is refused with a ProtocolError naming its reason', () => {
  for (const v of vectors.bad) {
    assert.throws(() => decodeVariant(unhex(v.hex)), (e) => {
      assert.ok(e instanceof ProtocolError, `${v.name}: ${e}`);
      assert.match(e.message, new RegExp(v.why), v.name);
      return true;
    }, v.name);
  }
});

test('the documented examples (docs/flow-protocol.md, Values)', () => {
  assert.equal(hex(encodeVariant(1)), '020100000000000000');
  assert.equal(hex(encodeVariant('hi')), '05020000006869');
  assert.equal(hex(encodeVariant([true, null])), '0702000000010100');
  assert.equal(hex(encodeVariant({ a: 1.5 })), '080100000001006104000000000000f83f');
});

test('JavaScript values map onto wire types as documented', () => {
  assert.equal(hex(encodeVariant(2 ** 53)).slice(0, 2), '04', 'beyond safe integers: float64');
  assert.equal(hex(encodeVariant(-(2 ** 53) + 1)).slice(0, 2), '02');
  assert.equal(hex(encodeVariant(0.5)).slice(0, 2), '04');
  assert.equal(hex(encodeVariant(5n)).slice(0, 2), '02');
  assert.equal(hex(encodeVariant(2n ** 63n)).slice(0, 2), '03');
  assert.equal(hex(encodeVariant(Variant.u64(5))).slice(0, 2), '03');
  assert.equal(hex(encodeVariant(Variant.i64(5n))).slice(0, 2), '02');
  assert.equal(hex(encodeVariant(Variant.f64(5n))), '040000000000001440');
  assert.equal(hex(encodeVariant(undefined)), '00');
  assert.equal(hex(encodeVariant(new Map([['a', 1.5]]))), '080100000001006104000000000000f83f');
  assert.equal(hex(encodeVariant(new Uint16Array([1]).buffer)), '06020000000100');
  assert.throws(() => encodeVariant(2n ** 64n), RangeError);
  assert.throws(() => encodeVariant(-(2n ** 63n) - 1n), RangeError);
  assert.throws(() => encodeVariant(Symbol('x')), TypeError);
  assert.throws(() => encodeVariant(new Map([[1, 2]])), TypeError);
});

test('bytes decode as a view into the input, never a copy', () => {
  const input = unhex('0603000000010203');
  const out = decodeVariant(input);
  assert.equal(out.buffer, input.buffer);
  assert.equal(out.byteOffset, 5);
});

test('limits: depth 32, counts checked before allocating, one value at most maxBytes', () => {
  let deep = [];
  for (let i = 1; i < MAX_DEPTH; ++i) deep = [deep];
  assert.doesNotThrow(() => encodeVariant(deep));
  assert.throws(() => encodeVariant([deep]), RangeError);
  // A list announcing 2^32-1 elements in 9 bytes: refused at once, nothing allocated.
  assert.throws(() => decodeVariant(unhex('07ffffffff00000000')), /list count 4294967295 exceeds/);
  const big = encodeVariant('x'.repeat(100));
  assert.throws(() => decodeVariant(big, { maxBytes: 50 }), /string length 100 exceeds/);
  assert.equal(decodeVariant(big, { maxBytes: 105 }).length, 100);
});

test('a map key named __proto__ is an ordinary key', () => {
  const out = decodeVariant(unhex('080100000009005f5f70726f746f5f5f0101'));
  assert.equal(Object.getPrototypeOf(out), Object.prototype);
  assert.deepEqual(Object.keys(out), ['__proto__']);
  assert.equal(Object.getOwnPropertyDescriptor(out, '__proto__').value, true);
});
