// Entry point: the WebSocket feed, the tabs (each with its own URL: /live, /editor), and the parts of the page
// (3D view, panels, editor, the run's status in the header).
import { LiveView } from "./live3d.js";
import { Panels } from "./panels.js";
import { Editor } from "./editor.js";
import { RunStatus } from "./status.js";
import { inflate, pageColours } from "./traversemap.js";

// Page state, also read by the browser tests and the FPS benchmark.
const lunarsim = (window.lunarsim = {
  connected: false, world: "", scene: null, state: null, stats: null, lander: null,
  photos: {}, map: null, maps: 0, fps: 0, renderScale: 1, frames: 0, states: 0, lastCommand: null, webgl: false,
});

const $ = (id) => document.getElementById(id);
const view = (lunarsim.view = new LiveView($("view3d"), lunarsim));
const panels = new Panels(lunarsim);
const editor = new Editor(lunarsim);
const run = new RunStatus(lunarsim);
view.onPick = (x, z) => panels.setTarget(x, z);

const TABS = { live: "LunarSim: live view", editor: "LunarSim: scenario editor" };

function tabOfPath() {
  const name = location.pathname.replace(/^\/+|\/+$/g, "");
  return name in TABS ? name : "live";
}

function showTab(name, push) {
  for (const t of document.querySelectorAll(".tab")) t.classList.toggle("active", t.dataset.tab === name);
  for (const p of document.querySelectorAll(".pane")) p.classList.toggle("active", p.id === name);
  document.title = TABS[name];
  lunarsim.tab = name;
  if (push && location.pathname !== `/${name}`) history.pushState({ tab: name }, "", `/${name}${location.search}`);
  if (name === "editor") editor.show(); else view.resize();
}

for (const tab of document.querySelectorAll(".tab")) tab.addEventListener("click", () => showTab(tab.dataset.tab, true));
window.addEventListener("popstate", () => showTab(tabOfPath(), false));
showTab(tabOfPath(), false);

function handle(msg) {
  switch (msg.type) {
    case "hello": lunarsim.world = msg.world; $("world").textContent = `world ${msg.world}`; run.hello(msg); break;
    case "scene": lunarsim.scene = msg.scene; lunarsim.map = null; view.setScene(msg.scene); panels.setScene(msg.scene); run.scene(); break;
    case "state": lunarsim.state = msg; lunarsim.states += 1; view.setState(msg); panels.setState(msg); run.state(msg); break;
    case "stats": lunarsim.stats = msg; panels.setStats(msg); run.stats(msg); break;
    case "source": run.source(msg); break;
    case "lander": lunarsim.lander = msg; panels.setLander(msg); break;
    case "photo": lunarsim.photos[msg.rover] = msg; panels.setPhoto(msg); break;
    case "map": showMap(msg); break;
  }
}

async function showMap(msg) {
  const cells = await inflate(msg.cells);
  msg.colours = pageColours(msg);
  if (lunarsim.map && lunarsim.map.stamp > msg.stamp) return; // a newer map was inflated first
  lunarsim.map = { ...msg, cells: undefined, bytes: cells.length };
  lunarsim.maps += 1;
  view.setMap(msg, cells);
  panels.setMap(msg);
}

$("map-show").addEventListener("change", () => view.showMap($("map-show").checked));

function connect() {
  const ws = new WebSocket(`${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/ws`);
  ws.onopen = () => { lunarsim.connected = true; run.connected(true); };
  ws.onmessage = (ev) => handle(JSON.parse(ev.data));
  ws.onclose = () => {
    lunarsim.connected = false;
    run.connected(false);
    setTimeout(connect, 1000);
  };
}

let last = performance.now(), counted = 0;
function frame(now) {
  if (view.render(now)) {
    counted += 1;
    lunarsim.frames += 1;
  }
  if (now - last >= 1000) {
    lunarsim.fps = (counted * 1000) / (now - last);
    $("fps").textContent = counted ? `${lunarsim.fps.toFixed(0)} fps` : "idle: nothing moved";
    counted = 0;
    last = now;
  }
  requestAnimationFrame(frame);
}
connect();
requestAnimationFrame(frame);
