// The editor's map drawn on its canvas: terrain, craters, rocks, rock fields, walls, the mission's route, rovers
// and the lander, then their labels (laid out so none covers another), a scale bar and the axes. Items are
// numbered from 1 on the map as in the lists and the terminal.
import { drawLabels, layoutLabels } from "./labels.js";
import { metresText, niceLength } from "./format.js";

const SCALE_BAR_MAX_PX = 140;

export function drawMap(ed) {
  const c = ed.canvas, ctx = ed.ctx;
  if (!c.clientWidth) return;
  if (c.width !== c.clientWidth || c.height !== c.clientHeight) { c.width = c.clientWidth; c.height = c.clientHeight; }
  ctx.fillStyle = "#202020";
  ctx.fillRect(0, 0, c.width, c.height);
  drawTerrain(ed);
  const { scale } = ed.transform();
  const labels = [];
  // Labels are laid out by rank: the lander, goals and rovers get the spots nearest their points.
  const dot = (x, z, r, color, label, rank) => {
    const [sx, sy] = ed.toScreen(x, z);
    ctx.fillStyle = color;
    ctx.beginPath(); ctx.arc(sx, sy, r, 0, Math.PI * 2); ctx.fill();
    if (label) labels.push({ text: label, ax: sx, ay: sy, r, rank });
  };
  ctx.font = "11px sans-serif";
  const sc = ed.sc;
  for (const [i, cr] of sc.craters.entries()) {
    const [sx, sy] = ed.toScreen(cr.x, cr.z);
    ctx.strokeStyle = "#e69933"; ctx.lineWidth = 2;
    ctx.beginPath(); ctx.arc(sx, sy, cr.radius_m * scale, 0, Math.PI * 2); ctx.stroke();
    dot(cr.x, cr.z, 4, "#e69933", `crater ${i + 1}`, 3);
  }
  for (const r of scatteredRocks(ed)) dot(r.x, r.z, Math.max(1.5, r.r * scale), "#6e655b");
  for (const r of sc.obstacles.rocks) dot(r.x, r.z, Math.max(2, r.radius_m * scale), "#8c8073");
  for (const [i, f] of sc.obstacles.rock_fields.entries()) {
    const [sx, sy] = ed.toScreen(f.x, f.z);
    ctx.strokeStyle = ed.isSelected(f) ? "#ffffff" : "#6b4f2e"; ctx.lineWidth = 1.5; ctx.setLineDash([6, 4]);
    ctx.beginPath(); ctx.arc(sx, sy, f.radius_m * scale, 0, Math.PI * 2); ctx.stroke(); ctx.setLineDash([]);
    dot(f.x, f.z, 4, "#6b4f2e", `rock field ${i + 1} (${f.count})`, 4);
  }
  sc.obstacles.walls.forEach((w, i) => labels.push(drawWall(ed, w, scale, ed.isSelected(w) ? "#ffffff" : "#d9534f", `wall ${i + 1}`)));
  if (ed.drawing) labels.push(drawWall(ed, ed.drawing, scale, "#ff9f9a", "new wall"));
  ctx.strokeStyle = "#33ff66"; ctx.lineWidth = 1; ctx.setLineDash([4, 4]);
  ctx.beginPath();
  sc.mission.forEach((g, i) => { const [sx, sy] = ed.toScreen(g.x, g.z); if (i) ctx.lineTo(sx, sy); else ctx.moveTo(sx, sy); });
  ctx.stroke(); ctx.setLineDash([]);
  sc.mission.forEach((g, i) => dot(g.x, g.z, 5, g.kind === "crater" ? "#33ff66" : "#33ccff", `goal ${i + 1}`, 1));
  sc.rovers.forEach((r, i) => dot(r.x, r.z, 4, "#3399ff", `${i + 1}`, 2));
  dot(sc.lander.x, sc.lander.z, 7, "#f2d94d", "lander", 0);
  const ranked = labels.filter(Boolean).sort((a, b) => a.rank - b.rank);
  const placed = layoutLabels(ranked, (text) => ctx.measureText(text).width, { w: c.width, h: c.height });
  drawLabels(ctx, placed);
  ed.state.labels = placed;
  ed.state.scaleBar = drawScaleBar(ctx, scale, c.height);
  drawAxes(ctx, c.width);
}

function drawWall(ed, w, scale, color, label) {
  const ctx = ed.ctx;
  const pts = w.points.map(([x, z]) => ed.toScreen(x, z));
  ctx.strokeStyle = color; ctx.lineCap = "round"; ctx.lineJoin = "round";
  ctx.lineWidth = Math.max(2, (w.thickness_m || 0) * scale);
  ctx.beginPath();
  pts.forEach(([sx, sy], i) => (i ? ctx.lineTo(sx, sy) : ctx.moveTo(sx, sy)));
  ctx.stroke();
  ctx.fillStyle = color;
  for (const [sx, sy] of pts) { ctx.beginPath(); ctx.arc(sx, sy, 3.5, 0, Math.PI * 2); ctx.fill(); }
  return pts.length ? { text: label, ax: pts[0][0], ay: pts[0][1], r: 4, rank: 5 } : null;
}

// A bar of a round number of metres at the bottom left; returns what it shows (the browser tests read it).
function drawScaleBar(ctx, pxPerMetre, height) {
  const metres = niceLength(SCALE_BAR_MAX_PX / pxPerMetre), px = metres * pxPerMetre;
  const x = 12, y = height - 14;
  ctx.save();
  ctx.fillStyle = "rgba(20, 20, 20, 0.7)"; // readable on light terrain too
  ctx.fillRect(x - 6, y - 22, px + 12, 28);
  ctx.strokeStyle = "#eee"; ctx.fillStyle = "#eee"; ctx.lineWidth = 2;
  ctx.beginPath(); ctx.moveTo(x, y - 5); ctx.lineTo(x, y); ctx.lineTo(x + px, y); ctx.lineTo(x + px, y - 5); ctx.stroke();
  ctx.textBaseline = "bottom";
  ctx.fillText(metresText(metres), x + 4, y - 3);
  ctx.restore();
  return { metres, px };
}

// The map's axes at the top right: +x to the right, +z up the map (heading 0 points along +z).
function drawAxes(ctx, width) {
  const ox = width - 60, oy = 50, len = 30;
  ctx.save();
  ctx.fillStyle = "rgba(20, 20, 20, 0.7)";
  ctx.fillRect(ox - 44, oy - len - 18, 104, len + 32);
  ctx.lineWidth = 2; ctx.textBaseline = "middle";
  for (const [dx, dy, color, text] of [[len, 0, "#ff6b6b", "+x"], [0, -len, "#6bb5ff", "+z (heading 0)"]]) {
    ctx.strokeStyle = color; ctx.fillStyle = color;
    ctx.beginPath(); ctx.moveTo(ox, oy); ctx.lineTo(ox + dx, oy + dy); ctx.stroke();
    ctx.fillText(text, dx ? ox + dx + 4 : ox - 20, dy ? oy + dy - 8 : oy);
  }
  ctx.restore();
}

// The rocks the server scattered for the rock fields (the preview lists the placed rocks first).
function scatteredRocks(ed) {
  const rocks = (ed.preview && ed.preview.rocks) || [];
  return ed.sc.obstacles.rock_fields.length ? rocks.slice(ed.previewPlaced ?? rocks.length) : [];
}

function drawTerrain(ed) {
  const t = ed.preview && ed.preview.terrain;
  if (!t) return;
  if (ed.terrainFor !== t) {
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
    ed.terrainImage = img;
    ed.terrainFor = t;
  }
  const [ax, ay] = ed.toScreen(t.x0, t.z1), [bx, by] = ed.toScreen(t.x1, t.z0);
  ed.ctx.imageSmoothingEnabled = true;
  ed.ctx.drawImage(ed.terrainImage, ax, ay, bx - ax, by - ay);
}
