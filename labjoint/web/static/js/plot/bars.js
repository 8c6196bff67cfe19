// Bar chart over named categories (the model ladder: NRMSE per step), with
// horizontal reference lines (the noise floor).
//
// barChart({labels, values, colors, ylabel, ylog, hlines, id, title}) -> <svg
//   data-plot=id data-values="v1,v2,...">

import { axis, drawFrame } from './axes.js';
import { color, s } from './svg.js';

export function barChart(o) {
  const W = o.width || 640;
  const H = o.height || 300;
  const labels = o.labels || [];
  const values = o.values || [];
  const f = { x0: 70, x1: W - 14, y0: o.title ? 30 : 12, y1: H - 64 };
  const finite = values.filter((v) => v != null && Number.isFinite(v) && (!o.ylog || v > 0));
  const refs = (o.hlines || []).map((l) => l.y).filter((v) => v != null && Number.isFinite(v));
  const all = finite.concat(refs);
  const hi = (all.length ? Math.max(...all) : 1) * (o.ylog ? 1.6 : 1.12);   // room for the labels
  const lo = o.ylog ? (all.length ? Math.min(...all) : 0.1) : 0;
  const ya = axis(lo, hi, f.y1, f.y0, { log: o.ylog, n: 5 });
  const root = s('svg', { viewBox: `0 0 ${W} ${H}`, class: 'plot', role: 'img',
    'data-plot': o.id || '', 'aria-label': o.title || o.ylabel || '' });
  const n = Math.max(labels.length, 1);
  const step = (f.x1 - f.x0) / n;
  const centres = labels.map((_, i) => f.x0 + step * (i + 0.5));
  drawFrame(root, f, null, ya, { ...o, xlabel: '' });
  const base = o.ylog ? f.y1 : ya.map(0);
  values.forEach((v, i) => {
    if (v == null || !Number.isFinite(v) || (o.ylog && v <= 0)) return;
    const y = ya.map(v);
    const w = Math.min(step * 0.6, 80);
    root.append(s('rect', { x: centres[i] - w / 2, y: Math.min(y, base), width: w,
      height: Math.abs(base - y), fill: (o.colors && o.colors[i]) || color(0), class: 'bar' }));
    root.append(s('text', { x: centres[i], y: y - 5, class: 'bar-value', 'text-anchor': 'middle' },
      (o.format || String)(v)));
  });
  labels.forEach((label, i) => {
    const lines = String(label).split('\n');
    lines.forEach((ln, j) => root.append(s('text', { x: centres[i], y: f.y1 + 16 + 14 * j,
      class: 'tick', 'text-anchor': 'middle' }, ln)));
  });
  for (const l of o.hlines || []) {
    if (l.y == null || !Number.isFinite(l.y) || (o.ylog && l.y <= 0)) continue;
    const y = ya.map(l.y);
    root.append(s('line', { x1: f.x0, x2: f.x1, y1: y, y2: y, class: 'hline', stroke: l.color || '#555' }));
    root.append(s('text', { x: f.x0 + 4, y: y - 4, class: 'hline-label' }, l.label || ''));
  }
  root.dataset.values = values.map((v) => (v == null ? '' : String(v))).join(',');
  root.dataset.points = String(finite.length);
  return root;
}
