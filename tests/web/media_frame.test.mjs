// SPDX-License-Identifier: Apache-2.0
// The pages' media frames (web/js/media-frame.js) in node: every format code of media-codes.js
// (generated from media_frame.hpp) parses, a raw payload of the wrong size is refused as the C++
// parser refuses it, and raw frames become the RGBA bytes of a canvas.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import {
  ENCODINGS, FORMAT, HEADER_BYTES, isRawImage, makeFrame, parseFrame, rawPayloadBytes, rawToRgba,
} from '../../web/js/media-frame.js';

const video = (encoding, width, height, pixels) =>
  makeFrame({ format: FORMAT[encoding], seq: 7, captureMs: 1000, width, height }, new Uint8Array(pixels));
const rgba = (frame) => [...rawToRgba(parseFrame(frame))];

test('the format codes are the table of media_frame.hpp, with the pages\' older names', () => {
  assert.deepEqual(ENCODINGS.map((e) => [e.encoding, e.format]), [
    ['jpeg', 1], ['mono8', 2], ['s16le', 3], ['rgb8', 4], ['bgr8', 5], ['rgba8', 6], ['bgra8', 7],
    ['mono16', 8], ['nv12', 9], ['i420', 10]]);
  assert.equal(FORMAT.y8, FORMAT.mono8);
  assert.equal(FORMAT.pcm, FORMAT.s16le);
  assert.equal(HEADER_BYTES, 32);
});

test('every raw encoding parses at its exact size and is refused one byte off', () => {
  const raw = ENCODINGS.filter((e) => e.bitsPerPixel !== 0);
  assert.equal(raw.length, 8);
  for (const e of raw) {
    const bytes = rawPayloadBytes(e, 4, 2);
    assert.equal(bytes, 4 * 2 * e.bitsPerPixel / 8, e.encoding);
    const f = parseFrame(video(e.encoding, 4, 2, new Uint8Array(bytes)));
    assert.ok(f, `${e.encoding} parses`);
    assert.deepEqual([f.format, f.encoding, f.width, f.height, f.seq, f.captureNs, f.payload.byteLength],
      [e.format, e.encoding, 4, 2, 7, 1000000000n, bytes]);
    assert.ok(isRawImage(f));
    assert.equal(rawToRgba(f).length, 4 * 2 * 4);
    assert.equal(parseFrame(video(e.encoding, 4, 2, new Uint8Array(bytes - 1))), null, `${e.encoding} short`);
    assert.equal(parseFrame(video(e.encoding, 4, 2, new Uint8Array(bytes + 1))), null, `${e.encoding} long`);
    assert.equal(parseFrame(video(e.encoding, 0, 2, new Uint8Array(0))), null, `${e.encoding} no width`);
  }
  // Chroma at half resolution: an odd width or height is refused.
  assert.equal(parseFrame(video('nv12', 3, 2, new Uint8Array(9))), null);
  assert.equal(parseFrame(video('i420', 2, 3, new Uint8Array(9))), null);
});

test('JPEG and audio parse; bad audio and unknown formats are refused', () => {
  const jpeg = parseFrame(video('jpeg', 640, 360, [0xff, 0xd8, 0xff, 0xd9]));
  assert.deepEqual([jpeg.encoding, jpeg.width, jpeg.height, jpeg.payload.byteLength], ['jpeg', 640, 360, 4]);
  assert.equal(isRawImage(jpeg), false);
  assert.equal(rawToRgba(jpeg), null);
  const pcm = (channels, sampleRate, bytes) => makeFrame(
    { format: FORMAT.pcm, seq: 480, captureMs: 0, channels, sampleRate }, new Uint8Array(bytes));
  const a = parseFrame(pcm(2, 48000, 8));
  assert.deepEqual([a.encoding, a.channels, a.sampleRate, a.width, a.height, a.seq], ['s16le', 2, 48000, 0, 0, 480]);
  assert.equal(parseFrame(pcm(2, 48000, 6)), null, 'a partial sample');
  assert.equal(parseFrame(pcm(0, 48000, 8)), null, 'no channels');
  assert.equal(parseFrame(pcm(1, 0, 8)), null, 'no rate');
  const unknown = video('jpeg', 2, 2, [1, 2]);
  new DataView(unknown).setUint8(6, 11);
  assert.equal(parseFrame(unknown), null, 'format 11');
  assert.equal(parseFrame(new ArrayBuffer(31)), null, 'shorter than the header');
});

test('packed pixels become RGBA', () => {
  const px = [10, 20, 30, 40, 50, 60, 70, 80, 90, 100, 110, 120];
  assert.deepEqual(rgba(video('rgb8', 2, 2, px)),
    [10, 20, 30, 255, 40, 50, 60, 255, 70, 80, 90, 255, 100, 110, 120, 255]);
  assert.deepEqual(rgba(video('bgr8', 2, 2, px)),
    [30, 20, 10, 255, 60, 50, 40, 255, 90, 80, 70, 255, 120, 110, 100, 255]);
  const px4 = [1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16];
  assert.deepEqual(rgba(video('rgba8', 2, 2, px4)), px4);
  assert.deepEqual(rgba(video('bgra8', 2, 2, px4)), [3, 2, 1, 4, 7, 6, 5, 8, 11, 10, 9, 12, 15, 14, 13, 16]);
});

test('mono8 and mono16 become gray (mono16: its high byte, little-endian)', () => {
  assert.deepEqual(rgba(video('mono8', 2, 2, [0, 85, 170, 255])),
    [0, 0, 0, 255, 85, 85, 85, 255, 170, 170, 170, 255, 255, 255, 255, 255]);
  assert.deepEqual(rgba(video('mono16', 2, 2, [0x34, 0x12, 0x00, 0xff, 0xff, 0x00, 0x00, 0x80])),
    [0x12, 0x12, 0x12, 255, 0xff, 0xff, 0xff, 255, 0, 0, 0, 255, 0x80, 0x80, 0x80, 255]);
});

test('nv12 and i420 become RGBA (BT.601 limited range, as OpenCV): black left, red right', () => {
  // 4x2: Y 16 (black) in the left 2x2 block, 81 in the right one; chroma (128, 128) left,
  // (90, 240) right: BT.601's red.
  const y = [16, 16, 81, 81, 16, 16, 81, 81];
  const black = [0, 0, 0, 255];
  const red = [255, 0, 0, 255];
  const want = [...black, ...black, ...red, ...red, ...black, ...black, ...red, ...red];
  assert.deepEqual(rgba(video('nv12', 4, 2, [...y, 128, 128, 90, 240])), want);
  assert.deepEqual(rgba(video('i420', 4, 2, [...y, 128, 90, 128, 240])), want);
  // Gray: Y 235 is white, neutral chroma.
  assert.deepEqual(rgba(video('i420', 2, 2, [235, 235, 235, 235, 128, 128])).slice(0, 4), [255, 255, 255, 255]);
});
