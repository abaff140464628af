// Statistics (report 10.6.3: the simulation's and each rover's), the ground station, and photos.
import { post } from "./api.js";

const $ = (id) => document.getElementById(id);
// Report 3.4.7 and the fitness list of 6.3.3, in their order, as the world's MissionReport names them.
const SIM_FIELDS = [
  ["relative_path_length_m", "relative path length (m)"],
  ["average_distance_covered_m", "average distance covered (m)"],
  ["average_path_efficiency", "average path efficiency"],
  ["rovers_reached_final_goal", "rovers that reached the final goal"],
  ["rover_collisions", "rover collisions"],
  ["obstacle_collisions", "obstacle collisions"],
  ["rovers_stuck", "rovers stuck"],
  ["mission_duration_s", "mission duration (s)"],
  ["total_distance_covered_m", "total distance covered (m)"],
  ["lander_connection_losses", "lander connection losses"],
  ["disconnected_time_s", "time without a route to the lander (rover-s)"],
  ["worst_rover_connected_fraction", "least connected rover's share"],
  ["max_rovers_in_daisy_chain", "most rovers in the daisy chain"],
  ["rejected_messages", "rejected messages"],
  ["radio_dropped", "radio dropped"],
  ["radio_lost", "radio lost"],
  ["complete", "complete"],
];
const TABLE_PERIOD_MS = 400;

function fmt(v) {
  return typeof v === "number" && !Number.isInteger(v) ? v.toFixed(3) : String(v);
}

export class Panels {
  constructor(page) {
    this.page = page;
    this.selected = null;
    this.tableAt = 0;
    this.known = new Set();
    for (const name of ["set-target", "stop", "return", "pause", "resume", "step"]) {
      $(`cmd-${name}`).addEventListener("click", () => this.send(name));
    }
    $("cmd-rover").addEventListener("change", () => { this.selected = $("cmd-rover").value || null; });
    $("rovers").querySelector("tbody").addEventListener("click", (ev) => {
      const row = ev.target.closest("tr");
      if (row) { this.selected = row.dataset.id; $("cmd-rover").value = row.dataset.id; }
    });
  }

  setState(state) {
    $("simtime").textContent = `t = ${state.stamp.toFixed(1)} s`;
    const now = performance.now();
    if (now - this.tableAt < TABLE_PERIOD_MS) return; // a DOM table of 100 rows is costly at 10 Hz
    this.tableAt = now;
    const rows = state.rovers.map((r) =>
      `<tr data-id="${r.id}" class="${String(r.id) === this.selected ? "sel" : ""}"><td>${r.id}</td>` +
      `<td>${r.alive ? r.state : "lost"}</td><td>${r.goal}</td><td>${r.to_goal.toFixed(1)}</td><td>${r.covered.toFixed(1)}</td></tr>`);
    $("rovers").querySelector("tbody").innerHTML = rows.join("");
    const select = $("cmd-rover");
    for (const r of state.rovers) {
      if (this.known.has(r.id)) continue;
      this.known.add(r.id);
      select.add(new Option(`rover ${r.id}`, String(r.id)));
    }
  }

  setStats(stats) {
    const r = stats.report;
    $("simstats").innerHTML = SIM_FIELDS.map(([k, label]) => `<tr><td>${label}</td><td data-field="${k}">${fmt(r[k])}</td></tr>`).join("")
      + `<tr><td>rovers</td><td>${r.rovers_total}</td></tr>`;
  }

  setLander(l) {
    $("lander").textContent = `lander: ${l.phase}; connected ${l.connected.join(", ") || "none"}` +
      (l.relay_chain.length ? `; relay chain ${l.relay_chain.join(" → ")}` : "");
  }

  setPhoto(p) {
    let fig = document.getElementById(`photo-${p.rover}`);
    if (!fig) {
      fig = document.createElement("figure");
      fig.id = `photo-${p.rover}`;
      fig.innerHTML = "<img alt=''><figcaption></figcaption>";
      $("photos").appendChild(fig);
    }
    fig.querySelector("img").src = `data:image/png;base64,${p.png}`;
    fig.querySelector("figcaption").textContent = `rover ${p.rover} at ${p.stamp.toFixed(1)} s ${p.label}`;
  }

  setTarget(x, z) {
    $("cmd-x").value = x.toFixed(1);
    $("cmd-z").value = z.toFixed(1);
  }

  async send(name) {
    const body = { command: name, rover_id: $("cmd-rover").value || null, x: $("cmd-x").value, z: $("cmd-z").value,
      kind: $("cmd-kind").value };
    $("cmd-result").textContent = `${name}: sending…`;
    const result = await post("/api/command", body);
    this.page.lastCommand = { name, ...result };
    $("cmd-result").textContent = result.ok ? `${name}: ${result.accepted ? "accepted" : "refused"}: ${result.detail}`
      : `${name}: ${result.error}`;
    $("cmd-result").className = result.ok && result.accepted ? "ok" : "bad";
  }
}
