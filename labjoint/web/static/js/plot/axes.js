// Scales, ticks and the drawn frame (grid, tick labels, axis titles) of a plot.

import { s } from './svg.js';

function niceStep(span, n) {
  const raw = span / Math.max(n, 1);
  const p = 10 ** Math.floor(Math.log10(raw));
  const m = raw / p;
  return (m < 1.5 ? 1 : m < 3 ? 2 : m < 7 ? 5 : 10) * p;
}

export function fmtTick(v) {
  if (v === 0) return '0';
  const a = Math.abs(v);
  if (a >= 1e5 || a < 1e-3) {
    const e = Math.floor(Math.log10(a));
    const m = v / 10 ** e;
    return Math.abs(Math.abs(m) - 1) < 1e-9 ? `${m < 0 ? '-' : ''}1e${e}` : `${parseFloat(m.toPrecision(2))}e${e}`;
  }
  return String(parseFloat(v.toPrecision(6)));
}

// An axis over data [lo, hi]: {domain, ticks, map(v) -> pixel, log}.
export function axis(lo, hi, r0, r1, { log = false, n = 6, pad = true } = {}) {
  if (log) return logAxis(lo, hi, r0, r1);
  if (!(hi > lo)) {
    const d = lo === 0 || !Number.isFinite(lo) ? 1 : Math.abs(lo) * 0.1;
    lo = (Number.isFinite(lo) ? lo : 0) - d;
    hi = (Number.isFinite(hi) ? hi : 0) + d;
  }
  const step = niceStep(hi - lo, n);
  if (pad) {
    lo = Math.floor(lo / step + 1e-9) * step;
    hi = Math.ceil(hi / step - 1e-9) * step;
  }
  const ticks = [];
  for (let v = Math.ceil(lo / step - 1e-9) * step; v <= hi + step * 1e-9; v += step) {
    ticks.push(Math.abs(v) < step * 1e-9 ? 0 : v);
  }
  const k = (r1 - r0) / (hi - lo);
  return { domain: [lo, hi], ticks, log: false, map: (v) => r0 + (v - lo) * k };
}

function logAxis(lo, hi, r0, r1) {
  if (!(lo > 0)) lo = hi > 0 ? hi / 10 : 1;
  if (!(hi > lo)) { lo /= 2; hi = lo * 4; }
  let l0 = Math.log10(lo);
  let l1 = Math.log10(hi);
  const span = l1 - l0;
  if (span > 1.5) { l0 = Math.floor(l0); l1 = Math.ceil(l1); } else { l0 -= 0.1; l1 += 0.1; }
  let ticks = [];
  const mult = l1 - l0 > 4 ? [1] : l1 - l0 > 1.6 ? [1, 2, 5] : [1, 1.5, 2, 3, 5, 7];
  const every = Math.max(1, Math.ceil((l1 - l0) / 7));   // at most ~7 decades labelled
  for (let e = Math.floor(l0); e <= Math.ceil(l1); e += 1) {
    if (e % every) continue;
    for (const m of mult) {
      const v = m * 10 ** e;
      const lv = Math.log10(v);
      if (lv >= l0 - 1e-9 && lv <= l1 + 1e-9) ticks.push(v);
    }
  }
  if (ticks.length < 3) {   // less than a decade: evenly stepped values, placed on the log scale
    const a = 10 ** l0;
    const b = 10 ** l1;
    const st = niceStep(b - a, 4);
    ticks = [];
    for (let v = Math.ceil(a / st) * st; v <= b; v += st) ticks.push(parseFloat(v.toPrecision(12)));
  }
  const k = (r1 - r0) / (l1 - l0);
  return { domain: [10 ** l0, 10 ** l1], ticks, log: true, map: (v) => r0 + (Math.log10(v) - l0) * k };
}

// Grid lines, tick labels and axis titles of frame f = {x0, x1, y0, y1} (y0 at the top).
export function drawFrame(root, f, xa, ya, { xlabel = '', ylabel = '', title = '', xTickLabels = null } = {}) {
  const g = s('g', { class: 'frame' });
  g.append(s('rect', { x: f.x0, y: f.y0, width: f.x1 - f.x0, height: f.y1 - f.y0, class: 'plot-bg' }));
  if (xa) {
    for (const t of xa.ticks) {
      const x = xa.map(t);
      g.append(s('line', { x1: x, x2: x, y1: f.y0, y2: f.y1, class: 'grid' }));
      g.append(s('text', { x, y: f.y1 + 16, class: 'tick', 'text-anchor': 'middle' }, fmtTick(t)));
    }
  }
  if (xTickLabels) {
    for (const [x, label] of xTickLabels) {
      g.append(s('text', { x, y: f.y1 + 16, class: 'tick', 'text-anchor': 'middle' }, label));
    }
  }
  if (ya) {
    for (const t of ya.ticks) {
      const y = ya.map(t);
      g.append(s('line', { x1: f.x0, x2: f.x1, y1: y, y2: y, class: 'grid' }));
      g.append(s('text', { x: f.x0 - 6, y: y + 4, class: 'tick', 'text-anchor': 'end' }, fmtTick(t)));
    }
  }
  g.append(s('rect', { x: f.x0, y: f.y0, width: f.x1 - f.x0, height: f.y1 - f.y0, class: 'plot-border' }));
  if (xlabel) {
    g.append(s('text', { x: (f.x0 + f.x1) / 2, y: f.y1 + 36, class: 'axis-label', 'text-anchor': 'middle' }, xlabel));
  }
  if (ylabel) {
    const cy = (f.y0 + f.y1) / 2;
    g.append(s('text', { x: 14, y: cy, class: 'axis-label', 'text-anchor': 'middle',
      transform: `rotate(-90 14 ${cy})` }, ylabel));
  }
  if (title) g.append(s('text', { x: f.x0, y: f.y0 - 10, class: 'plot-title' }, title));
  root.append(g);
  return g;
}
