// Heat map over a grid of categories (amplitude x frequency), with a colour bar.
//
// heatMap({x: [..], y: [..], z: [[z(y0,x0), z(y0,x1)..], ..], xlabel, ylabel, zlabel,
//   id, format}) -> <svg data-plot=id data-cells=N>; null cells stay empty.

import { axis, fmtTick } from './axes.js';
import { s } from './svg.js';

// A perceptually ordered colour map (viridis, sampled at 6 stops).
const STOPS = [[68, 1, 84], [65, 68, 135], [42, 120, 142], [34, 168, 132], [122, 209, 81], [253, 231, 37]];

export function colormap(t) {
  const u = Math.min(Math.max(t, 0), 1) * (STOPS.length - 1);
  const i = Math.min(Math.floor(u), STOPS.length - 2);
  const a = u - i;
  const c = STOPS[i].map((v, k) => Math.round(v + (STOPS[i + 1][k] - v) * a));
  return `rgb(${c[0]},${c[1]},${c[2]})`;
}

const label = (v) => (typeof v === 'number' ? fmtTick(v) : String(v));

// Width of a tick label's character at the plots' 11 px font (generous: digits and dashes).
const CHAR_PX = 6.6;
const SLANT = 40;   // degrees the column labels turn when they would not fit side by side

export function heatMap(o) {
  const W = o.width || 640;
  const xs = o.x || [];
  // column labels side by side when each fits its cell, else slanted (room made below)
  const cell = (W - 170) / Math.max(xs.length, 1);
  const widest = Math.max(0, ...xs.map((v) => label(v).length * CHAR_PX));
  const slant = widest > cell - 6;
  const drop = slant ? Math.ceil(widest * Math.sin(SLANT * Math.PI / 180)) + 4 : 0;
  const H = (o.height || 320) + drop;
  const f = { x0: 80, x1: W - 90, y0: o.title ? 30 : 12, y1: H - 46 - drop };
  const ys = o.y || [];
  const z = o.z || [];
  const flat = z.flat().filter((v) => v != null && Number.isFinite(v));
  const lo = flat.length ? Math.min(...flat) : 0;
  const hi = flat.length ? Math.max(...flat) : 1;
  const root = s('svg', { viewBox: `0 0 ${W} ${H}`, class: 'plot', role: 'img',
    'data-plot': o.id || '', 'aria-label': o.title || o.zlabel || '' });
  root.append(s('rect', { x: f.x0, y: f.y0, width: f.x1 - f.x0, height: f.y1 - f.y0, class: 'plot-bg' }));
  const cw = (f.x1 - f.x0) / Math.max(xs.length, 1);
  const ch = (f.y1 - f.y0) / Math.max(ys.length, 1);
  const fmt = o.format || fmtTick;
  let cells = 0;
  ys.forEach((yv, j) => {
    xs.forEach((xv, i) => {
      const v = z[j] ? z[j][i] : null;
      if (v == null || !Number.isFinite(v)) return;
      const t = hi > lo ? (v - lo) / (hi - lo) : 0.5;
      const x = f.x0 + i * cw;
      const y = f.y1 - (j + 1) * ch;
      root.append(s('rect', { x, y, width: cw, height: ch, fill: colormap(t), class: 'cell' },
        s('title', {}, `${o.xlabel}: ${xv}, ${o.ylabel}: ${yv}, ${o.zlabel}: ${fmt(v)}`)));
      root.append(s('text', { x: x + cw / 2, y: y + ch / 2 + 4, 'text-anchor': 'middle',
        class: t > 0.6 ? 'cell-text dark' : 'cell-text' }, fmt(v)));
      cells += 1;
    });
  });
  xs.forEach((xv, i) => {
    const x = f.x0 + (i + 0.5) * cw;
    root.append(s('text', slant
      ? { x, y: f.y1 + 14, class: 'tick col-label', 'text-anchor': 'end', transform: `rotate(-${SLANT} ${x} ${f.y1 + 14})` }
      : { x, y: f.y1 + 16, class: 'tick col-label', 'text-anchor': 'middle' }, label(xv)));
  });
  ys.forEach((yv, j) => root.append(s('text', { x: f.x0 - 6, y: f.y1 - (j + 0.5) * ch + 4, class: 'tick',
    'text-anchor': 'end' }, label(yv))));
  root.append(s('rect', { x: f.x0, y: f.y0, width: f.x1 - f.x0, height: f.y1 - f.y0, class: 'plot-border' }));
  root.append(s('text', { x: (f.x0 + f.x1) / 2, y: f.y1 + 36 + drop, class: 'axis-label', 'text-anchor': 'middle' }, o.xlabel || ''));
  const cy = (f.y0 + f.y1) / 2;
  root.append(s('text', { x: 14, y: cy, class: 'axis-label', 'text-anchor': 'middle',
    transform: `rotate(-90 14 ${cy})` }, o.ylabel || ''));
  colourBar(root, f, lo, hi, o.zlabel || '');
  root.dataset.cells = String(cells);
  root.dataset.points = String(cells);
  return root;
}

function colourBar(root, f, lo, hi, label) {
  const x = f.x1 + 18;
  const n = 24;
  const h = (f.y1 - f.y0) / n;
  for (let k = 0; k < n; k += 1) {
    root.append(s('rect', { x, y: f.y1 - (k + 1) * h, width: 14, height: h + 0.5, fill: colormap((k + 0.5) / n) }));
  }
  const a = axis(lo, hi, f.y1, f.y0, { n: 4, pad: false });
  for (const t of a.ticks) {
    root.append(s('text', { x: x + 18, y: a.map(t) + 4, class: 'tick' }, fmtTick(t)));
  }
  root.append(s('text', { x: x + 7, y: f.y0 - 4, class: 'tick', 'text-anchor': 'middle' }, label));
}
