// One 3-D view of a rollout: the humanoid as capsules/spheres/boxes per body, tracking goals, the
// goal-task scene (targets, heading arrows, boxes: sceneGoals.js), a ground grid, orbit controls
// and a camera that follows the root. World is z-up (as in maskadapt).
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { bodyPosition, bodyRotation } from './rollout.js';
import { bodyColors, GOAL_COLOR } from './colors.js';
import { SceneGoals } from './sceneGoals.js';

const UP = new THREE.Vector3(0, 0, 1);
const Y = new THREE.Vector3(0, 1, 0);

function geomMesh(g, material) {
  if (g.type === 'capsule') {
    const a = new THREE.Vector3(...g.from);
    const b = new THREE.Vector3(...g.to);
    const axis = b.clone().sub(a);
    const length = axis.length();
    const geometry = length > 1e-6 ? new THREE.CapsuleGeometry(g.radius, length, 4, 12) : new THREE.SphereGeometry(g.radius, 16, 12);
    const mesh = new THREE.Mesh(geometry, material);
    mesh.position.copy(a.clone().add(b).multiplyScalar(0.5));
    if (length > 1e-6) mesh.quaternion.setFromUnitVectors(Y, axis.normalize());  // capsule is built along y
    return mesh;
  }
  if (g.type === 'sphere') {
    const mesh = new THREE.Mesh(new THREE.SphereGeometry(g.radius, 16, 12), material);
    mesh.position.set(...g.center);
    return mesh;
  }
  const [hx, hy, hz] = g.halfSize;
  const mesh = new THREE.Mesh(new THREE.BoxGeometry(2 * hx, 2 * hy, 2 * hz), material);
  mesh.position.set(...g.center);
  return mesh;
}

export class RolloutView {
  /** @param container DOM element the canvas goes into. */
  constructor(container) {
    this.container = container;
    this.rollout = null;
    this.frame = 0;
    this.colors = [];
    this.renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));
    this.renderer.shadowMap.enabled = true;
    container.appendChild(this.renderer.domElement);

    this.scene = new THREE.Scene();
    this.scene.background = new THREE.Color('#f4f5f7');
    this.camera = new THREE.PerspectiveCamera(45, 1, 0.05, 200);
    this.camera.up.copy(UP);
    this.camera.position.set(2.6, -3.4, 2.3);
    this.controls = new OrbitControls(this.camera, this.renderer.domElement);
    this.controls.target.set(0, 0, 0.9);
    this.controls.update();
    this.controls.addEventListener('change', () => this.render());

    this.scene.add(new THREE.HemisphereLight('#ffffff', '#8a8f99', 1.6));
    const sun = new THREE.DirectionalLight('#ffffff', 1.8);
    sun.position.set(3, -4, 8);
    sun.castShadow = true;
    sun.shadow.mapSize.set(1024, 1024);
    Object.assign(sun.shadow.camera, { left: -4, right: 4, top: 4, bottom: -4, near: 0.5, far: 30 });
    this.sun = sun;
    this.scene.add(sun, sun.target);

    // Ground: a 200 m plane with a 1 m checker-grid texture (a texture rather than GridHelper
    // lines, which Chromium's software renderer clips away near the camera).
    const tile = document.createElement('canvas');
    tile.width = tile.height = 128;
    const ctx = tile.getContext('2d');
    ctx.fillStyle = '#f1f3f5';
    ctx.fillRect(0, 0, 128, 128);
    ctx.fillStyle = '#e6e9ed';
    ctx.fillRect(0, 0, 64, 64);
    ctx.fillRect(64, 64, 64, 64);
    ctx.strokeStyle = '#b9bfc7';
    ctx.lineWidth = 2;
    ctx.strokeRect(0, 0, 128, 128);
    const texture = new THREE.CanvasTexture(tile);
    texture.wrapS = texture.wrapT = THREE.RepeatWrapping;
    texture.repeat.set(100, 100);  // one 128 px tile = 2 m: 1 m checker cells
    texture.colorSpace = THREE.SRGBColorSpace;
    texture.anisotropy = 8;
    const ground = new THREE.Mesh(new THREE.PlaneGeometry(200, 200), new THREE.MeshStandardMaterial({ map: texture, roughness: 1 }));
    ground.receiveShadow = true;
    this.scene.add(ground);
    this.ground = ground;

    this.character = new THREE.Group();
    this.goalGroup = new THREE.Group();
    this.scene.add(this.character, this.goalGroup);
    this.resizeObserver = new ResizeObserver(() => this.resize());
    this.resizeObserver.observe(container);
    this.resize();
  }

  resize() {
    const w = Math.max(this.container.clientWidth, 1);
    const h = Math.max(this.container.clientHeight, 1);
    this.renderer.setSize(w, h, false);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
    this.render();
  }

  /** Replaces the displayed rollout (builds one group of meshes per body). */
  setRollout(rollout) {
    this.rollout = rollout;
    this.character.clear();
    this.goalGroup.clear();
    this.bodyGroups = [];
    this.materials = [];
    for (const body of rollout.bodies) {
      const material = new THREE.MeshStandardMaterial({ color: '#b8c0cc', roughness: 0.6, metalness: 0.05 });
      const group = new THREE.Group();
      for (const g of body.geoms) {
        const mesh = geomMesh(g, material);
        mesh.castShadow = true;
        group.add(mesh);
      }
      this.character.add(group);
      this.bodyGroups.push(group);
      this.materials.push(material);
    }
    this.goalMeshes = [];
    if (rollout.goals) {
      const mat = new THREE.MeshStandardMaterial({ color: GOAL_COLOR, transparent: true, opacity: 0.85 });
      for (let k = 0; k < rollout.goals.bodies.length; ++k) {
        const s = new THREE.Mesh(new THREE.SphereGeometry(0.04, 12, 8), mat);
        this.goalGroup.add(s);
        this.goalMeshes.push(s);
      }
      this.goalLines = rollout.goals.bodies.map(() => {
        const line = new THREE.Line(new THREE.BufferGeometry(), new THREE.LineBasicMaterial({ color: GOAL_COLOR }));
        this.goalGroup.add(line);
        return line;
      });
    }
    // Goal-task scene (location targets, heading arrows, boxes); empty when the file has none.
    if (this.sceneGoals) this.sceneGoals.dispose();
    this.sceneGoals = new SceneGoals(rollout);
    this.goalGroup.add(this.sceneGoals.group);
    this.lastRoot = null;
    this.setFrame(0, true);
  }

  /** Shows frame f; the camera target follows the root (keeping the user's orbit offset). */
  setFrame(f, snapCamera = false) {
    const r = this.rollout;
    if (!r || r.numFrames === 0) return;
    f = Math.min(Math.max(f, 0), r.numFrames - 1);
    this.frame = f;
    for (let b = 0; b < r.numBodies; ++b) {
      const g = this.bodyGroups[b];
      g.position.set(...bodyPosition(r, f, b));
      g.quaternion.set(...bodyRotation(r, f, b)).normalize();
    }
    this.colors = bodyColors(r, f);
    this.colors.forEach((c, b) => this.materials[b].color.set(c));
    this.updateGoals(f);
    this.sceneGoals.update(f);

    const root = new THREE.Vector3(...bodyPosition(r, f, 0));
    if (snapCamera || !this.lastRoot) {
      this.controls.target.set(root.x, root.y, Math.max(root.z, 0.5));
      this.camera.position.set(root.x + 2.6, root.y - 3.4, 2.3);
    } else {
      const delta = root.clone().sub(this.lastRoot);
      delta.z = 0;  // follow horizontally; vertical bobbing would make the view shake
      this.controls.target.add(delta);
      this.camera.position.add(delta);
    }
    this.lastRoot = root;
    this.sun.position.set(root.x + 3, root.y - 4, 8);
    this.sun.target.position.copy(root);
    this.controls.update();
  }

  updateGoals(f) {
    const r = this.rollout;
    if (!r.goals) return;
    const k = r.goals.bodies.length;
    const t = r.goals.targets[f];
    this.goalMeshes.forEach((m, i) => {
      m.visible = !!t;
      if (t) m.position.set(t[3 * i], t[3 * i + 1], t[3 * i + 2]);
    });
    // Trajectory line: the targets of the next second (where the goal is going).
    const horizon = Math.round(r.fps);
    this.goalLines.forEach((line, i) => {
      const pts = [];
      for (let g = f; g < Math.min(r.numFrames, f + horizon); ++g) {
        const tg = r.goals.targets[g];
        if (tg) pts.push(new THREE.Vector3(tg[3 * i], tg[3 * i + 1], tg[3 * i + 2]));
      }
      line.geometry.dispose();
      line.geometry = new THREE.BufferGeometry().setFromPoints(pts);
      line.visible = pts.length > 1 && k > 0;
    });
  }

  render() {
    this.renderer.render(this.scene, this.camera);
  }
}
