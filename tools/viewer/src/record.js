// Reads a sinew-record file (docs/record-format.md) into one Float32Array of frames, whatever its encoding:
// frame k occupies values[k * frameFloats ...] as [time, per body px py pz qw qx qy qz, per soft body x y z...].
// Every problem is a RecordError whose message names the file and the line (or byte) where it was found;
// a truncated last frame is dropped with a warning, so a run cut short still plays.

const SHAPE_TYPES = new Set(['sphere', 'box', 'capsule', 'convex_hull', 'plane', 'triangle_mesh', 'compound']);

export class RecordError extends Error {}

function fail(name, where, what) {
  throw new RecordError(`${name}: ${where}: ${what}`);
}

function checkShape(name, where, s) {
  if (!s || typeof s !== 'object') fail(name, where, 'shape is missing');
  if (!SHAPE_TYPES.has(s.type)) fail(name, where, `unknown shape type "${s.type}"`);
  const num = (v) => typeof v === 'number' && Number.isFinite(v);
  const vec = (v) => Array.isArray(v) && v.length === 3 && v.every(num);
  switch (s.type) {
    case 'sphere': if (!num(s.radius)) fail(name, where, 'sphere needs a finite "radius"'); break;
    case 'box': if (!vec(s.half_extents)) fail(name, where, 'box needs "half_extents" [x,y,z]'); break;
    case 'capsule': if (!num(s.radius) || !num(s.half_height)) fail(name, where, 'capsule needs "radius" and "half_height"'); break;
    case 'convex_hull': if (!Array.isArray(s.points) || s.points.length < 4 || !s.points.every(vec)) fail(name, where, 'convex_hull needs at least 4 "points"'); break;
    case 'plane': if (!vec(s.normal) || !num(s.offset)) fail(name, where, 'plane needs "normal" and "offset"'); break;
    case 'triangle_mesh':
      if (!Array.isArray(s.vertices) || !s.vertices.every(vec)) fail(name, where, 'triangle_mesh needs "vertices"');
      if (!Array.isArray(s.indices) || !s.indices.every((t) => Array.isArray(t) && t.length === 3 && t.every((i) => Number.isInteger(i) && i >= 0 && i < s.vertices.length)))
        fail(name, where, 'triangle_mesh "indices" must be [[a,b,c],...] within its vertices');
      break;
    case 'compound':
      if (!Array.isArray(s.children) || s.children.length === 0) fail(name, where, 'compound needs "children"');
      s.children.forEach((c, i) => checkShape(name, `${where}.children[${i}]`, c && c.shape));
      break;
  }
}

function checkHeader(name, h) {
  const where = 'line 1 (header)';
  if (!h || typeof h !== 'object' || h.format !== 'sinew-record')
    fail(name, where, 'not a sinew-record file (the first line must be a JSON object with "format": "sinew-record")');
  if (h.version !== 1 && h.version !== 2) fail(name, where, `version ${h.version} is not one this viewer reads (1 or 2)`);
  if (!Array.isArray(h.bodies)) fail(name, where, '"bodies" must be an array');
  if (!Array.isArray(h.particles)) fail(name, where, '"particles" must be an array');
  h.bodies.forEach((b, i) => {
    if (!b || typeof b.name !== 'string') fail(name, `${where}: bodies[${i}]`, 'needs a "name"');
    checkShape(name, `${where}: body "${b.name}"`, b.shape);
  });
  if (h.joints !== undefined) {
    if (!Array.isArray(h.joints)) fail(name, where, '"joints" must be an array');
    const vec = (v) => Array.isArray(v) && v.length === 3 && v.every((x) => typeof x === 'number');
    h.joints.forEach((j, i) => {
      const end = (k) => Number.isInteger(k) && k >= -1 && k < h.bodies.length;
      if (!j || !end(j.a) || !end(j.b) || !vec(j.anchor_a) || !vec(j.anchor_b))
        fail(name, `${where}: joints[${i}]`, `needs "a" and "b" (body indices, -1 for none) and "anchor_a", "anchor_b" [x,y,z]`);
    });
  }
  h.particles.forEach((p, i) => {
    if (!p || !Number.isInteger(p.count) || p.count < 0) fail(name, `${where}: particles[${i}]`, 'needs an integer "count"');
    if (!Array.isArray(p.triangles)) fail(name, `${where}: particles[${i}]`, 'needs "triangles" (may be empty)');
    for (const t of p.triangles)
      if (!Array.isArray(t) || t.length !== 3 || !t.every((k) => Number.isInteger(k) && k >= 0 && k < p.count))
        fail(name, `${where}: soft body "${p.name}"`, `triangle [${t}] refers to a particle outside 0..${p.count - 1}`);
  });
}

/// frameFloats for a header: time, 7 per body, 3 per particle.
export function frameFloatsOf(h) {
  return 1 + 7 * h.bodies.length + 3 * h.particles.reduce((n, p) => n + p.count, 0);
}

/// Parses `buffer` (ArrayBuffer) of the file `name`. Returns {name, header, frames, frameFloats, values,
/// contacts (null, or per frame a Float32Array of x y z nx ny nz per contact), warnings}.
export function parseRecording(name, buffer) {
  const bytes = new Uint8Array(buffer);
  if (bytes.length === 0) fail(name, 'line 1', 'the file is empty');
  const nl = bytes.indexOf(10);
  const headerEnd = nl < 0 ? bytes.length : nl;
  let header;
  try {
    header = JSON.parse(new TextDecoder('utf-8', { fatal: false }).decode(bytes.subarray(0, headerEnd)));
  } catch (e) {
    fail(name, 'line 1 (header)', `not JSON (${e.message}); is this a sinew-record file?`);
  }
  checkHeader(name, header);
  const frameFloats = frameFloatsOf(header);
  const warnings = [];
  let values, frames;
  const contacts = header.contacts === true ? [] : null; // per frame: Float32Array of x y z nx ny nz per point
  if (header.encoding === 'float32') {
    if (header.frame_floats !== frameFloats)
      fail(name, 'line 1 (header)', `"frame_floats" is ${header.frame_floats}, but the bodies and particles need ${frameFloats}`);
    const start = headerEnd + 1;
    const avail = Math.max(0, bytes.length - start);
    if (!contacts) {
      const bytesPerFrame = 4 * frameFloats;
      frames = Math.floor(avail / bytesPerFrame);
      if (avail % bytesPerFrame !== 0)
        warnings.push(`${name}: truncated: the file ends ${avail % bytesPerFrame} bytes into frame ${frames} (byte ${bytes.length}); that frame is dropped`);
      // One copy to an aligned buffer: the header's length puts the frames at any byte offset.
      values = new Float32Array(bytes.slice(start, start + frames * bytesPerFrame).buffer);
    } else {
      // Frames of different lengths: the fixed part, a contact count, then 6 values per contact.
      const all = new Float32Array(bytes.slice(start, start + avail - (avail % 4)).buffer);
      const fixed = [];
      let at = 0;
      for (;;) {
        if (at === all.length && avail % 4 === 0) break;
        const count = all[at + frameFloats];
        const size = frameFloats + 1 + 6 * count;
        if (at + frameFloats + 1 > all.length || !Number.isInteger(count) || count < 0 || at + size > all.length) {
          if (!Number.isInteger(count) && at + frameFloats + 1 <= all.length) fail(name, `frame ${fixed.length} (byte ${start + 4 * (at + frameFloats)})`, `contact count ${count} is not a whole number`);
          warnings.push(`${name}: truncated: the file ends inside frame ${fixed.length} (byte ${bytes.length}); that frame is dropped`);
          break;
        }
        fixed.push(all.subarray(at, at + frameFloats));
        contacts.push(all.subarray(at + frameFloats + 1, at + size));
        at += size;
      }
      frames = fixed.length;
      values = new Float32Array(frames * frameFloats);
      fixed.forEach((f, k) => values.set(f, k * frameFloats));
    }
  } else if (header.encoding === undefined || header.encoding === 'json') {
    const text = new TextDecoder('utf-8').decode(bytes.subarray(headerEnd + 1));
    const lines = text.split('\n');
    if (lines.length && lines[lines.length - 1] === '') lines.pop();
    values = new Float32Array(lines.length * frameFloats);
    frames = 0;
    for (let i = 0; i < lines.length; ++i) {
      const lineNo = i + 2;
      let f;
      try {
        f = JSON.parse(lines[i]);
      } catch (e) {
        if (i === lines.length - 1 && !text.endsWith('\n')) {
          warnings.push(`${name}: truncated: line ${lineNo} (frame ${i}) is incomplete and is dropped`);
          break;
        }
        fail(name, `line ${lineNo}`, `not JSON (${e.message})`);
      }
      const base = frames * frameFloats;
      if (!f || typeof f.time !== 'number') fail(name, `line ${lineNo}`, 'a frame needs a numeric "time"');
      if (!Array.isArray(f.bodies) || f.bodies.length !== header.bodies.length)
        fail(name, `line ${lineNo}`, `"bodies" has ${Array.isArray(f.bodies) ? f.bodies.length : 'no'} entries, the header names ${header.bodies.length}`);
      if (!Array.isArray(f.particles) || f.particles.length !== header.particles.length)
        fail(name, `line ${lineNo}`, `"particles" has ${Array.isArray(f.particles) ? f.particles.length : 'no'} entries, the header names ${header.particles.length}`);
      if (contacts) {
        if (!Array.isArray(f.contacts) || f.contacts.length % 6 !== 0)
          fail(name, `line ${lineNo}`, '"contacts" must hold 6 numbers per contact (the header says frames carry contacts)');
        contacts.push(Float32Array.from(f.contacts, (v) => (v === null ? NaN : v)));
      }
      values[base] = f.time;
      let k = base + 1;
      f.bodies.forEach((b, j) => {
        if (!Array.isArray(b) || b.length !== 7) fail(name, `line ${lineNo}`, `body ${j} ("${header.bodies[j].name}") needs 7 numbers [px,py,pz,qw,qx,qy,qz]`);
        for (const v of b) values[k++] = v === null ? NaN : v;
      });
      f.particles.forEach((p, j) => {
        const n = 3 * header.particles[j].count;
        if (!Array.isArray(p) || p.length !== n) fail(name, `line ${lineNo}`, `soft body ${j} ("${header.particles[j].name}") needs ${n} numbers, has ${Array.isArray(p) ? p.length : 'none'}`);
        for (const v of p) values[k++] = v === null ? NaN : v;
      });
      ++frames;
    }
    values = values.subarray(0, frames * frameFloats);
  } else {
    fail(name, 'line 1 (header)', `unknown "encoding" "${header.encoding}" (json or float32)`);
  }
  if (frames === 0) fail(name, 'frames', 'the file has a header but no complete frame');
  for (let f = 0; f < frames; ++f) {
    const t = values[f * frameFloats];
    if (!Number.isFinite(t)) { warnings.push(`${name}: frame ${f} has a non-finite time; playback stops before it`); frames = f; break; }
  }
  if (frames === 0) fail(name, 'frames', 'no frame has a finite time');
  if (contacts) contacts.length = frames;
  return { name, header, frames, frameFloats, values, contacts, warnings };
}

/// The frame whose time is the latest at or before `t` (frames are in time order).
export function frameAtTime(rec, t) {
  let lo = 0, hi = rec.frames - 1;
  if (t <= rec.values[0]) return 0;
  while (lo < hi) {
    const mid = (lo + hi + 1) >> 1;
    if (rec.values[mid * rec.frameFloats] <= t + 1e-9) lo = mid; else hi = mid - 1;
  }
  return lo;
}

export function frameTime(rec, k) { return rec.values[k * rec.frameFloats]; }
