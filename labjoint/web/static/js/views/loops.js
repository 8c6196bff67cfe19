// Measured hysteresis loops of a run: its last steady cycles, straight from the samples.

import { api } from '../api.js';
import { plotXY } from '../plot/plot.js';
import { color } from '../plot/svg.js';

export const MAX_SPAN = 20000; // samples in one request (the server's default max_points)

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

// One line per cycle, older cycles paler; displacement in µm, force in N.
export function loopPlot(lc, { id = 'loop', title = '', extra = [] } = {}) {
  const series = [];
  if (lc) {
    for (let c = 0; c < lc.cycles; c += 1) {
      const a = Math.round(c * lc.per);
      const b = Math.min(Math.round((c + 1) * lc.per) + 1, lc.u.length);
      series.push({ name: c === lc.cycles - 1 ? `measured (${lc.cycles} cycles)` : '',
        x: lc.u.slice(a, b).map((v) => (v == null ? null : v * 1e6)), y: lc.F.slice(a, b),
        color: color(0), opacity: 0.35 + 0.65 * ((c + 1) / lc.cycles), legend: c === lc.cycles - 1 });
    }
  }
  return plotXY({ id, title, series: series.concat(extra), xlabel: 'relative displacement (µm)',
    ylabel: 'joint force (N)', height: 360, empty: 'no cycles yet' });
}
