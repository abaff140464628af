// Terrain height at any (x, z) from the grid the server sent, bilinear; 0 when there is no terrain yet.
export class Ground {
  constructor(t) {
    this.t = t;
    if (t) {
      this.dx = (t.x1 - t.x0) / (t.nx - 1);
      this.dz = (t.z1 - t.z0) / (t.nz - 1);
    }
  }

  at(x, z) {
    const t = this.t;
    if (!t) return 0;
    const fi = Math.min(Math.max((x - t.x0) / this.dx, 0), t.nx - 1.001);
    const fj = Math.min(Math.max((z - t.z0) / this.dz, 0), t.nz - 1.001);
    const i = Math.floor(fi), j = Math.floor(fj), u = fi - i, v = fj - j;
    const h = (ii, jj) => t.heights[jj * t.nx + ii];
    return (h(i, j) * (1 - u) + h(i + 1, j) * u) * (1 - v) + (h(i, j + 1) * (1 - u) + h(i + 1, j + 1) * u) * v;
  }
}
