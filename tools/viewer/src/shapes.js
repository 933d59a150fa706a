// Three.js geometry for the scene format's shapes (docs/scene-format.md#shapes), as a list of parts, each a
// geometry placed in the body's frame: a compound gives one part per child. Geometries are shared between
// bodies of the same shape, so a pyramid of 5,500 equal boxes is one instanced draw.
import * as THREE from 'three';
import { ConvexGeometry } from 'three/addons/geometries/ConvexGeometry.js';

const PLANE_SIZE = 200; // a plane is drawn as a square this wide (m) around its point nearest the origin

function quatOf(q) { return new THREE.Quaternion(q[1], q[2], q[3], q[0]); } // files are [w,x,y,z]

function leafGeometry(s) {
  switch (s.type) {
    case 'sphere': return new THREE.SphereGeometry(s.radius, 24, 16);
    case 'box': return new THREE.BoxGeometry(2 * s.half_extents[0], 2 * s.half_extents[1], 2 * s.half_extents[2]);
    case 'capsule': return new THREE.CapsuleGeometry(s.radius, 2 * s.half_height, 8, 16); // along local y, as Sinew's
    case 'convex_hull': return new ConvexGeometry(s.points.map((p) => new THREE.Vector3(p[0], p[1], p[2])));
    case 'plane': {
      const g = new THREE.PlaneGeometry(PLANE_SIZE, PLANE_SIZE);
      const n = new THREE.Vector3(...s.normal).normalize();
      g.applyQuaternion(new THREE.Quaternion().setFromUnitVectors(new THREE.Vector3(0, 0, 1), n));
      g.translate(n.x * s.offset, n.y * s.offset, n.z * s.offset);
      return g;
    }
    case 'triangle_mesh': {
      const g = new THREE.BufferGeometry();
      g.setAttribute('position', new THREE.Float32BufferAttribute(s.vertices.flat(), 3));
      g.setIndex(s.indices.flat());
      g.computeVertexNormals();
      return g;
    }
    default: throw new Error(`no geometry for shape type ${s.type}`);
  }
}

/// [{geometry, matrix (THREE.Matrix4 in the body frame), doubleSided}] for a shape; `cache` maps a shape's
/// JSON to its parts.
export function shapeParts(shape, cache) {
  const key = JSON.stringify(shape);
  if (cache.has(key)) return cache.get(key);
  const parts = [];
  const add = (s, m) => {
    if (s.type === 'compound') {
      for (const c of s.children) {
        const local = new THREE.Matrix4().compose(new THREE.Vector3(...(c.position || [0, 0, 0])),
          quatOf(c.rotation || [1, 0, 0, 0]), new THREE.Vector3(1, 1, 1));
        add(c.shape, m.clone().multiply(local));
      }
      return;
    }
    parts.push({ geometry: leafGeometry(s), matrix: m, doubleSided: s.type === 'plane' || s.type === 'triangle_mesh' });
  };
  add(shape, new THREE.Matrix4());
  cache.set(key, parts);
  return parts;
}
