// How the page writes numbers: what a reader needs and no more. Metres, seconds and percentages get one decimal,
// counts are integers, ratios two decimals; goals are numbered from 1 as the terminal numbers them (the wire's
// goal_index stays 0-based: that is the contract, this is only what a person reads).

export function formatStat(kind, v) {
  if (v === null || v === undefined) return "–";
  if (kind === "bool") return v ? "yes" : "no";
  if (typeof v !== "number") return String(v);
  switch (kind) {
    case "count": return String(Math.round(v));
    case "m": case "s": return v.toFixed(1);
    case "share": return `${(100 * v).toFixed(1)}%`;
    case "ratio": return v.toFixed(2);
    case "Wh": return v === 0 ? "0" : v.toPrecision(3);
    default: return Number.isInteger(v) ? String(v) : v.toFixed(1);
  }
}

// A goal index off the wire (0-based, -1 for none) as people count goals.
export function goalNumber(index) {
  return typeof index === "number" && index >= 0 ? String(index + 1) : "–";
}

// The longest 1, 2 or 5 times a power of ten not over `metres`: a scale bar's length.
export function niceLength(metres) {
  if (!(metres > 0)) return 0;
  const power = 10 ** Math.floor(Math.log10(metres));
  for (const step of [5, 2, 1]) if (step * power <= metres) return step * power;
  return power;
}

export function metresText(metres) {
  return metres >= 1000 ? `${metres / 1000} km` : `${metres} m`;
}
