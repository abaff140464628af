// The scenario editor: a top-down map of the terrain on which the lander, rovers, craters, goals and rocks are
// placed and dragged; lists to edit them by number; validate, save, load, launch, and profile import/export.
// The scenario is held in the model's own JSON shape and every check is the server's (the CLI's pydantic models).
import { get, post } from "./api.js";

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

export class Editor {
  constructor(page) {
    this.page = page;
    this.canvas = $("map");
    this.ctx = this.canvas.getContext("2d");
    this.preview = null;
    this.drag = null;
    this.state = page.editor = { scenario: null, status: "", ok: null, files: [], toScreen: (x, z) => this.toScreen(x, z) };
    this.load(blank());
    this.bind();
    this.refreshFiles();
  }

  bind() {
    this.canvas.addEventListener("pointerdown", (ev) => this.down(ev));
    this.canvas.addEventListener("pointermove", (ev) => this.move(ev));
    window.addEventListener("pointerup", () => { if (this.drag) { this.drag = null; this.lists(); } });
    $("ed-name").addEventListener("change", () => { this.sc.name = $("ed-name").value; });
    $("ed-seed").addEventListener("change", () => { this.sc.seed = Number($("ed-seed").value); });
    $("ed-new").addEventListener("click", () => { this.load(blank()); this.status("new scenario", true); });
    $("ed-validate").addEventListener("click", () => this.validate());
    $("ed-save").addEventListener("click", () => this.save());
    $("ed-load").addEventListener("click", () => this.loadFile($("ed-files").value));
    $("ed-launch").addEventListener("click", () => this.launch());
    $("ed-stop").addEventListener("click", async () => { const r = await post("/api/launch/stop", {}); this.status(`launched run: ${r.running ? "running" : "stopped"}`, true); });
    $("ed-export").addEventListener("click", () => this.exportProfile());
    $("ed-import").addEventListener("change", (ev) => this.importProfile(ev.target.files[0]));
    new ResizeObserver(() => this.draw()).observe($("map-wrap"));
  }

  show() { this.draw(); }

  load(sc) {
    this.sc = structuredClone(sc);
    this.sc.obstacles = this.sc.obstacles || { rocks: [], walls: [], rock_fields: [] };
    this.sc.obstacles.rocks = this.sc.obstacles.rocks || [];
    this.state.scenario = this.sc;
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

  async exportProfile() {
    const r = await this.call("/api/profile/export");
    if (!r || !r.ok) return;
    const a = document.createElement("a");
    a.href = URL.createObjectURL(new Blob([JSON.stringify(r.profile, null, 1)], { type: "application/json" }));
    a.download = `${$("ed-name").value || "scenario"}.json`;
    document.body.appendChild(a);
    a.click();
    a.remove();
    this.status(`exported profile ${a.download} (profiles carry no obstacles, terrain or parameters)`, true);
  }

  async importProfile(file) {
    if (!file) return;
    let profile;
    try { profile = JSON.parse(await file.text()); } catch (err) { this.status(`${file.name}: not JSON: ${err.message}`, false); return; }
    const r = await post("/api/profile/import", { profile, name: file.name.replace(/\.json$/, "") });
    if (r.ok) { this.load(r.scenario); this.status(`imported profile ${file.name}`, true); } else this.status(r.error, false);
  }

  async requestPreview() {
    const asked = (this.previewAsked = (this.previewAsked || 0) + 1);
    let sc;
    try { sc = this.current(); } catch { return; }
    const r = await post("/api/scenario/validate", { scenario: sc, scene: true });
    if (asked === this.previewAsked && r.ok) { this.preview = r.scene; this.draw(); }
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
      for (const c of this.sc.craters) { xs.push(c.x - c.radius_m * 1.3, c.x + c.radius_m * 1.3); zs.push(c.z - c.radius_m * 1.3, c.z + c.radius_m * 1.3); }
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
    return out;
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
    const rect = this.canvas.getBoundingClientRect();
    const px = ev.clientX - rect.left, py = ev.clientY - rect.top;
    const [x, z] = this.toWorld(px, py);
    const tool = document.querySelector("input[name=tool]:checked").value;
    const sc = this.sc;
    if (tool === "select") { this.drag = this.nearest(px, py); return; }
    if (tool === "lander") sc.lander = { ...sc.lander, x, z };
    else if (tool === "rover") sc.rovers.push({ x, z, heading_deg: sc.rovers.length ? sc.rovers[sc.rovers.length - 1].heading_deg : 180 });
    else if (tool === "crater") sc.craters.push({ x, z, radius_m: Number($("ed-crater-r").value) || 20 });
    else if (tool === "goal-crater") sc.mission.push({ x, z, kind: "crater" });
    else if (tool === "goal-waypoint") sc.mission.push({ x, z, kind: "waypoint" });
    else if (tool === "rock") sc.obstacles.rocks.push({ x, z, radius_m: Number($("ed-rock-r").value) || 1 });
    else if (tool === "delete") this.remove(this.nearest(px, py));
    this.lists();
    if (tool === "crater") this.requestPreview();
  }

  remove(hit) {
    if (!hit || hit[0] === "lander") return;
    const [kind, item] = hit;
    const list = { rover: this.sc.rovers, crater: this.sc.craters, goal: this.sc.mission, rock: this.sc.obstacles.rocks }[kind];
    list.splice(list.indexOf(item), 1);
  }

  move(ev) {
    if (!this.drag) return;
    const rect = this.canvas.getBoundingClientRect();
    const [x, z] = this.toWorld(ev.clientX - rect.left, ev.clientY - rect.top);
    this.drag[1].x = x;
    this.drag[1].z = z;
    this.draw();
  }

  draw() {
    const c = this.canvas, ctx = this.ctx;
    if (!c.clientWidth) return;
    if (c.width !== c.clientWidth || c.height !== c.clientHeight) { c.width = c.clientWidth; c.height = c.clientHeight; }
    ctx.fillStyle = "#202020";
    ctx.fillRect(0, 0, c.width, c.height);
    this.drawTerrain();
    const { scale } = this.transform();
    const dot = (x, z, r, color, label) => {
      const [sx, sy] = this.toScreen(x, z);
      ctx.fillStyle = color;
      ctx.beginPath(); ctx.arc(sx, sy, r, 0, Math.PI * 2); ctx.fill();
      if (label) { ctx.fillStyle = "#eee"; ctx.fillText(label, sx + r + 2, sy - r); }
    };
    ctx.font = "11px sans-serif";
    for (const [i, cr] of this.sc.craters.entries()) {
      const [sx, sy] = this.toScreen(cr.x, cr.z);
      ctx.strokeStyle = "#e69933"; ctx.lineWidth = 2;
      ctx.beginPath(); ctx.arc(sx, sy, cr.radius_m * scale, 0, Math.PI * 2); ctx.stroke();
      dot(cr.x, cr.z, 4, "#e69933", `crater ${i}`);
    }
    for (const r of this.sc.obstacles.rocks) dot(r.x, r.z, Math.max(2, r.radius_m * scale), "#8c8073");
    ctx.strokeStyle = "#33ff66"; ctx.lineWidth = 1; ctx.setLineDash([4, 4]);
    ctx.beginPath();
    this.sc.mission.forEach((g, i) => { const [sx, sy] = this.toScreen(g.x, g.z); if (i) ctx.lineTo(sx, sy); else ctx.moveTo(sx, sy); });
    ctx.stroke(); ctx.setLineDash([]);
    this.sc.mission.forEach((g, i) => dot(g.x, g.z, 5, g.kind === "crater" ? "#33ff66" : "#33ccff", `goal ${i}`));
    this.sc.rovers.forEach((r, i) => dot(r.x, r.z, 4, "#3399ff", `${i + 1}`));
    dot(this.sc.lander.x, this.sc.lander.z, 7, "#f2d94d", "lander");
  }

  drawTerrain() {
    const t = this.preview && this.preview.terrain;
    if (!t) return;
    if (this.terrainFor !== t) {
      const img = document.createElement("canvas");
      img.width = t.nx; img.height = t.nz;
      const g = img.getContext("2d"), data = g.createImageData(t.nx, t.nz);
      const lo = Math.min(...t.heights), hi = Math.max(...t.heights);
      for (let j = 0; j < t.nz; j++) {
        for (let i = 0; i < t.nx; i++) {
          const s = 60 + (hi > lo ? (140 * (t.heights[j * t.nx + i] - lo)) / (hi - lo) : 60);
          const k = ((t.nz - 1 - j) * t.nx + i) * 4;
          data.data.set([s, s, s, 255], k);
        }
      }
      g.putImageData(data, 0, 0);
      this.terrainImage = img;
      this.terrainFor = t;
    }
    const [ax, ay] = this.toScreen(t.x0, t.z1), [bx, by] = this.toScreen(t.x1, t.z0);
    this.ctx.imageSmoothingEnabled = true;
    this.ctx.drawImage(this.terrainImage, ax, ay, bx - ax, by - ay);
  }

  // ---- lists ----

  lists() {
    const sc = this.sc;
    const num = (obj, key, label) => {
      const input = document.createElement("input");
      input.type = "number"; input.step = "any"; input.value = obj[key]; input.title = label; input.dataset.field = key;
      input.addEventListener("change", () => { obj[key] = Number(input.value); this.draw(); });
      return input;
    };
    const button = (text, fn) => { const b = document.createElement("button"); b.textContent = text; b.addEventListener("click", fn); return b; };
    const row = (parent, label, ...els) => {
      const div = document.createElement("div"); div.className = "item";
      div.append(label, ...els); parent.appendChild(div);
    };
    const fill = (id, list, render) => { const el = $(id); el.innerHTML = ""; list.forEach((item, i) => render(el, item, i)); };
    fill("ed-lander", [sc.lander], (el, l) => row(el, "x, z", num(l, "x", "x"), num(l, "z", "z")));
    fill("ed-rovers", sc.rovers, (el, r, i) => row(el, `rover ${i + 1}`, num(r, "x", "x"), num(r, "z", "z"), num(r, "heading_deg", "heading"),
      button("×", () => { sc.rovers.splice(i, 1); this.lists(); })));
    fill("ed-craters", sc.craters, (el, c, i) => row(el, `crater ${i}`, num(c, "x", "x"), num(c, "z", "z"), num(c, "radius_m", "radius m"),
      button("×", () => { sc.craters.splice(i, 1); this.lists(); })));
    fill("ed-goals", sc.mission, (el, g, i) => {
      const kind = document.createElement("select");
      kind.innerHTML = "<option>crater</option><option>waypoint</option>";
      kind.value = g.kind;
      kind.addEventListener("change", () => { g.kind = kind.value; this.draw(); });
      const swap = (j) => { if (j < 0 || j >= sc.mission.length) return; [sc.mission[i], sc.mission[j]] = [sc.mission[j], sc.mission[i]]; this.lists(); };
      row(el, `goal ${i}`, num(g, "x", "x"), num(g, "z", "z"), kind, button("↑", () => swap(i - 1)), button("↓", () => swap(i + 1)),
        button("×", () => { sc.mission.splice(i, 1); this.lists(); }));
    });
    fill("ed-rocks", sc.obstacles.rocks, (el, r, i) => row(el, `rock ${i}`, num(r, "x", "x"), num(r, "z", "z"), num(r, "radius_m", "radius m"),
      button("×", () => { sc.obstacles.rocks.splice(i, 1); this.lists(); })));
    this.draw();
  }
}
