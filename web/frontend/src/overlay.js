// What the 3D view draws over the picture: a scale bar in metres at the orbit's centre, and a compass with the
// report's axes (+x right, +z forward; a heading of 0 points along +z) as the camera sees them. Both are plain
// HTML over the canvas, redrawn only when what they show changes.
import * as THREE from "three";
import { metresText, niceLength } from "./format.js";

const BAR_MAX_PX = 150;
const ARROW_PX = 30;

export class ViewOverlay {
  constructor(container, onFrame) {
    this.scale = null; // {metres, px}: what the bar shows
    this.compass = null; // {x: [dx, dy], z: [dx, dy]}: the axes' screen directions, y down
    this.bar = element(container, "div", "scalebar", "overlay", "<div class='bar'></div><span></span>");
    this.dial = element(container, "canvas", "compass", "overlay");
    this.dial.width = 120; this.dial.height = 100;
    this.dial.title = "the report's axes: x to the right, z forward; a heading of 0 points along +z";
    const button = element(container, "button", "frame-view", "overlay", "frame the mission");
    button.title = "look at the lander, the rovers' start and the goals again";
    button.addEventListener("click", onFrame);
  }

  // Metres per pixel at the orbit's centre, where the eye rests: the bar is right there and close to right nearby.
  update(camera, target, heightPx) {
    const distance = camera.position.distanceTo(target);
    const metresPerPx = (2 * distance * Math.tan((camera.fov * Math.PI) / 360)) / Math.max(1, heightPx);
    const metres = niceLength(BAR_MAX_PX * metresPerPx), px = Math.round(metres / metresPerPx);
    if (!this.scale || this.scale.metres !== metres || this.scale.px !== px) {
      this.scale = { metres, px };
      this.bar.querySelector(".bar").style.width = `${px}px`;
      this.bar.querySelector("span").textContent = metresText(metres);
    }
    const x = screenDirection(camera, target, new THREE.Vector3(1, 0, 0));
    const z = screenDirection(camera, target, new THREE.Vector3(0, 0, -1)); // LunarSim +z is three.js -z
    const same = this.compass && [...x, ...z].every((v, i) => Math.abs(v - [...this.compass.x, ...this.compass.z][i]) < 0.01);
    if (!same) {
      this.compass = { x, z };
      this.drawCompass();
    }
  }

  drawCompass() {
    const ctx = this.dial.getContext("2d"), w = this.dial.width, h = this.dial.height;
    const ox = w / 2, oy = h / 2 - 6;
    ctx.clearRect(0, 0, w, h);
    ctx.fillStyle = "rgba(20, 20, 20, 0.7)";
    ctx.fillRect(0, 0, w, h);
    ctx.font = "11px sans-serif"; ctx.textAlign = "center"; ctx.textBaseline = "middle"; ctx.lineWidth = 2;
    for (const [name, [dx, dy], color] of [["x", this.compass.x, "#ff6b6b"], ["z", this.compass.z, "#6bb5ff"]]) {
      const ex = ox + dx * ARROW_PX, ey = oy + dy * ARROW_PX;
      ctx.strokeStyle = color; ctx.fillStyle = color;
      ctx.beginPath(); ctx.moveTo(ox, oy); ctx.lineTo(ex, ey); ctx.stroke();
      ctx.beginPath(); ctx.arc(ex, ey, 2.5, 0, Math.PI * 2); ctx.fill();
      ctx.fillText(`+${name}`, ox + dx * (ARROW_PX + 10), oy + dy * (ARROW_PX + 10));
    }
    ctx.fillStyle = "#bbb";
    ctx.fillText("heading 0 = +z", w / 2, h - 8);
  }
}

function element(container, tag, id, cls, html) {
  const el = document.createElement(tag);
  el.id = id;
  el.className = cls;
  if (html) el.innerHTML = html;
  container.appendChild(el);
  return el;
}

// Where a unit step along `axis` from `target` goes on the screen: x right, y down, scaled so the longer of the
// two ground axes is 1 (a foreshortened axis shows shorter).
function screenDirection(camera, target, axis) {
  const a = target.clone().project(camera), b = target.clone().add(axis).project(camera);
  const dx = (b.x - a.x) * camera.aspect, dy = -(b.y - a.y);
  const other = target.clone().add(new THREE.Vector3(axis.z, 0, axis.x)).project(camera);
  const ox = (other.x - a.x) * camera.aspect, oy = -(other.y - a.y);
  const longest = Math.max(Math.hypot(dx, dy), Math.hypot(ox, oy)) || 1;
  return [dx / longest, dy / longest].map((v) => Math.round(v * 1000) / 1000);
}
