// SPDX-License-Identifier: Apache-2.0
// The avatar's voice: PCM frames from the hub played in order of their sample counter, and the
// viseme timeline of each utterance on the same clock, so the lips move with the sound.
import { FORMAT, parseFrame } from './media-frame.js';

const LEAD_S = 0.12; // scheduling margin before the first sample plays

export class Voice {
  constructor() {
    this.ctx = new AudioContext();
    this.utterances = new Map(); // utterance id -> { startSeq, rate, visemes, startTime, end }
    this.current = null;
    this.framesReceived = 0;
    this.framesPlayed = 0;
  }

  resume() { return this.ctx.resume(); }

  // A "speech" command: the timeline of an utterance whose audio follows.
  onSpeech(msg) {
    this.utterances.set(msg.utterance, {
      id: msg.utterance, startSeq: msg.start_seq, rate: msg.sample_rate, visemes: msg.visemes,
      durationMs: msg.duration_ms, startTime: null, text: msg.text || '',
    });
  }

  onFrame(buffer) {
    const f = parseFrame(buffer);
    if (!f || f.format !== FORMAT.pcm || f.channels !== 1) return;
    this.framesReceived++;
    const u = this.utteranceOf(f.seq);
    const pcm = new Int16Array(f.payload);
    const audio = this.ctx.createBuffer(1, pcm.length, f.sampleRate);
    const data = audio.getChannelData(0);
    for (let i = 0; i < pcm.length; i++) data[i] = pcm[i] / 32768;
    if (u.startTime === null) {
      u.startTime = this.ctx.currentTime + LEAD_S;
      this.current = u;
    }
    const at = u.startTime + (f.seq - u.startSeq) / f.sampleRate;
    const src = this.ctx.createBufferSource();
    src.buffer = audio;
    src.connect(this.ctx.destination);
    src.onended = () => { this.framesPlayed++; };
    src.start(Math.max(at, this.ctx.currentTime));
  }

  utteranceOf(seq) {
    let best = null;
    for (const u of this.utterances.values()) {
      if (seq >= u.startSeq && (!best || u.startSeq > best.startSeq)) best = u;
    }
    if (best) return best;
    // Audio without a timeline: play it, with the mouth at rest.
    const u = { id: -1, startSeq: seq, rate: 22050, visemes: [], durationMs: 0, startTime: null };
    this.utterances.set(`orphan-${seq}`, u);
    return u;
  }

  // The mouth shape now: { open, wide, round } of the viseme playing, whether the avatar is
  // speaking, and the utterance's viseme timeline with the time on it (ms).
  mouth() {
    const u = this.current;
    const rest = { open: 0, wide: 0, round: 0, speaking: false };
    if (!u || u.startTime === null) return rest;
    const ms = (this.ctx.currentTime - u.startTime) * 1000;
    if (ms < 0 || ms > u.durationMs + 50) return rest;
    let shape = null;
    for (const v of u.visemes) {
      if (v.t_ms > ms) break;
      shape = v;
    }
    // The timeline and the time on it go along: the avatar blends the shapes (coarticulation).
    const on = { speaking: true, text: u.text, timeline: u.visemes, ms };
    if (!shape) return { ...rest, ...on };
    return { open: shape.open, wide: shape.wide, round: shape.round, viseme: shape.v, ...on };
  }
}
