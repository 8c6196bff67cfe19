// The structure view's FRF plots: per mode and sensor, magnitude per newton and phase
// against frequency, every force level overlaid (one colour per level, named in the
// legend): the measured steps as points, the model as a curve evaluated densely by
// harmonic balance between and around the steps (POST /structures/{name}/curves), never a
// line through the steps. Residual over noise per frequency and level for each harmonic.

import { h } from '../dom.js';
import { fmt } from '../units.js';
import { plotXY } from '../plot/plot.js';
import { heatMap } from '../plot/heatmap.js';
import { color } from '../plot/svg.js';

// "m/s^2/N" -> "m/s²/N"
const pretty = (u) => String(u || '').replace(/\^2/g, '²');
const levelName = (sw) => `${fmt(sw.level_n, 3)} N ${sw.direction}`;
const slug = (x) => String(x).replace(/[^A-Za-z0-9_-]/g, '_');

// A phone's screen: plots drawn narrower, so that their text stays readable when scaled.
const narrow = () => window.innerWidth < 600;

// Phase in (-180, 180]: a wrap between two neighbours is not drawn as a vertical line.
function unwrapBreaks(f, ph) {
  const x = [];
  const y = [];
  for (let i = 0; i < ph.length; i += 1) {
    if (i > 0 && ph[i] != null && ph[i - 1] != null && Math.abs(ph[i] - ph[i - 1]) > 180) {
      x.push(null);
      y.push(null);
    }
    x.push(f[i]);
    y.push(ph[i]);
  }
  return { x, y };
}

// One figure per (mode, sensor) of the harmonic hn: magnitude and phase, levels overlaid.
export function curvePlots(curves, hn) {
  const sweeps = curves.sweeps.slice().sort((a, b) => a.mode - b.mode || a.level_n - b.level_n
    || a.direction.localeCompare(b.direction));
  const levels = [...new Set(sweeps.map(levelName))];
  const hue = (sw) => color(levels.indexOf(levelName(sw)));
  // where levels coincide (a linear law: one curve per newton) each stays visible: the
  // first level's line and points are the widest, each next one narrower on top of it
  const under = (sw) => levels.length - 1 - levels.indexOf(levelName(sw));
  const modes = [...new Set(sweeps.map((sw) => sw.mode))];
  const figs = [];
  for (const mode of modes) {
    const ms = sweeps.filter((sw) => sw.mode === mode && hn <= sw.harmonics);
    if (!ms.length) continue;
    const units = pretty(ms[0].units);
    for (const [s, sensor] of ms[0].sensors.entries()) {
      const mag = [];
      const phase = [];
      for (const sw of ms) {
        const c = hue(sw);
        const name = levelName(sw);
        const mf = sw.model.frequency_hz;
        const look = { color: c, width: 1.5 + 1.5 * under(sw), r: 3 + 1.2 * under(sw) };
        mag.push({ name: `${name} measured`, x: sw.measured.frequency_hz, y: sw.measured.magnitude_per_n[s][hn - 1],
          mode: 'points', legend: false, ...look });
        mag.push({ name: `${name} model`, x: mf, y: sw.model.magnitude_per_n[s][hn - 1], ...look });
        phase.push({ name: `${name} measured`, x: sw.measured.frequency_hz, y: sw.measured.phase_deg[s][hn - 1],
          mode: 'points', legend: false, ...look });
        phase.push({ name: `${name} model`, ...unwrapBreaks(mf, sw.model.phase_deg[s][hn - 1]), legend: false,
          ...look });
      }
      const id = `m${mode}-${slug(sensor)}-h${hn}`;
      const opts = { xlabel: 'frequency (Hz)', height: 280, width: narrow() ? 420 : 640 };
      const none = ms.every((sw) => sw.model.magnitude_per_n[s][hn - 1].every((v) => v === 0));
      const where = `mode ${mode}, ${sensor}, harmonic ${hn}`;
      const magPlot = plotXY({ ...opts, id: `frf-mag-${id}`, ylog: true, legendAt: 'auto',
        title: '|response| / |force|', ylabel: `|H${hn}| (${units})`, series: mag });
      const phPlot = plotXY({ ...opts, id: `frf-phase-${id}`, ydomain: [-180, 180],
        title: 'phase to the force', ylabel: 'phase (°)', series: phase });
      magPlot.setAttribute('aria-label', `${where}: |response| / |force| (${units})`);
      phPlot.setAttribute('aria-label', `${where}: phase to the force (°)`);
      const steps = ms.reduce((n, sw) => n + sw.measured.frequency_hz.length, 0);
      const dense = ms.reduce((n, sw) => n + sw.model.points, 0);
      for (const p of [magPlot, phPlot]) {
        Object.assign(p.dataset, { mode, sensor, harmonic: hn, levels: ms.length, steps, modelPoints: dense,
          model: curves.model });
      }
      figs.push(h('figure', { class: 'frf-curve', dataset: { mode, sensor } }, h('h4', {}, where), magPlot, phPlot,
        none ? h('figcaption', { class: 'caption' }, `The model has no response at harmonic ${hn} here `
          + '(below 1e-9 of harmonic 1: a law with no such harmonic); only the measured steps are drawn.') : null));
    }
  }
  const failed = curves.sweeps.filter((sw) => sw.model.not_converged_hz.length).map((sw) => {
    const f = sw.model.not_converged_hz;
    const at = f.length <= 3 ? f.map((x) => `${fmt(x, 5)} Hz`).join(', ')
      : `${f.length} frequencies between ${fmt(Math.min(...f), 5)} and ${fmt(Math.max(...f), 5)} Hz`;
    return `${levelName(sw)} mode ${sw.mode}: ${at}`;
  });
  const hb = curves.harmonic_balance || {};
  const red = hb.reduction && hb.reduction.method === 'craig_bampton' ? `Craig-Bampton, ${hb.reduction.modes} modes`
    : 'unreduced';
  return h('div', { id: 'frf-curves', dataset: { model: curves.model, levels: levels.length } },
    h('p', { class: 'caption', id: 'frf-curves-about' }, `Points: the measured steps. Lines: ${curves.model} `
      + `solved by harmonic balance (${hb.harmonics} harmonics, ${red}) at ${curves.points} frequencies per `
      + 'sweep, continued in frequency in the sweep\'s direction. Colours: force levels.'),
    failed.length ? h('p', { class: 'note error', id: 'frf-curves-failed' },
      `harmonic balance did not converge (${failed.join('; ')}): left out of the curves`) : null,
    h('div', { class: 'grid2' }, ...figs));
}

// Residual over noise: rows are force levels, columns the steps' frequencies, per harmonic.
export function residualMaps(cells) {
  const harmonics = [...new Set(cells.map((c) => c.harmonic))].sort();
  return h('div', { class: 'grid2', id: 'frf-maps' }, ...harmonics.map((hn) => {
    const cs = cells.filter((c) => c.harmonic === hn).sort((a, b) => a.mode - b.mode || a.level_n - b.level_n);
    const xs = [...new Set(cs.flatMap((c) => c.frequency_hz.map((f) => Number(f.toFixed(2)))))].sort((a, b) => a - b);
    const rows = cs.map((c) => {
      const z = xs.map(() => null);
      c.frequency_hz.forEach((f, i) => { z[xs.indexOf(Number(f.toFixed(2)))] = c.residual_over_noise[i]; });
      return z;
    });
    const title = `harmonic ${hn}: residual over the FRF's noise (1 = noise)`;
    return h('figure', { class: 'frf-map', 'data-harmonic': hn }, h('h3', {}, title), heatMap({
      id: `frf-residual-h${hn}`, title,
      x: xs, y: cs.map((c) => `${c.level_n} N ${c.direction} m${c.mode}`), z: rows,
      xlabel: 'frequency (Hz)', ylabel: 'level', zlabel: 'residual / noise', format: (v) => fmt(v, 2),
    }));
  }));
}
