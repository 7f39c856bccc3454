// SPDX-License-Identifier: Apache-2.0
// Detections drawn over the camera preview: face boxes, motion centre and regions, QR codes.
// Coordinates arrive in pixels of the analysed frame and are scaled to the canvas.
const FRESH_MS = 700;

export class Overlay {
  constructor(canvas) {
    this.canvas = canvas;
    this.ctx = canvas.getContext('2d');
    this.faces = null;
    this.motion = null;
    this.codes = null;
    this.boxesDrawn = 0;
  }

  set(kind, data) {
    this[kind] = { data, at: performance.now() };
  }

  draw() {
    const { ctx, canvas } = this;
    ctx.clearRect(0, 0, canvas.width, canvas.height);
    const now = performance.now();
    const fresh = (x) => x && now - x.at < FRESH_MS;
    const scale = (d) => [canvas.width / (d.width || canvas.width), canvas.height / (d.height || canvas.height)];
    if (fresh(this.motion)) {
      const d = this.motion.data;
      const [sx, sy] = scale(d);
      ctx.strokeStyle = 'rgba(255, 200, 0, 0.8)';
      ctx.lineWidth = 1;
      for (const r of d.regions || []) ctx.strokeRect(r.x * sx, r.y * sy, r.w * sx, r.h * sy);
      if (d.center) {
        const x = d.center.x * sx;
        const y = d.center.y * sy;
        ctx.beginPath();
        ctx.moveTo(x - 8, y); ctx.lineTo(x + 8, y); ctx.moveTo(x, y - 8); ctx.lineTo(x, y + 8);
        ctx.stroke();
      }
    }
    if (fresh(this.faces)) {
      const d = this.faces.data;
      const [sx, sy] = scale(d);
      ctx.strokeStyle = '#3cf07a';
      ctx.lineWidth = 3;
      for (const f of d.faces || []) {
        ctx.strokeRect(f.x * sx, f.y * sy, f.w * sx, f.h * sy);
        this.boxesDrawn++;
      }
    }
    if (fresh(this.codes)) {
      const d = this.codes.data;
      const [sx, sy] = scale(d);
      ctx.strokeStyle = '#4aa3ff';
      ctx.lineWidth = 2;
      for (const c of d.codes || []) {
        if (!c.corners || c.corners.length < 3) continue;
        ctx.beginPath();
        c.corners.forEach(([x, y], i) => (i ? ctx.lineTo(x * sx, y * sy) : ctx.moveTo(x * sx, y * sy)));
        ctx.closePath();
        ctx.stroke();
      }
    }
  }
}
