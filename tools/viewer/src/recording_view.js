// One recording drawn in a Three.js scene: rigid bodies as instanced meshes (one draw per distinct shape
// part, however many bodies share it), soft surfaces as meshes whose vertices are the particles, ropes as
// lines with a sphere per particle. setFrame(k) places everything as frame k of the recording.
import * as THREE from 'three';
import { shapeParts } from './shapes.js';

const COLOURS = { static: 0x8a8f98, kinematic: 0xe0a040 };
const SOFT_COLOUR = 0x4aa3df;
const SENSOR_COLOUR = 0x58d68d; // sensors: translucent green, drawn without hiding what is inside

// A body's colour: static grey, kinematic amber, dynamic ones spread around the hue circle by index so
// neighbours differ (golden-ratio hue steps).
function bodyColour(type, index) {
  if (COLOURS[type] !== undefined) return new THREE.Color(COLOURS[type]);
  return new THREE.Color().setHSL((index * 0.618034) % 1, 0.55, 0.55);
}

export class RecordingView {
  constructor(rec) {
    this.rec = rec;
    this.scene = new THREE.Scene();
    this.scene.background = new THREE.Color(0x1d2128);
    this.scene.add(new THREE.HemisphereLight(0xdde8ff, 0x30302a, 1.6));
    const sun = new THREE.DirectionalLight(0xffffff, 1.8);
    sun.position.set(5, 12, 8);
    this.scene.add(sun);
    this.groups = []; // {mesh (InstancedMesh), bodies: [index], partMatrix}
    this.softs = [];  // {mesh, offset (float index into a frame), count}
    this.bodyMatrix = new THREE.Matrix4();
    this.tmp = new THREE.Matrix4();
    this.pos = new THREE.Vector3();
    this.quat = new THREE.Quaternion();
    this.one = new THREE.Vector3(1, 1, 1);
    this.frame = -1;
    this.showContacts = true;
    this.showJoints = true;
    this.normalLength = 0.1; // m, the drawn length of a contact normal (main.js scales it to the scene)
    this.build();
    this.buildOverlays();
  }

  // Contacts (a red segment along each normal and a point) and joints (a line between the two world
  // anchors, points at both), drawn over the bodies.
  buildOverlays() {
    const h = this.rec.header;
    const overlay = (kind, colour) => {
      const g = new THREE.BufferGeometry();
      g.setAttribute('position', new THREE.BufferAttribute(new Float32Array(0), 3));
      const m = kind === 'lines' ? new THREE.LineSegments(g, new THREE.LineBasicMaterial({ color: colour, depthTest: false }))
        : new THREE.Points(g, new THREE.PointsMaterial({ color: colour, size: 5, sizeAttenuation: false, depthTest: false }));
      m.frustumCulled = false;
      m.renderOrder = 10;
      this.scene.add(m);
      return m;
    };
    this.contactLines = this.rec.contacts ? overlay('lines', 0xff4040) : null;
    this.contactPoints = this.rec.contacts ? overlay('points', 0xffd040) : null;
    this.joints = (h.joints || []).filter((j) => j.a >= 0 || j.b >= 0);
    this.jointLines = this.joints.length ? overlay('lines', 0x80ff80) : null;
    this.jointPoints = this.joints.length ? overlay('points', 0x80ff80) : null;
  }

  static setPositions(object, array, count) {
    const g = object.geometry;
    let attr = g.getAttribute('position');
    if (attr.array.length < array.length) {
      attr = new THREE.BufferAttribute(new Float32Array(Math.max(array.length, 2 * attr.array.length)), 3);
      attr.setUsage(THREE.DynamicDrawUsage);
      g.setAttribute('position', attr);
    }
    attr.array.set(array);
    attr.needsUpdate = true;
    g.setDrawRange(0, count);
  }

  updateOverlays() {
    const k = this.frame;
    if (this.contactLines) {
      const c = this.rec.contacts[k] || new Float32Array(0), n = c.length / 6, L = this.normalLength;
      const lines = new Float32Array(6 * n), points = new Float32Array(3 * n);
      for (let i = 0; i < n; ++i) {
        const o = 6 * i;
        lines.set([c[o], c[o + 1], c[o + 2], c[o] + L * c[o + 3], c[o + 1] + L * c[o + 4], c[o + 2] + L * c[o + 5]], 6 * i);
        points.set([c[o], c[o + 1], c[o + 2]], 3 * i);
      }
      RecordingView.setPositions(this.contactLines, lines, this.showContacts ? 2 * n : 0);
      RecordingView.setPositions(this.contactPoints, points, this.showContacts ? n : 0);
    }
    if (this.jointLines) {
      const lines = [], points = [];
      const world = (b, anchor) => {
        const o = k * this.rec.frameFloats + 1 + 7 * b, v = this.rec.values;
        this.pos.set(anchor[0], anchor[1], anchor[2]);
        this.quat.set(v[o + 4], v[o + 5], v[o + 6], v[o + 3]);
        return this.pos.applyQuaternion(this.quat).add(new THREE.Vector3(v[o], v[o + 1], v[o + 2])).toArray();
      };
      for (const j of this.joints) {
        const a = j.a >= 0 ? world(j.a, j.anchor_a) : null, b = j.b >= 0 ? world(j.b, j.anchor_b) : null;
        if (a && b) lines.push(...a, ...b);
        for (const p of [a, b]) if (p) points.push(...p);
      }
      RecordingView.setPositions(this.jointLines, Float32Array.from(lines), this.showJoints ? lines.length / 3 : 0);
      RecordingView.setPositions(this.jointPoints, Float32Array.from(points), this.showJoints ? points.length / 3 : 0);
    }
  }

  /// Shows or hides the overlays (and redraws them for the current frame).
  setOverlays(contacts, joints) {
    this.showContacts = contacts;
    this.showJoints = joints;
    if (this.frame >= 0) this.updateOverlays();
  }

  build() {
    const h = this.rec.header;
    const cache = new Map();
    const byShape = new Map(); // shape JSON -> [body index]
    h.bodies.forEach((b, i) => {
      const key = JSON.stringify({ shape: b.shape, sensor: b.sensor === true });
      if (!byShape.has(key)) byShape.set(key, []);
      byShape.get(key).push(i);
    });
    for (const [key, bodies] of byShape) {
      const { shape, sensor } = JSON.parse(key);
      const parts = shapeParts(shape, cache);
      for (const part of parts) {
        const material = new THREE.MeshStandardMaterial({ roughness: 0.75, metalness: 0.05,
          side: part.doubleSided || sensor ? THREE.DoubleSide : THREE.FrontSide });
        if (sensor) Object.assign(material, { transparent: true, opacity: 0.25, depthWrite: false });
        const mesh = new THREE.InstancedMesh(part.geometry, material, bodies.length);
        mesh.instanceMatrix.setUsage(THREE.DynamicDrawUsage);
        bodies.forEach((b, k) => mesh.setColorAt(k, sensor ? new THREE.Color(SENSOR_COLOUR) : bodyColour(h.bodies[b].type, b)));
        mesh.frustumCulled = false; // instances move every frame; the bounding sphere is refreshed only for picking
        mesh.userData = { bodies };
        this.scene.add(mesh);
        this.groups.push({ mesh, bodies, partMatrix: part.matrix });
      }
    }
    let offset = 1 + 7 * h.bodies.length;
    h.particles.forEach((p, i) => {
      const positions = new Float32Array(3 * p.count);
      const g = new THREE.BufferGeometry();
      g.setAttribute('position', new THREE.BufferAttribute(positions, 3).setUsage(THREE.DynamicDrawUsage));
      let mesh, beads = null;
      if (p.triangles.length > 0) {
        g.setIndex(p.triangles.flat());
        mesh = new THREE.Mesh(g, new THREE.MeshStandardMaterial({ color: SOFT_COLOUR, roughness: 0.6, side: THREE.DoubleSide }));
      } else {
        mesh = new THREE.Line(g, new THREE.LineBasicMaterial({ color: SOFT_COLOUR }));
        const r = Math.max(p.thickness || 0.02, 0.01);
        if (p.count <= 4096) {
          beads = new THREE.InstancedMesh(new THREE.SphereGeometry(r, 10, 8), new THREE.MeshStandardMaterial({ color: SOFT_COLOUR }), p.count);
          beads.frustumCulled = false;
          beads.userData = { soft: i };
          this.scene.add(beads);
        }
      }
      mesh.frustumCulled = false;
      mesh.userData = { soft: i };
      this.scene.add(mesh);
      this.softs.push({ mesh, beads, offset, count: p.count, positions });
      offset += 3 * p.count;
    });
  }

  /// Places every body and particle as in frame k.
  setFrame(k) {
    const rec = this.rec;
    k = Math.max(0, Math.min(rec.frames - 1, k));
    if (k === this.frame) return;
    this.frame = k;
    const v = rec.values;
    const base = k * rec.frameFloats;
    for (const g of this.groups) {
      g.bodies.forEach((b, i) => {
        const o = base + 1 + 7 * b;
        this.pos.set(v[o], v[o + 1], v[o + 2]);
        this.quat.set(v[o + 4], v[o + 5], v[o + 6], v[o + 3]);
        this.bodyMatrix.compose(this.pos, this.quat, this.one);
        g.mesh.setMatrixAt(i, this.tmp.multiplyMatrices(this.bodyMatrix, g.partMatrix));
      });
      g.mesh.instanceMatrix.needsUpdate = true;
    }
    for (const s of this.softs) {
      s.positions.set(v.subarray(base + s.offset, base + s.offset + 3 * s.count));
      const attr = s.mesh.geometry.getAttribute('position');
      attr.needsUpdate = true;
      if (s.mesh.isMesh) s.mesh.geometry.computeVertexNormals();
      if (s.beads) {
        for (let i = 0; i < s.count; ++i) {
          this.tmp.makeTranslation(s.positions[3 * i], s.positions[3 * i + 1], s.positions[3 * i + 2]);
          s.beads.setMatrixAt(i, this.tmp);
        }
        s.beads.instanceMatrix.needsUpdate = true;
      }
    }
    this.updateOverlays();
  }

  /// Body k's position in the current frame.
  bodyPosition(b) {
    const o = this.frame * this.rec.frameFloats + 1 + 7 * b;
    return new THREE.Vector3(this.rec.values[o], this.rec.values[o + 1], this.rec.values[o + 2]);
  }

  /// The body or soft body a ray hits first: {kind: 'body'|'soft', index, point} or null.
  pick(raycaster) {
    const targets = [];
    for (const g of this.groups) { g.mesh.computeBoundingSphere(); targets.push(g.mesh); }
    for (const s of this.softs) { s.mesh.geometry.computeBoundingSphere(); targets.push(s.mesh); }
    const hits = raycaster.intersectObjects(targets, false);
    for (const hit of hits) {
      const ud = hit.object.userData;
      if (ud.bodies !== undefined && hit.instanceId !== undefined) return { kind: 'body', index: ud.bodies[hit.instanceId], point: hit.point };
      if (ud.soft !== undefined) return { kind: 'soft', index: ud.soft, point: hit.point };
    }
    return null;
  }

  /// Centre and radius of what moves (dynamic and kinematic bodies, particles) in frame k, for the camera;
  /// falls back to every body when nothing moves.
  bounds(k) {
    const rec = this.rec, h = rec.header, v = rec.values, base = k * rec.frameFloats;
    const box = new THREE.Box3();
    const addPoint = (x, y, z) => { if (Number.isFinite(x + y + z)) box.expandByPoint(new THREE.Vector3(x, y, z)); };
    h.bodies.forEach((b, i) => {
      if (b.type === 'static') return;
      const o = base + 1 + 7 * i;
      addPoint(v[o], v[o + 1], v[o + 2]);
    });
    for (const s of this.softs)
      for (let i = 0; i < s.count; ++i) addPoint(v[base + s.offset + 3 * i], v[base + s.offset + 3 * i + 1], v[base + s.offset + 3 * i + 2]);
    if (box.isEmpty()) h.bodies.forEach((b, i) => { const o = base + 1 + 7 * i; addPoint(v[o], v[o + 1], v[o + 2]); });
    if (box.isEmpty()) box.expandByPoint(new THREE.Vector3());
    const sphere = box.getBoundingSphere(new THREE.Sphere());
    sphere.radius = Math.max(sphere.radius + 1, 2);
    return sphere;
  }

  /// What was drawn: instanced bodies, soft meshes, ropes.
  stats() {
    let bodies = 0;
    const counted = new Set();
    for (const g of this.groups) for (const b of g.bodies) counted.add(b);
    bodies = counted.size;
    const drawn = (o) => (o ? o.geometry.drawRange.count : 0);
    return { bodies, softBodies: this.softs.length, drawCalls: this.groups.length + this.softs.length,
      contacts: drawn(this.contactPoints), jointLines: drawn(this.jointLines) / 2, jointAnchors: drawn(this.jointPoints) };
  }
}
