// The goal-task scene of a rollout as three.js objects: location targets (a translucent disc and a
// ring of the target's radius on the floor), heading arrows (an ArrowHelper from the root at floor
// level, as long as the target speed covers in one second) and rigid boxes (the strike box, with
// its per-frame pose). No renderer or DOM: unit-tested with vitest in node.
import * as THREE from 'three';
import { sceneAt } from './rollout.js';
import { ARROW_COLOR, OBJECT_COLOR, TARGET_COLOR } from './colors.js';

/** Height above the floor (m) at which the flat markers are drawn (avoids z-fighting with it). */
export const FLOOR_OFFSET = 0.01;
/** Shortest arrow drawn (m), so that a target speed of 0 still shows the direction. */
export const MIN_ARROW_LENGTH = 0.25;
/** Radius (m) of the arrow's shaft. */
const SHAFT_RADIUS = 0.02;

/** Length (m) of the arrow of a heading goal with target speed `speed` (m/s): the distance covered in 1 s. */
export function arrowLength(speed) {
  return Math.max(speed, MIN_ARROW_LENGTH);
}

function maxPerFrame(rows) {
  return rows ? Math.max(0, ...rows.map((r) => r.length)) : 0;
}

export class SceneGoals {
  /** @param rollout a parsed rollout (parseRollout); builds nothing when it has no scene. */
  constructor(rollout) {
    this.rollout = rollout;
    this.group = new THREE.Group();
    this.group.name = 'scene-goals';
    const sc = rollout.scene;
    // Pools sized for the busiest frame; update() shows as many as the frame has.
    this.targets = [];
    this.arrows = [];
    this.objects = [];
    if (!sc) return;
    const discMat = new THREE.MeshBasicMaterial({ color: TARGET_COLOR, transparent: true, opacity: 0.3, depthWrite: false, side: THREE.DoubleSide });
    const ringMat = new THREE.MeshBasicMaterial({ color: TARGET_COLOR, side: THREE.DoubleSide });
    const disc = new THREE.CircleGeometry(1, 48);  // unit radius in the xy plane (the floor), scaled per target
    const ring = new THREE.RingGeometry(0.92, 1, 48);
    for (let k = 0; k < maxPerFrame(sc.targets); ++k) {
      const marker = new THREE.Group();
      marker.name = `target-${k}`;
      marker.add(new THREE.Mesh(disc, discMat), new THREE.Mesh(ring, ringMat));
      this.group.add(marker);
      this.targets.push(marker);
    }
    // ArrowHelper's shaft is a 1-pixel line; a thin cylinder inside it (a child of the line, so
    // it follows the line's length) makes it visible from the usual camera distance.
    const shaftGeometry = new THREE.CylinderGeometry(SHAFT_RADIUS, SHAFT_RADIUS, 1, 12).translate(0, 0.5, 0);
    const shaftMat = new THREE.MeshBasicMaterial({ color: ARROW_COLOR });
    for (let k = 0; k < maxPerFrame(sc.arrows); ++k) {
      const arrow = new THREE.ArrowHelper(new THREE.Vector3(1, 0, 0), new THREE.Vector3(), 1, ARROW_COLOR);
      arrow.line.add(new THREE.Mesh(shaftGeometry, shaftMat));
      arrow.name = `arrow-${k}`;
      this.group.add(arrow);
      this.arrows.push(arrow);
    }
    for (const o of sc.objects) {
      const [hx, hy, hz] = o.halfSize;
      const geometry = new THREE.BoxGeometry(2 * hx, 2 * hy, 2 * hz);
      const mesh = new THREE.Mesh(geometry, new THREE.MeshStandardMaterial({ color: OBJECT_COLOR, roughness: 0.8 }));
      mesh.castShadow = true;
      mesh.receiveShadow = true;
      mesh.add(new THREE.LineSegments(new THREE.EdgesGeometry(geometry), new THREE.LineBasicMaterial({ color: '#3d4429' })));
      mesh.name = o.name;
      this.group.add(mesh);
      this.objects.push(mesh);
    }
  }

  /** Poses every marker for frame f (0 ≤ f < numFrames). */
  update(f) {
    if (!this.rollout.scene) return;
    const s = sceneAt(this.rollout, f);
    this.targets.forEach((marker, k) => {
      const t = s.targets[k];
      marker.visible = !!t;
      if (!t) return;
      marker.position.set(t.position[0], t.position[1], FLOOR_OFFSET);
      marker.scale.set(t.radius, t.radius, 1);
    });
    this.arrows.forEach((arrow, k) => {
      const a = s.arrows[k];
      arrow.visible = !!a;
      if (!a) return;
      const length = arrowLength(a.speed);
      arrow.position.set(a.origin[0], a.origin[1], a.origin[2] + 2 * FLOOR_OFFSET);
      arrow.setDirection(new THREE.Vector3(...a.direction).normalize());
      arrow.setLength(length, Math.min(0.3, 0.4 * length), Math.min(0.18, 0.25 * length));
    });
    this.objects.forEach((mesh, i) => {
      mesh.position.set(...s.objects[i].position);
      mesh.quaternion.set(...s.objects[i].rotation).normalize();
    });
  }

  /** What is shown (for tests and the window.__viewerState hook). */
  state() {
    return {
      targets: this.targets.filter((m) => m.visible).map((m) => ({ position: m.position.toArray(), radius: m.scale.x })),
      arrows: this.arrows.filter((a) => a.visible).map((a) => ({ origin: a.position.toArray(), length: a.cone.position.y })),
      objects: this.objects.map((m) => ({ name: m.name, position: m.position.toArray(), quaternion: m.quaternion.toArray() })),
    };
  }

  dispose() {
    this.group.traverse((o) => {
      if (o.geometry) o.geometry.dispose();
      if (o.material) o.material.dispose();
    });
  }
}
