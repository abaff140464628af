// Labels on the editor's map laid out so that none covers another: labels of things at one place ("crater 1"
// and "goal 1" on its centre) become one label, and each label takes the first free spot around its point,
// further out with a leader line when the near ones are taken. Pure: screen coordinates in, boxes out.

const MERGE_PX = 6;
const HEIGHT_PX = 12;

function intersects(a, b) {
  return a.x < b.x + b.w && b.x < a.x + a.w && a.y < b.y + b.h && b.y < a.y + a.h;
}

function overlapArea(a, b) {
  const w = Math.min(a.x + a.w, b.x + b.w) - Math.max(a.x, b.x), h = Math.min(a.y + a.h, b.y + b.h) - Math.max(a.y, b.y);
  return w > 0 && h > 0 ? w * h : 0;
}

// Labels whose points are within MERGE_PX of each other, as one label listing their texts in order.
export function mergeLabels(labels) {
  const groups = [];
  for (const label of labels) {
    const near = groups.find((g) => Math.hypot(g.ax - label.ax, g.ay - label.ay) <= MERGE_PX);
    if (near) { near.texts.push(label.text); near.r = Math.max(near.r, label.r); } else groups.push({ ...label, texts: [label.text] });
  }
  return groups.map((g) => ({ ax: g.ax, ay: g.ay, r: g.r, text: g.texts.join(" · ") }));
}

function candidates(label, w, h) {
  const out = [];
  for (const ring of [1, 2.5, 4]) {
    const g = (label.r + 2) * ring + (ring > 1 ? 6 * ring : 0);
    const { ax, ay } = label;
    out.push([ax + g, ay - g - h + 4], [ax + g, ay + g - 4], [ax - g - w, ay - g - h + 4], [ax - g - w, ay + g - 4],
      [ax - w / 2, ay - g - h], [ax - w / 2, ay + g], [ax + g, ay - h / 2], [ax - g - w, ay - h / 2]);
  }
  return out.map(([x, y], i) => ({ x, y, w, h, leader: i >= 8 }));
}

// `labels`: [{text, ax, ay, r}] in drawing priority (first placed first); `measure(text)`: its width in pixels;
// `area`: {w, h} of the canvas. Returns [{text, ax, ay, x, y, w, h, leader}] with x, y the box's top left.
export function layoutLabels(labels, measure, area) {
  const merged = mergeLabels(labels);
  const dots = merged.map((l) => ({ x: l.ax - l.r, y: l.ay - l.r, w: 2 * l.r, h: 2 * l.r }));
  const placed = [];
  for (const label of merged) {
    const w = Math.ceil(measure(label.text)) + 2;
    let best = null, bestCost = Infinity;
    for (const box of candidates(label, w, HEIGHT_PX)) {
      let cost = 0;
      for (const other of placed) cost += 1000 * overlapArea(box, other);
      for (const dot of dots) if (intersects(box, dot)) cost += 10;
      if (box.x < 0 || box.y < 0 || box.x + w > area.w || box.y + HEIGHT_PX > area.h) cost += 5;
      if (cost < bestCost) { best = box; bestCost = cost; }
      if (cost === 0) break;
    }
    placed.push({ text: label.text, ax: label.ax, ay: label.ay, ...best });
  }
  return placed;
}

// Draw laid-out labels on a 2D canvas context, a faint leader line to those set away from their point.
export function drawLabels(ctx, placed) {
  ctx.save();
  ctx.textBaseline = "top";
  for (const l of placed) {
    if (l.leader) {
      ctx.strokeStyle = "rgba(230, 230, 230, 0.5)"; ctx.lineWidth = 1;
      ctx.beginPath(); ctx.moveTo(l.ax, l.ay);
      ctx.lineTo(Math.min(Math.max(l.ax, l.x), l.x + l.w), Math.min(Math.max(l.ay, l.y), l.y + l.h)); ctx.stroke();
    }
    ctx.fillStyle = "rgba(20, 20, 20, 0.6)";
    ctx.fillRect(l.x, l.y, l.w, l.h);
    ctx.fillStyle = "#eee";
    ctx.fillText(l.text, l.x + 1, l.y + 1);
  }
  ctx.restore();
}
