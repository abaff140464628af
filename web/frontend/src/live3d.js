// The 3D view. LunarSim (x, z, height) is three.js (x, height, -z): a proper rotation, so the map reads as in
// our plots from above (+x right, +z up the screen). Heading h (0 = +z, 90 = +x) is a rotation of 90 - h
// degrees about +y. Rovers are one InstancedMesh, trails and links one LineSegments each: a few draw calls
// whatever the team size.
import * as THREE from "three";
import { OrbitControls } from "three/examples/jsm/controls/OrbitControls.js";
import { Ground } from "./ground.js";
import { ViewOverlay } from "./overlay.js";
import { MapOverlay } from "./traversemap.js";

const ROVER = { length: 1.4, width: 1.0, height: 0.6, scale: 2.0 };
const TRAIL_POINTS = 300;
const EASE_MS = 100; // a rover eases from its last state to the newest over one stream period, so 10 Hz looks smooth
// The start's view: from the south, a little east, this far above the horizon, with the mission filling the picture.
const VIEW_FROM = new THREE.Vector3(0.15, 0.75, 0.6).normalize();
const FRAME_MARGIN = { share: 0.12, min_m: 12 };
const MIN_VIEW_DISTANCE_M = 30;
const DEFAULT_SUN = new THREE.Vector3(-0.5, 0.7, 0.4).normalize();
const STATE_COLORS = {
  waiting: 0x999999, migration: 0x3399ff, avoiding: 0xffcc1a, climbing: 0xe6801a, observing: 0x4ce64c,
  done: 0x1ab333, stuck: 0xff1a1a, stopped: 0x804d4d, relay: 0xe64de6,
};

export class LiveView {
  constructor(container, page) {
    this.container = container;
    this.page = page;
    this.ground = new Ground(null);
    this.trails = new Map();
    this.prev = new Map();
    this.curr = new Map();
    this.stateAt = 0;
    this.onPick = null;
    this.dirty = true; // the picture may have changed since it was last drawn
    this.drawnEase = 1; // how far the last drawn frame had eased the rovers towards their newest state
    try {
      this.renderer = new THREE.WebGLRenderer({ antialias: false });
    } catch (err) {
      container.querySelector("#nowebgl").hidden = false;
      return;
    }
    page.webgl = true;
    // ?scale=0.5 draws a quarter of the pixels (scaled up by the browser): an option for software WebGL, not the
    // default, as its gain was between none and 1.8x in paired runs on a shared machine (README, Web view).
    const scale = Number(new URLSearchParams(location.search).get("scale"));
    page.renderScale = scale > 0 && scale <= 1 ? scale : 1;
    this.renderer.setPixelRatio(page.renderScale);
    this.renderer.domElement.className = "gl"; // the picture; the overlay's canvas keeps its own size
    container.appendChild(this.renderer.domElement);
    this.scene = new THREE.Scene();
    this.scene.background = new THREE.Color(0x05070c);
    this.camera = new THREE.PerspectiveCamera(50, 1, 0.5, 20000);
    this.controls = new OrbitControls(this.camera, this.renderer.domElement);
    this.controls.addEventListener("start", () => { this.userMoved = true; });
    this.controls.addEventListener("change", () => this.invalidate());
    this.scene.add(new THREE.AmbientLight(0xffffff, 0.55));
    this.sun = new THREE.DirectionalLight(0xffffff, 1.6);
    this.sun.position.set(...DEFAULT_SUN.clone().multiplyScalar(500).toArray());
    this.scene.add(this.sun);
    this.mapOverlay = new MapOverlay(this.scene);
    this.statics = new THREE.Group();
    this.scene.add(this.statics);
    this.makeDynamic(128);
    this.overlay = new ViewOverlay(container, () => this.frame(this.page.scene));
    this.renderer.domElement.addEventListener("click", (ev) => this.click(ev));
    new ResizeObserver(() => this.resize()).observe(container);
    this.resize();
  }

  // Something the picture shows has changed: the next animation frame draws it.
  invalidate() {
    this.dirty = true;
  }

  makeDynamic(capacity) {
    if (this.rovers) { this.scene.remove(this.rovers); this.rovers.dispose(); }
    const box = new THREE.BoxGeometry(ROVER.length * ROVER.scale, ROVER.height * ROVER.scale, ROVER.width * ROVER.scale);
    this.rovers = new THREE.InstancedMesh(box, new THREE.MeshLambertMaterial(), capacity);
    this.rovers.count = 0;
    this.rovers.frustumCulled = false;
    this.scene.add(this.rovers);
    if (!this.trailLines) {
      this.trailLines = this.lines(0x66ccff, 0.6);
      this.linkLines = this.lines(0x4d99ff, 0.8);
      this.chainLines = this.lines(0xff4dff, 1.0);
    }
  }

  lines(color, opacity) {
    const l = new THREE.LineSegments(new THREE.BufferGeometry(),
      new THREE.LineBasicMaterial({ color, transparent: opacity < 1, opacity }));
    l.frustumCulled = false;
    this.scene.add(l);
    return l;
  }

  resize() {
    if (!this.renderer) return;
    const w = this.container.clientWidth || 1, h = this.container.clientHeight || 1;
    this.renderer.setSize(w, h, false);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
    this.invalidate();
    // Framed while hidden (a page opened on another tab) or resized since: frame again, unless the user moved.
    if (this.framed && !this.userMoved) this.frame(this.page.scene);
  }

  setScene(scene) {
    this.ground = new Ground(scene.terrain);
    this.trails.clear();
    this.prev.clear();
    this.curr.clear();
    if (!this.renderer) return;
    this.statics.clear();
    this.mapOverlay.clear();
    const g = this.ground;
    const sun = scene.sun ? sunVector(scene.sun) : DEFAULT_SUN;
    this.sun.position.copy(sun).multiplyScalar(500);
    if (scene.terrain) this.statics.add(terrainMesh(scene.terrain, sun));
    for (const c of scene.craters) this.statics.add(ring(c.x, c.z, c.r, c.h + 0.2, 0xe69933));
    if (scene.rocks.length) this.statics.add(rocks(scene.rocks));
    for (const w of scene.walls) for (const seg of walls(w, g)) this.statics.add(seg);
    if (scene.lander) {
      const l = scene.lander;
      const m = new THREE.Mesh(new THREE.CylinderGeometry(l.r, l.r, 2.5, 24), new THREE.MeshLambertMaterial({ color: 0xf2d94d }));
      m.position.set(l.x, l.h + 1.25, -l.z);
      this.statics.add(m);
    }
    for (const goal of scene.goals) {
      const m = new THREE.Mesh(new THREE.CylinderGeometry(0.6, 0.6, 8, 8),
        new THREE.MeshBasicMaterial({ color: goal.kind === "crater" ? 0x33ff66 : 0x33ccff, transparent: true, opacity: 0.8 }));
      m.position.set(goal.x, goal.h + 4, -goal.z);
      this.statics.add(m);
    }
    this.invalidate();
    this.frame(scene);
  }

  // Look at the lander, the rovers and the goals (what the mission is about), not the whole terrain: from the
  // terrain's size the rovers were specks. Without a scenario, at the rovers once their first state comes.
  frame(scene) {
    const box = missionBox(scene, [...this.curr.values()]);
    this.needsFrame = !box;
    if (!box || !this.renderer) return;
    this.framed = box;
    this.userMoved = false;
    const cx = (box.x0 + box.x1) / 2, cz = (box.z0 + box.z1) / 2, h = this.ground.at(cx, cz);
    const vfov = (this.camera.fov * Math.PI) / 180, hfov = 2 * Math.atan(Math.tan(vfov / 2) * this.camera.aspect);
    const elevation = Math.asin(VIEW_FROM.y);
    // The ground's depth is foreshortened by the view's elevation; 1.2 leaves room for perspective at the near edge.
    const distance = 1.2 * Math.max(MIN_VIEW_DISTANCE_M, (box.x1 - box.x0) / 2 / Math.tan(hfov / 2),
      ((box.z1 - box.z0) / 2) * Math.sin(elevation) / Math.tan(vfov / 2));
    this.controls.target.set(cx, h, -cz);
    this.camera.position.copy(this.controls.target).addScaledVector(VIEW_FROM, distance);
    const t = scene && scene.terrain;
    this.camera.far = Math.max(distance * 10, t ? 10 * Math.max(t.x1 - t.x0, t.z1 - t.z0) : 0);
    this.camera.updateProjectionMatrix();
    this.controls.update();
    this.invalidate();
  }

  // Where a ground point is on the canvas, in CSS pixels from its top left (the browser tests read it).
  screenOf(x, z) {
    const p = new THREE.Vector3(x, this.ground.at(x, z), -z).project(this.camera);
    return [((p.x + 1) / 2) * this.container.clientWidth, ((1 - p.y) / 2) * this.container.clientHeight];
  }

  setState(state) {
    const now = performance.now();
    this.prev = this.curr;
    this.curr = new Map();
    for (const r of state.rovers) {
      this.curr.set(r.id, r);
      let trail = this.trails.get(r.id);
      if (!trail) this.trails.set(r.id, (trail = []));
      const lastPoint = trail[trail.length - 1];
      if (!lastPoint || Math.hypot(lastPoint[0] - r.x, lastPoint[1] - r.z) > 0.3) {
        trail.push([r.x, r.z, this.ground.at(r.x, r.z) + 0.3]); // height once, not at every redraw
        if (trail.length > TRAIL_POINTS) trail.shift();
      }
    }
    this.stateAt = now;
    this.state = state;
    this.invalidate();
    if (this.needsFrame && state.rovers.length) this.frame(this.page.scene);
    if (!this.renderer) return;
    if (state.rovers.length > this.rovers.instanceMatrix.count) this.makeDynamic(state.rovers.length * 2);
    this.updateTrails();
    this.updateLinks(state);
  }

  setMap(msg, cells) {
    if (this.renderer) { this.mapOverlay.update(msg, cells, this.ground); this.invalidate(); }
  }

  showMap(on) {
    if (this.renderer) { this.mapOverlay.show(on); this.invalidate(); }
  }

  where(id) {
    const r = this.curr.get(id);
    if (id === 0 && this.page.scene && this.page.scene.lander) {
      const l = this.page.scene.lander;
      return [l.x, l.z];
    }
    return r ? [r.x, r.z] : null;
  }

  updateTrails() {
    const pts = [];
    for (const trail of this.trails.values()) {
      for (let i = 1; i < trail.length; i++) {
        const a = trail[i - 1], b = trail[i];
        pts.push(a[0], a[2], -a[1], b[0], b[2], -b[1]);
      }
    }
    setPoints(this.trailLines, pts);
  }

  updateLinks(state) {
    const relays = new Set(state.relays);
    const plain = [], chain = [];
    for (const [a, b] of state.links) {
      const pa = this.where(a), pb = this.where(b);
      if (!pa || !pb) continue;
      const out = relays.has(a) || relays.has(b) ? chain : plain;
      out.push(pa[0], this.ground.at(pa[0], pa[1]) + 1.5, -pa[1], pb[0], this.ground.at(pb[0], pb[1]) + 1.5, -pb[1]);
    }
    setPoints(this.linkLines, plain);
    setPoints(this.chainLines, chain);
  }

  // Draws only when the picture can have changed (a new state while the rovers ease towards it, the camera, the
  // scene, the map, the canvas's size), so a page on an ended run, a paused replay or a silent world draws nothing:
  // with software WebGL each frame takes a core's worth of milliseconds. True when it drew.
  render(now) {
    if (!this.renderer) return false;
    const f = Math.min(1, (now - this.stateAt) / EASE_MS);
    if (!this.dirty && this.drawnEase === 1) return false;
    this.dirty = false;
    this.drawnEase = f;
    const m = new THREE.Matrix4(), q = new THREE.Quaternion(), p = new THREE.Vector3(), color = new THREE.Color();
    const up = new THREE.Vector3(0, 1, 0), s = new THREE.Vector3(1, 1, 1);
    let i = 0;
    for (const r of this.curr.values()) {
      const a = this.prev.get(r.id) || r;
      const x = a.x + (r.x - a.x) * f, z = a.z + (r.z - a.z) * f;
      p.set(x, this.ground.at(x, z) + ROVER.height * ROVER.scale / 2, -z);
      q.setFromAxisAngle(up, ((90 - r.heading) * Math.PI) / 180);
      this.rovers.setMatrixAt(i, m.compose(p, q, s));
      this.rovers.setColorAt(i, color.setHex(r.alive ? STATE_COLORS[r.state] ?? 0xffffff : 0x333333));
      i += 1;
    }
    this.rovers.count = i;
    this.rovers.instanceMatrix.needsUpdate = true;
    if (this.rovers.instanceColor) this.rovers.instanceColor.needsUpdate = true;
    this.controls.update();
    this.overlay.update(this.camera, this.controls.target, this.container.clientHeight);
    this.renderer.render(this.scene, this.camera);
    return true;
  }

  click(ev) {
    // Shift-click on the terrain: its map point becomes the command target.
    if (!ev.shiftKey || !this.onPick) return;
    const rect = this.renderer.domElement.getBoundingClientRect();
    const ndc = new THREE.Vector2(((ev.clientX - rect.left) / rect.width) * 2 - 1, -((ev.clientY - rect.top) / rect.height) * 2 + 1);
    const ray = new THREE.Raycaster();
    ray.setFromCamera(ndc, this.camera);
    const hit = ray.intersectObjects(this.statics.children, false)[0];
    if (hit) this.onPick(hit.point.x, -hit.point.z);
  }
}

// The ground rectangle holding the lander, the rovers (their spawns, else where they are), the goals and the
// craters they are in, with a margin; null when there is nothing to look at yet.
function missionBox(scene, rovers) {
  const xs = [], zs = [];
  const add = (x, z, r = 0) => { xs.push(x - r, x + r); zs.push(z - r, z + r); };
  if (scene && scene.lander) add(scene.lander.x, scene.lander.z, scene.lander.r);
  const spawns = scene && scene.spawns && scene.spawns.length ? scene.spawns : rovers;
  for (const r of spawns) add(r.x, r.z);
  for (const g of (scene && scene.goals) || []) {
    add(g.x, g.z);
    for (const c of scene.craters) if (Math.hypot(c.x - g.x, c.z - g.z) <= c.r) add(c.x, c.z, c.r);
  }
  if (!xs.length) return null;
  const x0 = Math.min(...xs), x1 = Math.max(...xs), z0 = Math.min(...zs), z1 = Math.max(...zs);
  const m = Math.max(FRAME_MARGIN.min_m, FRAME_MARGIN.share * Math.max(x1 - x0, z1 - z0));
  return { x0: x0 - m, x1: x1 + m, z0: z0 - m, z1: z1 + m };
}

function setPoints(lines, pts) {
  lines.geometry.setAttribute("position", new THREE.Float32BufferAttribute(pts, 3));
  lines.geometry.computeBoundingSphere();
}

// The scenario's sun (azimuth like a heading: 0 = shining from +z) as a three.js direction towards it.
function sunVector(s) {
  const az = (s.azimuth_deg * Math.PI) / 180, el = (s.elevation_deg * Math.PI) / 180;
  return new THREE.Vector3(Math.sin(az) * Math.cos(el), Math.sin(el), -Math.cos(az) * Math.cos(el));
}

function terrainMesh(t, sun) {
  const geo = new THREE.BufferGeometry();
  const pos = new Float32Array(t.nx * t.nz * 3), col = new Float32Array(t.nx * t.nz * 3);
  const lo = Math.min(...t.heights), hi = Math.max(...t.heights);
  const dx = (t.x1 - t.x0) / (t.nx - 1), dz = (t.z1 - t.z0) / (t.nz - 1);
  for (let j = 0; j < t.nz; j++) {
    for (let i = 0; i < t.nx; i++) {
      const k = j * t.nx + i, h = t.heights[k];
      pos.set([t.x0 + i * dx, h, -(t.z0 + j * dz)], k * 3);
      const s = hi > lo ? 0.35 + 0.45 * (h - lo) / (hi - lo) : 0.55;
      col.set([s, s, s * 1.02], k * 3);
    }
  }
  const index = [];
  for (let j = 0; j < t.nz - 1; j++) {
    for (let i = 0; i < t.nx - 1; i++) {
      const a = j * t.nx + i, b = a + 1, c = a + t.nx, d = c + 1;
      index.push(a, b, d, a, d, c);
    }
  }
  geo.setAttribute("position", new THREE.BufferAttribute(pos, 3));
  geo.setIndex(index);
  geo.computeVertexNormals();
  // Sunlight baked into the vertex colours once: an unlit material costs far less per pixel, which is what
  // limits a browser drawing without a GPU.
  const normal = geo.getAttribute("normal"), n = new THREE.Vector3();
  for (let k = 0; k < t.nx * t.nz; k++) {
    const light = 0.45 + 0.75 * Math.max(0, n.fromBufferAttribute(normal, k).dot(sun));
    col[k * 3] *= light; col[k * 3 + 1] *= light; col[k * 3 + 2] *= light;
  }
  geo.setAttribute("color", new THREE.BufferAttribute(col, 3));
  return new THREE.Mesh(geo, new THREE.MeshBasicMaterial({ vertexColors: true, side: THREE.DoubleSide }));
}

function ring(x, z, r, h, color) {
  const pts = [];
  for (let i = 0; i < 64; i++) {
    const a = (i / 64) * Math.PI * 2;
    pts.push(new THREE.Vector3(x + r * Math.sin(a), h, -(z + r * Math.cos(a))));
  }
  return new THREE.LineLoop(new THREE.BufferGeometry().setFromPoints(pts), new THREE.LineBasicMaterial({ color }));
}

function rocks(list) {
  const mesh = new THREE.InstancedMesh(new THREE.DodecahedronGeometry(1, 0), new THREE.MeshLambertMaterial({ color: 0x8c8073 }), list.length);
  const m = new THREE.Matrix4();
  list.forEach((r, i) => mesh.setMatrixAt(i, m.makeScale(r.r, r.r * 0.7, r.r).setPosition(r.x, r.h + r.r * 0.3, -r.z)));
  return mesh;
}

function walls(w, ground) {
  const out = [];
  for (let i = 1; i < w.points.length; i++) {
    const [x0, z0] = w.points[i - 1], [x1, z1] = w.points[i];
    const len = Math.hypot(x1 - x0, z1 - z0) + w.thickness;
    const mx = (x0 + x1) / 2, mz = (z0 + z1) / 2;
    const mesh = new THREE.Mesh(new THREE.BoxGeometry(len, w.height, w.thickness), new THREE.MeshLambertMaterial({ color: 0xb3b3bf }));
    mesh.position.set(mx, ground.at(mx, mz) + w.height / 2, -mz);
    mesh.rotation.y = Math.atan2(z1 - z0, x1 - x0);
    out.push(mesh);
  }
  return out;
}
