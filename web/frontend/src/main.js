// Entry point: the WebSocket feed, tabs, and the three parts (3D view, panels, editor).
import { LiveView } from "./live3d.js";
import { Panels } from "./panels.js";
import { Editor } from "./editor.js";
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
view.onPick = (x, z) => panels.setTarget(x, z);

for (const tab of document.querySelectorAll(".tab")) {
  tab.addEventListener("click", () => {
    for (const t of document.querySelectorAll(".tab")) t.classList.toggle("active", t === tab);
    for (const p of document.querySelectorAll(".pane")) p.classList.toggle("active", p.id === tab.dataset.tab);
    if (tab.dataset.tab === "editor") editor.show(); else view.resize();
  });
}

function handle(msg) {
  switch (msg.type) {
    case "hello": lunarsim.world = msg.world; $("world").textContent = `world ${msg.world}`; break;
    case "scene": lunarsim.scene = msg.scene; lunarsim.map = null; view.setScene(msg.scene); panels.setScene(msg.scene); break;
    case "state": lunarsim.state = msg; lunarsim.states += 1; view.setState(msg); panels.setState(msg); break;
    case "stats": lunarsim.stats = msg; panels.setStats(msg); break;
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
  ws.onopen = () => { lunarsim.connected = true; $("conn").textContent = "connected"; $("conn").className = "ok"; };
  ws.onmessage = (ev) => handle(JSON.parse(ev.data));
  ws.onclose = () => {
    lunarsim.connected = false;
    $("conn").textContent = "disconnected, retrying…";
    $("conn").className = "bad";
    setTimeout(connect, 1000);
  };
}

let last = performance.now(), counted = 0;
function frame(now) {
  view.render(now);
  counted += 1;
  lunarsim.frames += 1;
  if (now - last >= 1000) {
    lunarsim.fps = (counted * 1000) / (now - last);
    $("fps").textContent = `${lunarsim.fps.toFixed(0)} fps`;
    counted = 0;
    last = now;
  }
  requestAnimationFrame(frame);
}
connect();
requestAnimationFrame(frame);
