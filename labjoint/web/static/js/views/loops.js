// Measured hysteresis loops of a run: its steady cycles as the loop pipeline found them
// (GET /runs/{name}/loops), or, for a run being recorded, its last cycles straight from
// the samples.

import { api } from '../api.js';
import { plotXY } from '../plot/plot.js';
import { color } from '../plot/svg.js';

export const MAX_SPAN = 20000; // samples in one request (the server's default max_points)
export const LOOP_POINTS = 200; // most points per cycle asked of the server

// The last `cycles` steady cycles of a finished run: the endpoint's body (cycles may be
// empty, with the reason).
export function steadyLoops(name, cycles = 8, points = LOOP_POINTS) {
  return api(`/runs/${encodeURIComponent(name)}/loops`, {
    query: { max_cycles: cycles, points_per_cycle: points },
  });
}

// Fetch displacement and joint force over the last `cycles` whole cycles of a run that
// holds nSamples samples at fs, excited at f; {u, F, per, cycles, start}.
export async function lastCycles(name, nSamples, fs, f, cycles = 8) {
  const per = fs / f;
  let k = Math.min(cycles, Math.floor(nSamples / per));
  while (k > 1 && k * per > MAX_SPAN) k -= 1;
  if (k < 1 || !(per > 2)) return null;
  const span = Math.round(k * per);
  const start = nSamples - span;
  const data = await api(`/runs/${encodeURIComponent(name)}/data`, {
    query: { channel: ['displacement', 'force'], unit: 'samples', start, stop: nSamples,
      max_points: Math.max(span, 10) },
  });
  const [u, F] = data.series.map((x) => x.values);
  return { u, F, per, cycles: k, start: data.start_sample, decimated: data.decimated };
}

const um = (xs) => xs.map((v) => (v == null ? null : v * 1e6));

// One closed line per cycle, older cycles paler; displacement in µm, force in N.
// `lc`: lastCycles' raw stretch ({u, F, per, cycles}) or steadyLoops' body ({cycles: [...]}).
export function loopPlot(lc, { id = 'loop', title = '', extra = [] } = {}) {
  const series = [];
  const steady = lc && Array.isArray(lc.cycles);
  const n = !lc ? 0 : steady ? lc.cycles.length : lc.cycles;
  for (let c = 0; c < n; c += 1) {
    let x;
    let y;
    if (steady) {
      const cy = lc.cycles[c];
      x = um([...cy.displacement_m, cy.displacement_m[0]]);  // one whole period: close it
      y = [...cy.force_n, cy.force_n[0]];
    } else {
      const a = Math.round(c * lc.per);
      const b = Math.min(Math.round((c + 1) * lc.per) + 1, lc.u.length);
      x = um(lc.u.slice(a, b));
      y = lc.F.slice(a, b);
    }
    const last = c === n - 1;
    series.push({ name: last ? `measured (${n} ${steady ? 'steady ' : ''}cycles)` : '', x, y,
      color: color(0), opacity: 0.35 + 0.65 * ((c + 1) / n), legend: last });
  }
  const svg = plotXY({ id, title, series: series.concat(extra), xlabel: 'relative displacement (µm)',
    ylabel: 'joint force (N)', height: 360, empty: 'no cycles yet' });
  svg.dataset.source = !lc ? 'none' : steady ? 'steady' : 'raw';
  svg.dataset.cycles = String(n);
  return svg;
}
