// Line and scatter plots on linear or log axes, with horizontal reference lines.
//
// plotXY({series: [{name, x, y, color, mode: 'line'|'points'|'both', dash, opacity,
//   legend, err}], xlabel, ylabel, title, xlog, ylog, hlines: [{y, label, color}], id,
//   width, height}) -> <svg data-plot=id data-points=N data-series=M>
// A points series with `err` (one standard uncertainty per point) gets error bars y ± err
// (on a log axis a bar reaching zero or below stops at y / 10).

import { axis, drawFrame } from './axes.js';
import { color, nextId, s } from './svg.js';

const ok = (v, log) => v != null && Number.isFinite(v) && (!log || v > 0);

function extent(series, key, log, extra = []) {
  let lo = Infinity;
  let hi = -Infinity;
  for (const sr of series) {
    for (const v of sr[key]) {
      if (ok(v, log)) { lo = Math.min(lo, v); hi = Math.max(hi, v); }
    }
  }
  for (const v of extra) if (ok(v, log)) { lo = Math.min(lo, v); hi = Math.max(hi, v); }
  return lo <= hi ? [lo, hi] : [log ? 1 : 0, log ? 10 : 1];
}

function pathOf(sr, xa, ya, xlog, ylog) {
  let d = '';
  let pen = false;
  let n = 0;
  for (let i = 0; i < sr.x.length; i += 1) {
    const x = sr.x[i];
    const y = sr.y[i];
    if (!ok(x, xlog) || !ok(y, ylog)) { pen = false; continue; }
    d += `${pen ? 'L' : 'M'}${xa.map(x).toFixed(1)} ${ya.map(y).toFixed(1)}`;
    pen = true;
    n += 1;
  }
  return [d, n];
}

// Screen positions of a series' points that fall inside the frame (what the eye sees).
function inside(sr, xa, ya, f, xlog, ylog) {
  const pts = [];
  for (let i = 0; i < sr.x.length; i += 1) {
    if (!ok(sr.x[i], xlog) || !ok(sr.y[i], ylog)) continue;
    const px = xa.map(sr.x[i]);
    const py = ya.map(sr.y[i]);
    if (px >= f.x0 - 0.5 && px <= f.x1 + 0.5 && py >= f.y0 - 0.5 && py <= f.y1 + 0.5) pts.push([px, py]);
  }
  return pts;
}

export function plotXY(o) {
  const W = o.width || 640;
  const H = o.height || 320;
  const f = { x0: 70, x1: W - 14, y0: o.title ? 30 : 12, y1: H - 46 };
  const series = (o.series || []).map((sr, i) => ({
    mode: 'line', color: color(i), legend: true, ...sr, x: sr.x || [], y: sr.y || [],
  }));
  const hlines = o.hlines || [];
  const [xlo, xhi] = o.xdomain || extent(series, 'x', o.xlog);
  const [ylo, yhi] = o.ydomain || extent(series, 'y', o.ylog, hlines.map((l) => l.y));
  const xa = axis(xlo, xhi, f.x0, f.x1, { log: o.xlog, pad: !o.xdomain });
  if (o.xticks) xa.ticks = o.xticks;
  const ya = axis(ylo, yhi, f.y1, f.y0, { log: o.ylog, n: 5 });
  const root = s('svg', { viewBox: `0 0 ${W} ${H}`, class: 'plot', role: 'img',
    'data-plot': o.id || '', 'aria-label': o.title || o.ylabel || '' });
  drawFrame(root, f, xa, ya, o);
  const clip = nextId('clip');
  root.append(s('clipPath', { id: clip },
    s('rect', { x: f.x0, y: f.y0, width: f.x1 - f.x0, height: f.y1 - f.y0 })));
  const body = s('g', { 'clip-path': `url(#${clip})` });
  root.append(body);
  let total = 0;
  const screen = [];   // every point drawn inside the frame, to keep the legend off them
  for (const sr of series) {
    const attrs = { stroke: sr.color, 'stroke-opacity': sr.opacity ?? 1 };
    const seen = inside(sr, xa, ya, f, o.xlog, o.ylog);
    sr.drawn = seen.length;
    for (const p of seen) screen.push(p);
    if (sr.mode === 'line' || sr.mode === 'both') {
      const [d, n] = pathOf(sr, xa, ya, o.xlog, o.ylog);
      total += n;
      body.append(s('path', { ...attrs, d, class: 'series', 'stroke-width': sr.width || 1.5,
        'stroke-dasharray': sr.dash || null, 'data-name': sr.name || '', 'data-drawn': sr.drawn }));
    }
    if (sr.mode === 'points' || sr.mode === 'both') {
      const g = s('g', { fill: sr.color, 'fill-opacity': sr.opacity ?? 1, 'data-name': sr.name || '',
        'data-drawn': sr.drawn });
      let n = 0;
      let bars = 0;
      for (let i = 0; i < sr.x.length; i += 1) {
        if (!ok(sr.x[i], o.xlog) || !ok(sr.y[i], o.ylog)) continue;
        const e = sr.err ? sr.err[i] : null;
        if (e != null && Number.isFinite(e) && e > 0) {
          const lo = sr.y[i] - e;
          const x = xa.map(sr.x[i]).toFixed(1);
          g.append(s('line', { x1: x, x2: x, y1: ya.map(o.ylog && lo <= 0 ? sr.y[i] / 10 : lo).toFixed(1),
            y2: ya.map(sr.y[i] + e).toFixed(1), stroke: sr.color, 'stroke-width': 1, class: 'errbar' }));
          bars += 1;
        }
        g.append(s('circle', { cx: xa.map(sr.x[i]).toFixed(1), cy: ya.map(sr.y[i]).toFixed(1), r: sr.r || 3.5 }));
        n += 1;
      }
      if (sr.mode === 'points') total += n;
      if (bars) g.setAttribute('data-bars', String(bars));
      body.append(g);
    }
  }
  for (const l of hlines) {
    if (!ok(l.y, o.ylog)) continue;
    const y = ya.map(l.y);
    body.append(s('line', { x1: f.x0, x2: f.x1, y1: y, y2: y, class: 'hline', stroke: l.color || '#555' }));
    body.append(s('text', { x: f.x1 - 4, y: y - 4, class: 'hline-label', 'text-anchor': 'end' }, l.label || ''));
  }
  // the legend names only what is drawn (a model at zero has no place on a log axis)
  legend(root, series.filter((sr) => sr.legend && sr.name && sr.drawn > 0), f, o.legendAt, screen);
  if (!total) {
    root.append(s('text', { x: (f.x0 + f.x1) / 2, y: (f.y0 + f.y1) / 2, class: 'empty',
      'text-anchor': 'middle' }, o.empty || 'no data'));
  }
  root.dataset.points = String(total);
  root.dataset.series = String(series.length);
  const [dx0, dx1] = extent(series, 'x', o.xlog);
  const [dy0, dy1] = extent(series, 'y', o.ylog);
  if (total) Object.assign(root.dataset, { xmin: dx0, xmax: dx1, ymin: dy0, ymax: dy1 });
  return root;
}

// Where a w x hgt box sits in corner `at` of frame f.
function corner(at, f, w, hgt) {
  return [at[1] === 'l' ? f.x0 + 6 : f.x1 - w - 6, at[0] === 'b' ? f.y1 - hgt - 6 : f.y0 + 6];
}

// The corner (tr, tl, br, bl) whose box covers the fewest of the drawn points `pts`.
export function freeCorner(f, w, hgt, pts, prefer = ['tr', 'tl', 'br', 'bl']) {
  const pad = 3;
  let best = prefer[0];
  let fewest = Infinity;
  for (const at of prefer) {
    const [x0, y0] = corner(at, f, w, hgt);
    let n = 0;
    for (const [x, y] of pts) {
      if (x >= x0 - pad && x <= x0 + w + pad && y >= y0 - pad && y <= y0 + hgt + pad) n += 1;
    }
    if (n < fewest) { fewest = n; best = at; }
  }
  return best;
}

// Legend box in a corner of the frame: at = 'auto' (default: the corner over the fewest
// of the drawn points `pts`), 'tr', 'tl', 'br' or 'bl'.
export function legend(root, items, f, at = 'auto', pts = []) {
  if (!items.length) return;
  const g = s('g', { class: 'legend' });
  const w = Math.min(260, 26 + 6.5 * Math.max(...items.map((i) => i.name.length)));
  const hgt = 8 + 16 * items.length;
  const where = !at || at === 'auto' ? freeCorner(f, w, hgt, pts) : at;
  const [x0, y0] = corner(where, f, w, hgt);
  g.dataset.corner = where;
  g.append(s('rect', { x: x0, y: y0, width: w, height: hgt, class: 'legend-bg' }));
  items.forEach((it, i) => {
    const y = y0 + 12 + 16 * i;
    if (it.mode === 'points') {
      g.append(s('circle', { cx: x0 + 13, cy: y - 4, r: 3.5, fill: it.color }));
    } else {
      g.append(s('line', { x1: x0 + 6, x2: x0 + 20, y1: y - 4, y2: y - 4, stroke: it.color,
        'stroke-width': 2.5, 'stroke-dasharray': it.dash || null }));
    }
    g.append(s('text', { x: x0 + 26, y, class: 'legend-text' }, it.name));
  });
  root.append(g);
}
