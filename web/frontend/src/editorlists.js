// The editor's lists: every item of the scenario by number (from 1, as on the map), its fields editable in place.
// A field the model defaults (left out of the scenario) shows empty with "default"; emptying a field restores it.
const $ = (id) => document.getElementById(id);

export function fillLists(ed) {
  const sc = ed.sc;
  const num = (obj, key, label) => {
    const input = document.createElement("input");
    input.type = "number"; input.step = "any"; input.value = obj[key] ?? ""; input.placeholder = "default";
    input.title = label; input.dataset.field = key;
    input.addEventListener("change", () => {
      if (input.value === "" && label !== "x" && label !== "z") delete obj[key]; else obj[key] = Number(input.value);
      ed.draw();
      if (obj.count !== undefined) ed.requestPreview();
    });
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
    button("×", () => { sc.rovers.splice(i, 1); ed.lists(); })));
  fill("ed-craters", sc.craters, (el, c, i) => row(el, `crater ${i + 1}`, num(c, "x", "x"), num(c, "z", "z"), num(c, "radius_m", "radius m"),
    button("×", () => { sc.craters.splice(i, 1); ed.lists(); })));
  fill("ed-goals", sc.mission, (el, g, i) => {
    const kind = document.createElement("select");
    kind.innerHTML = "<option>crater</option><option>waypoint</option>";
    kind.value = g.kind;
    kind.addEventListener("change", () => { g.kind = kind.value; ed.draw(); });
    const swap = (j) => { if (j < 0 || j >= sc.mission.length) return; [sc.mission[i], sc.mission[j]] = [sc.mission[j], sc.mission[i]]; ed.lists(); };
    row(el, `goal ${i + 1}`, num(g, "x", "x"), num(g, "z", "z"), kind, button("↑", () => swap(i - 1)), button("↓", () => swap(i + 1)),
      button("×", () => { sc.mission.splice(i, 1); ed.lists(); }));
  });
  fill("ed-rocks", sc.obstacles.rocks, (el, r, i) => row(el, `rock ${i + 1}`, num(r, "x", "x"), num(r, "z", "z"), num(r, "radius_m", "radius m"),
    button("×", () => { sc.obstacles.rocks.splice(i, 1); ed.lists(); })));
  const drop = (list, i) => button("×", () => { ed.remove([list === sc.obstacles.walls ? "wall" : "rockfield", list[i]]); ed.lists(); ed.requestPreview(); });
  fill("ed-walls", sc.obstacles.walls, (el, w, i) => {
    const points = document.createElement("input");
    points.className = "points"; points.dataset.field = "points"; points.title = "points: x z; x z; ...";
    points.value = w.points.map(([x, z]) => `${x} ${z}`).join("; ");
    points.addEventListener("change", () => {
      const parsed = points.value.split(";").map((p) => p.trim().split(/[\s,]+/).map(Number)).filter((p) => p.length === 2 && p.every(Number.isFinite));
      if (parsed.length < 2) { ed.status(`wall ${i + 1}: give at least two points as "x z; x z"`, false); return; }
      w.points = parsed;
      ed.lists();
    });
    row(el, `wall ${i + 1}`, num(w, "thickness_m", "thickness m"), num(w, "height_m", "height m"), points, drop(sc.obstacles.walls, i));
    if (ed.isSelected(w)) el.lastChild.classList.add("selected");
  });
  fill("ed-fields", sc.obstacles.rock_fields, (el, f, i) => {
    row(el, `field ${i + 1}`, num(f, "x", "x"), num(f, "z", "z"), num(f, "radius_m", "radius m"), num(f, "count", "rocks"),
      num(f, "min_radius_m", "smallest rock radius m"), num(f, "max_radius_m", "largest rock radius m"), drop(sc.obstacles.rock_fields, i));
    if (ed.isSelected(f)) el.lastChild.classList.add("selected");
  });
  ed.draw();
}
