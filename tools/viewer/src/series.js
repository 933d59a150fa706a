// Time series drawn under the views: how fast things move in each recording, and how far each recording
// is from the reference one (a comparison's "reference" run if present, else the first).
import { frameAtTime, frameTime } from './record.js';

// Indices (into a frame) of the x of every moving point: non-static bodies' origins and every particle.
function movingPoints(rec) {
  const h = rec.header, idx = [];
  h.bodies.forEach((b, i) => { if (b.type !== 'static') idx.push(1 + 7 * i); });
  let o = 1 + 7 * h.bodies.length;
  for (const p of h.particles) for (let i = 0; i < p.count; ++i, o += 3) idx.push(o);
  return idx;
}

/// Mean speed (m/s) of the moving points at every frame, from the positions of consecutive frames.
export function meanSpeed(rec) {
  const idx = movingPoints(rec), v = rec.values, n = rec.frameFloats;
  const out = new Array(rec.frames).fill(0);
  if (idx.length === 0) return out;
  for (let k = 1; k < rec.frames; ++k) {
    const dt = v[k * n] - v[(k - 1) * n];
    if (!(dt > 0)) { out[k] = out[k - 1]; continue; }
    let sum = 0;
    for (const o of idx) {
      const dx = v[k * n + o] - v[(k - 1) * n + o], dy = v[k * n + o + 1] - v[(k - 1) * n + o + 1], dz = v[k * n + o + 2] - v[(k - 1) * n + o + 2];
      sum += Math.sqrt(dx * dx + dy * dy + dz * dz) / dt;
    }
    out[k] = sum / idx.length;
  }
  return out;
}

/// Whether two recordings hold the same bodies and particles (so their positions can be compared).
export function comparable(a, b) {
  const ha = a.header, hb = b.header;
  return ha.bodies.length === hb.bodies.length && ha.particles.length === hb.particles.length &&
    ha.particles.every((p, i) => p.count === hb.particles[i].count);
}

/// RMS distance (m) of the moving points of `rec` from the same points of `ref` at the same time.
export function rmsDistance(rec, ref) {
  const idx = movingPoints(rec), v = rec.values, w = ref.values, n = rec.frameFloats, m = ref.frameFloats;
  const out = new Array(rec.frames).fill(null);
  if (idx.length === 0 || !comparable(rec, ref)) return out;
  for (let k = 0; k < rec.frames; ++k) {
    const j = frameAtTime(ref, frameTime(rec, k));
    let sum = 0;
    for (const o of idx) {
      const dx = v[k * n + o] - w[j * m + o], dy = v[k * n + o + 1] - w[j * m + o + 1], dz = v[k * n + o + 2] - w[j * m + o + 2];
      sum += dx * dx + dy * dy + dz * dz;
    }
    out[k] = Math.sqrt(sum / idx.length);
  }
  return out;
}

/// The recording the others are measured against: one named "...reference..." if any, else the first.
export function referenceIndex(recs) {
  const i = recs.findIndex((r) => /reference/i.test(r.name));
  return i >= 0 ? i : 0;
}
