// SPDX-License-Identifier: Apache-2.0
// The JavaScript values of tests/js/vectors/variant.json's good vectors, by name: variant.test.mjs
// decodes each vector's hex to exactly this value and encodes this value to exactly that hex.
import { Variant } from '../../../satellite/js/src/node.js';

const deep = (n) => (n === 0 ? [] : [deep(n - 1)]);

export const VALUES = {
  null: null,
  true: true,
  false: false,
  int_one: 1n,
  int_minus_one: -1n,
  int64_min: -(2n ** 63n),
  int64_max: 2n ** 63n - 1n,
  uint64_2_63: 2n ** 63n,
  uint64_max: 2n ** 64n - 1n,
  float_1_5: 1.5,
  float_two: Variant.f64(2),
  float_minus_zero: -0,
  float_tiny: 5e-324,
  string_hi: 'hi',
  string_empty: '',
  string_utf8: 'é€😀',
  bytes: new Uint8Array([1, 2, 255]),
  bytes_empty: new Uint8Array(0),
  list_empty: [],
  list_true_null: [true, null],
  map_a_1_5: { a: 1.5 },
  map_empty: {},
  map_nested: { a: [1n, { x: 'y' }], b: { c: null } },
  depth_32: deep(31),
};

// What the value decodes to when it differs from what is encoded (a forced type).
export const DECODED = { float_two: 2 };
