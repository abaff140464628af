// The scenario editor: a top-down map of the terrain on which the lander, rovers, craters, goals, rocks, walls
// (polylines) and rock fields are placed and dragged; lists to edit them by number; validate, save, load, launch,
// and profile import/export.
// The scenario is held in the model's own JSON shape and every check is the server's (the CLI's pydantic models).
// It opens on the scenario the live view shows (`lunarsim view --scenario`, or the last launched), else a blank one.
// Items are numbered from 1, as the terminal numbers goals and rovers.
import { get, post } from "./api.js";
import { fillLists } from "./editorlists.js";
import { exportProfile, importProfile } from "./profiles.js";
import { drawMap } from "./editormap.js";

const $ = (id) => document.getElementById(id);
const PICK_PX = 12;
const MARGIN_M = 60;

function blank() {
  return {
    name: "web_scenario", seed: 1, lander: { x: 0, z: 0 },
    rovers: [{ x: 10, z: 10, heading_deg: 180 }, { x: 16, z: 10, heading_deg: 180 }],
    craters: [{ x: -40, z: -60, radius_m: 20 }],
    obstacles: { rocks: [], walls: [], rock_fields: [] },
    mission: [{ x: -40, z: -60, kind: "crater" }],
    rover_params: {},
  };
}

const round = (v) => Math.round(v * 10) / 10;

// A wall's point is an [x, z] pair in the model; dragging moves anything with x and z, so a point is seen through
// this handle, which reads and writes the pair in place.
function pointHandle(wall, i) {
  return {
    wall, index: i,
    get x() { return wall.points[i][0]; }, set x(v) { wall.points[i][0] = v; },
    get z() { return wall.points[i][1]; }, set z(v) { wall.points[i][1] = v; },
  };
}

// Distance from p to the segment a-b, all in screen pixels.
function segmentDistance(p, a, b) {
  const dx = b[0] - a[0], dy = b[1] - a[1], len2 = dx * dx + dy * dy;
  const t = len2 ? Math.max(0, Math.min(1, ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / len2)) : 0;
  return Math.hypot(p[0] - a[0] - t * dx, p[1] - a[1] - t * dy);
}

export class Editor {
  constructor(page) {
    this.page = page;
    this.canvas = $("map");
    this.ctx = this.canvas.getContext("2d");
    this.preview = null;
    this.drag = null;
    this.drawing = null; // the wall being drawn: its points, until a double-click or Enter ends it
    this.state = page.editor = {
      scenario: null, status: "", ok: null, files: [], selected: null, drawing: null,
      toScreen: (x, z) => this.toScreen(x, z),
    };
    this.load(blank());
    this.touched = false; // a blank until the live view's scenario arrives, or the user starts on it
    this.bind();
    this.refreshFiles();
    this.opened = this.openCurrent();
  }

  // The live view's scenario, unless the user started editing before it arrived.
  async openCurrent() {
    const r = await get("/api/scenario/current");
    if (!r.ok || !r.scenario || this.touched) return;
    this.load(r.scenario);
    this.status(`opened ${r.scenario.name}, the scenario the live view shows`, true);
  }

  bind() {
    this.canvas.addEventListener("pointerdown", (ev) => this.down(ev));
    this.canvas.addEventListener("pointermove", (ev) => this.move(ev));
    window.addEventListener("pointerup", () => this.up());
    this.canvas.addEventListener("dblclick", () => this.finishWall());
    window.addEventListener("keydown", (ev) => this.key(ev));
    for (const radio of document.querySelectorAll("input[name=tool]")) radio.addEventListener("change", () => this.finishWall());
    $("ed-name").addEventListener("change", () => { this.sc.name = $("ed-name").value; });
    $("ed-seed").addEventListener("change", () => { this.sc.seed = Number($("ed-seed").value); });
    $("ed-new").addEventListener("click", () => { this.load(blank()); this.status("new scenario", true); });
    $("ed-validate").addEventListener("click", () => this.validate());
    $("ed-save").addEventListener("click", () => this.save());
    $("ed-load").addEventListener("click", () => this.loadFile($("ed-files").value));
    $("ed-launch").addEventListener("click", () => this.launch());
    $("ed-stop").addEventListener("click", async () => { const r = await post("/api/launch/stop", {}); this.status(`launched run: ${r.running ? "running" : "stopped"}`, true); });
    $("ed-export").addEventListener("click", () => exportProfile(this));
    $("ed-import").addEventListener("change", (ev) => importProfile(this, ev.target.files[0]));
    new ResizeObserver(() => this.draw()).observe($("map-wrap"));
  }

  show() { this.draw(); }

  load(sc) {
    this.touched = true;
    this.sc = structuredClone(sc);
    this.sc.obstacles = this.sc.obstacles || { rocks: [], walls: [], rock_fields: [] };
    for (const key of ["rocks", "walls", "rock_fields"]) this.sc.obstacles[key] = this.sc.obstacles[key] || [];
    this.state.scenario = this.sc;
    this.select(null);
    this.drawing = this.state.drawing = null;
    $("ed-name").value = this.sc.name;
    $("ed-seed").value = this.sc.seed ?? 0;
    $("ed-params").value = JSON.stringify(this.sc.rover_params || {}, null, 1);
    this.fit();
    this.lists();
    this.requestPreview();
  }

  status(text, ok) {
    this.state.status = text;
    this.state.ok = ok;
    $("ed-status").textContent = text;
    $("ed-status").className = ok ? "ok" : "bad";
  }

  // ---- the scenario as sent to the server ----

  current() {
    const sc = structuredClone(this.sc);
    sc.name = $("ed-name").value;
    sc.seed = Number($("ed-seed").value || 0);
    try {
      sc.rover_params = JSON.parse($("ed-params").value || "{}");
    } catch (err) {
      throw new Error(`rover parameters are not valid JSON: ${err.message}`);
    }
    return sc;
  }

  async call(path, extra = {}) {
    let sc;
    try { sc = this.current(); } catch (err) { this.status(err.message, false); return null; }
    const result = await post(path, { scenario: sc, ...extra });
    if (!result.ok) this.status(result.error, false);
    return result;
  }

  async validate() {
    const r = await this.call("/api/scenario/validate", { scene: true });
    if (r && r.ok) {
      this.load(r.scenario);
      this.preview = r.scene;
      this.previewPlaced = r.scenario.obstacles.rocks.length;
      this.draw();
      this.status(`valid: ${r.summary}`, true);
    }
    return r;
  }

  async save() {
    const r = await this.call("/api/scenario/save", { name: $("ed-name").value });
    if (r && r.ok) { this.status(`saved ${r.path}`, true); this.refreshFiles(r.name); }
  }

  async refreshFiles(select) {
    const r = await get("/api/scenario/list");
    this.state.files = r.names || [];
    $("ed-files").innerHTML = this.state.files.map((n) => `<option>${n}</option>`).join("");
    if (select) $("ed-files").value = select;
  }

  async loadFile(name) {
    if (!name) { this.status("no saved scenario to load", false); return; }
    const r = await get(`/api/scenario/load?name=${encodeURIComponent(name)}`);
    if (r.ok) { this.load(r.scenario); this.status(`loaded ${name}`, true); } else this.status(r.error, false);
  }

  async launch() {
    const r = await this.call("/api/scenario/launch", { name: $("ed-name").value, time_scale: Number($("ed-scale").value) });
    if (r && r.ok) {
      this.status(`launched: run folder ${r.out}`, true);
      this.state.launched = r;
      document.getElementById("tab-live").click();
    }
  }

  // One preview in flight at a time: edits made meanwhile are previewed together once it is back, so a quick run
  // of edits (or a loaded machine) never piles requests on the view's one scenario reader.
  async requestPreview() {
    if (this.previewing) { this.previewAgain = true; return; }
    this.previewing = true;
    try {
      do {
        this.previewAgain = false;
        let sc;
        try { sc = this.current(); } catch { return; }
        const r = await post("/api/scenario/validate", { scenario: sc, scene: true });
        if (!this.previewAgain && r.ok) {
          this.preview = r.scene;
          this.previewPlaced = sc.obstacles.rocks.length;
          this.draw();
        }
      } while (this.previewAgain);
    } finally {
      this.previewing = false;
    }
  }

  // ---- map ----

  fit() {
    const t = this.sc.terrain;
    let x0, z0, x1, z1;
    if (t) {
      [x0, z0] = t.origin;
      x1 = x0 + t.size_m[0];
      z1 = z0 + t.size_m[1];
    } else {
      const xs = [], zs = [];
      for (const p of [this.sc.lander, ...this.sc.rovers, ...this.sc.mission]) { xs.push(p.x); zs.push(p.z); }
      for (const c of [...this.sc.craters, ...this.sc.obstacles.rock_fields]) { xs.push(c.x - c.radius_m * 1.3, c.x + c.radius_m * 1.3); zs.push(c.z - c.radius_m * 1.3, c.z + c.radius_m * 1.3); }
      for (const w of this.sc.obstacles.walls) for (const [x, z] of w.points) { xs.push(x); zs.push(z); }
      x0 = Math.min(...xs) - MARGIN_M; x1 = Math.max(...xs) + MARGIN_M;
      z0 = Math.min(...zs) - MARGIN_M; z1 = Math.max(...zs) + MARGIN_M;
    }
    this.bounds = { x0, z0, x1, z1 };
  }

  transform() {
    const w = this.canvas.clientWidth, h = this.canvas.clientHeight, b = this.bounds;
    const scale = Math.min(w / (b.x1 - b.x0), h / (b.z1 - b.z0));
    const ox = (w - scale * (b.x1 - b.x0)) / 2, oz = (h - scale * (b.z1 - b.z0)) / 2;
    return { scale, ox, oz };
  }

  toScreen(x, z) {
    const { scale, ox, oz } = this.transform();
    return [ox + (x - this.bounds.x0) * scale, this.canvas.clientHeight - oz - (z - this.bounds.z0) * scale];
  }

  toWorld(px, py) {
    const { scale, ox, oz } = this.transform();
    return [round(this.bounds.x0 + (px - ox) / scale), round(this.bounds.z0 + (this.canvas.clientHeight - oz - py) / scale)];
  }

  items() {
    const out = [["lander", this.sc.lander]];
    this.sc.rovers.forEach((r) => out.push(["rover", r]));
    this.sc.craters.forEach((c) => out.push(["crater", c]));
    this.sc.mission.forEach((g) => out.push(["goal", g]));
    this.sc.obstacles.rocks.forEach((r) => out.push(["rock", r]));
    this.sc.obstacles.rock_fields.forEach((f) => out.push(["rockfield", f]));
    this.sc.obstacles.walls.forEach((w) => w.points.forEach((_, i) => out.push(["wallpoint", pointHandle(w, i)])));
    return out;
  }

  // The wall whose line passes within PICK_PX of a screen point (for selecting and deleting a whole wall).
  nearestWall(px, py) {
    let best = null, bestD = PICK_PX;
    for (const w of this.sc.obstacles.walls) {
      const pts = w.points.map(([x, z]) => this.toScreen(x, z));
      for (let i = 1; i < pts.length; i++) {
        const d = segmentDistance([px, py], pts[i - 1], pts[i]);
        if (d < bestD) { best = ["wall", w]; bestD = d; }
      }
    }
    return best;
  }

  // A point first (to drag it), else a wall's line (to select the wall).
  pick(px, py) {
    return this.nearest(px, py) || this.nearestWall(px, py);
  }

  select(hit) {
    if (!hit) { this.selected = null; } else {
      const [kind, item] = hit;
      this.selected = kind === "wallpoint" ? ["wall", item.wall] : [kind, item];
    }
    const s = this.selected;
    this.state.selected = s ? { kind: s[0], index: this.indexOf(s) } : null;
  }

  indexOf([kind, item]) {
    const list = this.listOf(kind);
    return list ? list.indexOf(item) : 0;
  }

  listOf(kind) {
    const sc = this.sc;
    return { rover: sc.rovers, crater: sc.craters, goal: sc.mission, rock: sc.obstacles.rocks,
      rockfield: sc.obstacles.rock_fields, wall: sc.obstacles.walls }[kind];
  }

  nearest(px, py) {
    let best = null, bestD = PICK_PX;
    for (const [kind, item] of this.items()) {
      const [sx, sy] = this.toScreen(item.x, item.z);
      const d = Math.hypot(sx - px, sy - py);
      if (d < bestD) { best = [kind, item]; bestD = d; }
    }
    return best;
  }

  down(ev) {
    this.touched = true;
    const rect = this.canvas.getBoundingClientRect();
    const px = ev.clientX - rect.left, py = ev.clientY - rect.top;
    const [x, z] = this.toWorld(px, py);
    const tool = document.querySelector("input[name=tool]:checked").value;
    const sc = this.sc;
    if (tool === "select") {
      const hit = this.pick(px, py);
      this.select(hit);
      this.drag = hit && hit[0] !== "wall" ? hit : null;
      this.lists();
      return;
    }
    if (tool === "wall") { this.addWallPoint(px, py, x, z); return; }
    if (tool === "lander") sc.lander = { ...sc.lander, x, z };
    else if (tool === "rover") sc.rovers.push({ x, z, heading_deg: sc.rovers.length ? sc.rovers[sc.rovers.length - 1].heading_deg : 180 });
    else if (tool === "crater") sc.craters.push({ x, z, radius_m: Number($("ed-crater-r").value) || 20 });
    else if (tool === "goal-crater") sc.mission.push({ x, z, kind: "crater" });
    else if (tool === "goal-waypoint") sc.mission.push({ x, z, kind: "waypoint" });
    else if (tool === "rock") sc.obstacles.rocks.push({ x, z, radius_m: Number($("ed-rock-r").value) || 1 });
    else if (tool === "rockfield") {
      sc.obstacles.rock_fields.push({ x, z, radius_m: Number($("ed-field-r").value) || 20, count: Number($("ed-field-n").value) || 0 });
    } else if (tool === "delete") this.remove(this.pick(px, py));
    this.lists();
    if (["crater", "rockfield", "delete"].includes(tool)) this.requestPreview();
  }

  up() {
    if (!this.drag) return;
    const moved = this.drag[0];
    this.drag = null;
    this.lists();
    if (["crater", "rockfield"].includes(moved)) this.requestPreview();
  }

  // ---- walls: click points, double-click or Enter ends the wall (Escape drops it) ----

  addWallPoint(px, py, x, z) {
    if (!this.drawing) {
      this.drawing = { points: [] };
      if ($("ed-wall-t").value !== "") this.drawing.thickness_m = Number($("ed-wall-t").value);
      this.state.drawing = this.drawing;
    }
    const pts = this.drawing.points;
    if (pts.length) {
      const [lx, ly] = this.toScreen(...pts[pts.length - 1]);
      if (Math.hypot(lx - px, ly - py) < PICK_PX / 2) { this.draw(); return; } // a double-click's second press
    }
    pts.push([x, z]);
    this.draw();
  }

  finishWall() {
    const wall = this.drawing;
    this.drawing = this.state.drawing = null;
    if (!wall) return;
    if (wall.points.length < 2) { this.status("a wall needs at least two points: click them, then double-click or Enter", false); this.draw(); return; }
    this.sc.obstacles.walls.push(wall);
    this.select(["wall", wall]);
    this.status(`wall ${this.sc.obstacles.walls.length}: ${wall.points.length} points`, true);
    this.lists();
  }

  key(ev) {
    if (!$("editor").classList.contains("active") && !this.drawing) return;
    const el = document.activeElement;
    const typing = ["TEXTAREA", "SELECT"].includes(el?.tagName) || (el?.tagName === "INPUT" && !["radio", "checkbox"].includes(el.type));
    if (ev.key === "Enter" && this.drawing) { ev.preventDefault(); this.finishWall(); }
    else if (ev.key === "Escape" && this.drawing) { this.drawing = this.state.drawing = null; this.draw(); }
    else if ((ev.key === "Delete" || ev.key === "Backspace") && this.selected && !typing) {
      ev.preventDefault();
      this.remove(this.selected);
      this.lists();
      this.requestPreview();
    }
  }

  remove(hit) {
    if (!hit || hit[0] === "lander") return;
    const [kind, item] = hit[0] === "wallpoint" ? ["wall", hit[1].wall] : hit;
    const list = this.listOf(kind);
    list.splice(list.indexOf(item), 1);
    if (this.selected && this.selected[1] === item) this.select(null);
  }

  move(ev) {
    if (!this.drag) return;
    const rect = this.canvas.getBoundingClientRect();
    const [x, z] = this.toWorld(ev.clientX - rect.left, ev.clientY - rect.top);
    this.drag[1].x = x;
    this.drag[1].z = z;
    this.draw();
  }

  draw() { drawMap(this); }

  isSelected(item) { return this.selected !== null && this.selected[1] === item; }

  lists() { fillLists(this); }
}
