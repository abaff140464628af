// What the header says about the run. The page's link to the viewer is one thing and the world another: the viewer
// stays up after the world stops, so a green "connected" said nothing. The header says "live" while world states
// arrive, "run ended" once the world's final statistics come (with what they say), and "world silent" when states
// stop without them (a world that was killed, or a paused replay).
import { formatStat } from "./format.js";

const SILENT_AFTER_MS = 5000;
const $ = (id) => document.getElementById(id);

export class RunStatus {
  constructor(page) {
    this.page = page;
    this.viewer = false;
    this.lastStateAt = null;
    this.ended = null;
    this.sceneSeen = false;
    page.run = { status: "connecting", detail: "" };
    setInterval(() => this.show(), 500);
  }

  connected(on) {
    this.viewer = on;
    this.wasConnected = this.wasConnected || on;
    this.sceneSeen = false;
    this.show();
  }

  // The viewer says how long ago the world's last state reached it, so a late page knows a stopped world at once.
  // That stored state comes next, before anything new: it must not count as the world speaking now.
  hello(msg) {
    const age = msg.state_age_s;
    this.lastStateAt = typeof age === "number" ? performance.now() - 1000 * age : null;
    this.storedStateDue = typeof age === "number";
  }

  // A scene after the first one is a new run (launched from the editor): the last run's ending no longer holds.
  scene() {
    if (this.sceneSeen) { this.lastStateAt = null; this.ended = null; }
    this.sceneSeen = true;
    this.show();
  }

  state(msg) {
    if (this.storedStateDue) this.storedStateDue = false; else this.lastStateAt = performance.now();
    if (this.ended && msg.stamp < this.ended.stamp) this.ended = null; // a looping replay started over
    this.show();
  }

  stats(msg) {
    this.ended = msg.final ? msg : null;
    this.show();
  }

  show() {
    const [status, text, cls, detail] = this.describe();
    if (status === this.page.run.status && detail === this.page.run.detail) return;
    this.page.run = { status, detail };
    $("conn").textContent = text;
    $("conn").className = cls;
    $("runinfo").textContent = detail;
  }

  describe() {
    if (!this.viewer && !this.wasConnected) return ["connecting", "connecting…", "bad", ""];
    if (!this.viewer) return ["disconnected", "viewer disconnected, retrying…", "bad", ""];
    if (this.ended) {
      const r = this.ended.report;
      return ["ended", "run ended", "ended", `at t = ${formatStat("s", this.ended.stamp)} s: ${r.rovers_reached_final_goal}/` +
        `${r.rovers_total} rovers reached their final goal; mission ${r.complete ? "complete" : "not complete"}`];
    }
    if (this.lastStateAt === null) return ["waiting", "waiting for the world", "wait", ""];
    const quiet = performance.now() - this.lastStateAt;
    if (quiet > SILENT_AFTER_MS) {
      return ["silent", "world silent", "bad", `no world state for ${Math.round(quiet / 1000)} s: stopped, or a paused replay`];
    }
    return ["live", "live", "ok", ""];
  }
}
