// The lander's traverse map (lander_agent/mapping.py) draped over the terrain: one texel per map cell, in the
// classes' PNG colours, unknown cells transparent. The server forwards the map still zlib-compressed; the
// browser inflates it (DecompressionStream "deflate" is zlib's format).
import * as THREE from "three";

const ALPHA = 150;
const LIFT_M = 0.25;
const MAX_SIDE = 160;

// The PNG's free light grey vanishes on the light terrain of the 3D view: free ground is drawn teal here.
const PAGE_COLOURS = { free: [40, 170, 200] };

export function pageColours(msg) {
  return msg.classes.map((name, i) => PAGE_COLOURS[name] || msg.colours[i]);
}

export async function inflate(b64) {
  const bytes = Uint8Array.from(atob(b64), (c) => c.charCodeAt(0));
  const stream = new Blob([bytes]).stream().pipeThrough(new DecompressionStream("deflate"));
  return new Uint8Array(await new Response(stream).arrayBuffer());
}

// RGBA texels for the class codes: row j of the map is texture row j (DataTexture rows run from v = 0).
export function texels(msg, cells) {
  const rgba = new Uint8Array(msg.width * msg.height * 4);
  for (let k = 0; k < cells.length; k++) {
    const code = cells[k], c = msg.colours[code] || [255, 0, 255];
    rgba.set([c[0], c[1], c[2], code === 0 ? 0 : ALPHA], k * 4);
  }
  return rgba;
}

// A grid mesh over the map's rectangle following the ground, a little above it so the terrain does not
// show through; at most MAX_SIDE vertices a side (the texture carries the cells' detail).
function drape(msg, ground) {
  const w = msg.width * msg.cell_m, h = msg.height * msg.cell_m;
  const nx = Math.min(MAX_SIDE, msg.width + 1), nz = Math.min(MAX_SIDE, msg.height + 1);
  const pos = new Float32Array(nx * nz * 3), uv = new Float32Array(nx * nz * 2), index = [];
  for (let j = 0; j < nz; j++) {
    for (let i = 0; i < nx; i++) {
      const u = i / (nx - 1), v = j / (nz - 1), x = msg.origin_x + u * w, z = msg.origin_z + v * h;
      pos.set([x, ground.at(x, z) + LIFT_M, -z], (j * nx + i) * 3);
      uv.set([u, v], (j * nx + i) * 2);
      if (i && j) { const d = j * nx + i, c = d - 1, b = d - nx, a = b - 1; index.push(a, b, d, a, d, c); }
    }
  }
  const geo = new THREE.BufferGeometry();
  geo.setAttribute("position", new THREE.BufferAttribute(pos, 3));
  geo.setAttribute("uv", new THREE.BufferAttribute(uv, 2));
  geo.setIndex(index);
  return geo;
}

export class MapOverlay {
  constructor(scene) {
    this.scene = scene;
    this.mesh = null;
    this.shape = "";
    this.visible = true;
  }

  // Same grid as before: only the texture changes. A new grid (or new terrain): a new mesh.
  update(msg, cells, ground) {
    const shape = [msg.width, msg.height, msg.cell_m, msg.origin_x, msg.origin_z].join();
    if (this.mesh && (shape !== this.shape || ground !== this.ground)) this.clear();
    if (!this.mesh) {
      const texture = new THREE.DataTexture(texels(msg, cells), msg.width, msg.height, THREE.RGBAFormat);
      texture.magFilter = THREE.NearestFilter;
      texture.minFilter = THREE.NearestFilter;
      const material = new THREE.MeshBasicMaterial({ map: texture, transparent: true, depthWrite: false, side: THREE.DoubleSide });
      this.mesh = new THREE.Mesh(drape(msg, ground), material);
      this.mesh.visible = this.visible;
      this.scene.add(this.mesh);
      this.shape = shape;
      this.ground = ground;
    } else {
      this.mesh.material.map.image.data.set(texels(msg, cells));
    }
    this.mesh.material.map.needsUpdate = true;
  }

  show(on) {
    this.visible = on;
    if (this.mesh) this.mesh.visible = on;
  }

  clear() {
    if (!this.mesh) return;
    this.scene.remove(this.mesh);
    this.mesh.geometry.dispose();
    this.mesh.material.map.dispose();
    this.mesh.material.dispose();
    this.mesh = null;
  }
}
