// Statistics (report 10.6.3: the simulation's and each rover's), the ground station, and photos.
import { post } from "./api.js";
import { formatStat, goalNumber } from "./format.js";

const $ = (id) => document.getElementById(id);
// Report 3.4.7 and the fitness list of 6.3.3, in their order, as the world's MissionReport names them, each with
// its kind (format.js: how many decimals a reader needs).
const SIM_FIELDS = [
  ["relative_path_length_m", "relative path length (m)", "m"],
  ["average_distance_covered_m", "average distance covered (m)", "m"],
  ["average_path_efficiency", "average path efficiency (every rover)", "ratio"],
  ["reached_path_efficiency", "path efficiency of the rovers that reached", "ratio"],
  ["rovers_reached_final_goal", "rovers that reached the final goal", "count"],
  ["rovers_holding_relay_spots", "rovers holding daisy-chain relay spots", "count"],
  ["rover_collisions", "rover collisions", "count"],
  ["obstacle_collisions", "obstacle collisions", "count"],
  ["rovers_stuck", "rovers stuck", "count"],
  ["mission_duration_s", "mission duration (s)", "s"],
  ["total_distance_covered_m", "total distance covered (m)", "m"],
  ["lander_connection_losses", "lander connection losses", "count"],
  ["disconnected_time_s", "time without a route to the lander (rover-s)", "s"],
  ["worst_rover_connected_fraction", "least connected rover's share", "share"],
  ["max_rovers_in_daisy_chain", "most rovers in the daisy chain", "count"],
  ["rejected_messages", "rejected messages", "count"],
  ["radio_dropped", "radio dropped", "count"],
  ["radio_lost", "radio lost", "count"],
  ["complete", "complete", "bool"],
];
// Shown only when the run has them: the lander's map and the power model (a scenario with a sun).
const OPTIONAL_FIELDS = [
  ["map_corridor_mapped", "share of the A-B corridor mapped", "share"],
  ["map_obstacles_found", "share of the corridor's obstacles mapped", "share"],
  ["map_obstacle_precision", "share of mapped obstacles that are real", "share"],
  ["power_budget_efficiency", "power budget efficiency", "ratio"],
  ["energy_used_wh", "energy used (Wh)", "Wh"],
  ["power_shutdowns", "power shutdowns (battery empty)", "count"],
  ["cold_shutdowns", "cold shutdowns (too cold to run)", "count"],
];
// The report's average efficiency divides the ideal path by the distance every rover covered, finished or not, so
// above 1 it says rovers stopped short, not that they did well: the page says so, as the terminal does.
const NOTES = {
  average_path_efficiency: (v) => (v > 1 ? " (above 1: rovers stopped short)" : ""),
};
const BASE_COLUMNS = "<th>id</th><th>state</th><th>goal</th><th>to goal m</th><th>covered m</th>";
const POWER_COLUMNS = "<th title=\"battery charge\">Wh</th><th title=\"battery charge, % of capacity\">%</th>" +
  "<th title=\"temperature\">°C</th><th title=\"panel in sunlight\">light</th><th title=\"off: battery empty or too cold\">on</th>";
const TABLE_PERIOD_MS = 400;

export class Panels {
  constructor(page) {
    this.page = page;
    this.selected = null;
    this.tableAt = -TABLE_PERIOD_MS;
    this.tableTimer = null;
    this.pendingState = null;
    this.known = new Set();
    this.capacity = null;
    this.powerShown = null;
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
    // A DOM table of 100 rows is costly at 10 Hz, so it is redrawn at most once a period; the latest state
    // is drawn at the period's end, so the last state of a world that stops is never left undrawn.
    this.pendingState = state;
    if (this.tableTimer !== null) return;
    const wait = Math.max(0, this.tableAt + TABLE_PERIOD_MS - performance.now());
    this.tableTimer = setTimeout(() => {
      this.tableTimer = null;
      this.tableAt = performance.now();
      this.drawTable(this.pendingState);
    }, wait);
  }

  drawTable(state) {
    const power = state.rovers.some((r) => r.battery_wh !== undefined);
    if (power !== this.powerShown) {
      this.powerShown = power;
      $("rovers").querySelector("thead tr").innerHTML = BASE_COLUMNS + (power ? POWER_COLUMNS : "");
      $("power-note").textContent = power ? "" : "No sun in this scenario: battery and temperature are not simulated.";
    }
    const rows = state.rovers.map((r) =>
      `<tr data-id="${r.id}" class="${String(r.id) === this.selected ? "sel" : ""}"><td>${r.id}</td>` +
      `<td>${r.alive ? r.state : "lost"}</td><td data-field="goal">${goalNumber(r.goal)}</td><td>${r.to_goal.toFixed(1)}</td><td>${r.covered.toFixed(1)}</td>` +
      (power ? this.powerCells(r) : "") + "</tr>");
    $("rovers").querySelector("tbody").innerHTML = rows.join("");
    const select = $("cmd-rover");
    for (const r of state.rovers) {
      if (this.known.has(r.id)) continue;
      this.known.add(r.id);
      select.add(new Option(`rover ${r.id}`, String(r.id)));
    }
  }

  powerCells(r) {
    if (r.battery_wh === undefined) return "<td></td>".repeat(5);
    const pct = this.capacity ? `${Math.round((100 * r.battery_wh) / this.capacity)}` : "";
    const temp = r.temperature_c === null ? "" : r.temperature_c.toFixed(1);
    return `<td data-field="battery_wh">${r.battery_wh.toPrecision(3)}</td><td data-field="battery_pct">${pct}</td>` +
      `<td>${temp}</td><td>${r.sunlit ? "sun" : "shadow"}</td>` +
      `<td class="${r.powered ? "" : "bad"}">${r.powered ? "on" : "off"}</td>`;
  }

  setScene(scene) {
    this.capacity = scene.power ? scene.power.capacity_wh : null;
    $("maplegend").hidden = true;
  }

  setMap(msg) {
    $("maplegend").hidden = false;
    $("map-info").textContent = `lander's map at ${msg.stamp.toFixed(0)} s, ${msg.width} × ${msg.height} cells of ${msg.cell_m} m`;
    $("map-classes").innerHTML = msg.classes.map((name, i) => {
      const [r, g, b] = msg.colours[i];
      return `<span class="swatch" style="background: rgb(${r},${g},${b})"></span>${name} ${msg.counts[i]}`;
    }).join(" ");
  }

  setStats(stats) {
    const r = stats.report;
    const fields = SIM_FIELDS.concat(OPTIONAL_FIELDS.filter(([k]) => r[k] !== null && r[k] !== undefined));
    $("simstats").innerHTML = fields.map(([k, label, kind]) =>
      `<tr><td>${label}</td><td data-field="${k}">${formatStat(kind, r[k])}${NOTES[k]?.(r[k]) ?? ""}</td></tr>`).join("")
      + `<tr><td>rovers</td><td data-field="rovers_total">${r.rovers_total}</td></tr>`;
    $("stats-when").textContent = `${stats.final ? "final, " : ""}at t = ${formatStat("s", stats.stamp)} s`;
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
