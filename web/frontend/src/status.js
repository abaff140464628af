// What the header says about the run. The page's link to the viewer is one thing and the world another: the viewer
// stays up after the world stops, so a green "connected" said nothing. The header says "waiting for a world at ..."
// while the viewer reaches no router there, "live" while world states arrive, "replay" (or "replay paused") while
// a replay holds its token on the world, "run ended" once the world's final statistics come (with what they say),
// and "world silent" when states stop without them (a world that was killed).
import { formatStat } from "./format.js";

const SILENT_AFTER_MS = 5000;
// A replay's last states may reach the page just after word that it went (another path through Zenoh and the viewer).
const REPLAY_TAIL_MS = 1000;
const $ = (id) => document.getElementById(id);

export class RunStatus {
  constructor(page) {
    this.page = page;
    this.viewer = false;
    this.lastStateAt = null;
    this.ended = null;
    this.sceneSeen = false;
    this.from = { router: "", connected: true, replay: null };
    this.replayGoneAt = null;
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
    if (msg.source) this.source(msg.source);
  }

  // Where the samples come from: whether the viewer reaches a router, and whether a replay plays on the world.
  // The states shown until a replay went came from it: they say nothing of a live world, so no "live" after it.
  source(msg) {
    const replay = msg.replay || null;
    if (this.from.replay && !replay) this.replayGoneAt = performance.now();
    this.from = { router: String(msg.router || ""), connected: Boolean(msg.connected), replay };
    this.page.source = this.from;
    this.show();
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
    if (status === this.page.run.status && text === this.page.run.text && detail === this.page.run.detail) return;
    this.page.run = { status, text, detail };
    $("conn").textContent = text;
    $("conn").className = cls;
    $("runinfo").textContent = detail;
  }

  describe() {
    if (!this.viewer && !this.wasConnected) return ["connecting", "connecting…", "bad", ""];
    if (!this.viewer) return ["disconnected", "viewer disconnected, retrying…", "bad", ""];
    const replay = this.from.connected ? this.from.replay : null;
    // A paused replay says so first, also when it was paused at its recording's end (a looping one starts over)
    if (replay === "paused") return ["paused", "replay paused", "wait", "resume it here or in the replay's terminal"];
    if (this.ended) {
      const r = this.ended.report;
      return ["ended", replay ? "replay: run ended" : "run ended", "ended", `at t = ${formatStat("s", this.ended.stamp)} s: ` +
        `${r.rovers_reached_final_goal}/${r.rovers_total} rovers reached their final goal; mission ${r.complete ? "complete" : "not complete"}`];
    }
    if (!this.from.connected) {
      return ["no-router", `waiting for a world at ${this.from.router}`, "wait",
        "the view connects by itself when a world (lunarsim run) or a router starts there"];
    }
    const quiet = this.lastStateAt === null ? null : performance.now() - this.lastStateAt;
    if (replay) {
      const note = quiet === null ? "no world state from it yet" : quiet > SILENT_AFTER_MS ? `no world state for ${Math.round(quiet / 1000)} s` : "";
      return ["replay", "replay", "ok", note];
    }
    if (quiet === null) return ["waiting", "waiting for the world", "wait", ""];
    if (this.replayGoneAt !== null && this.lastStateAt <= this.replayGoneAt + REPLAY_TAIL_MS) {
      return ["silent", "world silent", "bad", "the replay stopped"];
    }
    if (quiet > SILENT_AFTER_MS) {
      return ["silent", "world silent", "bad", `no world state for ${Math.round(quiet / 1000)} s: the world stopped`];
    }
    return ["live", "live", "ok", ""];
  }
}
