// Trends: pick runs (a catalog filter, as on the Runs page, or the runs ticked there) and
// see energy loss, damping and stiffness by both methods of seed 002 with their standard
// uncertainties against excitation, displacement or force amplitude or torque; log axes
// where W is a power law, with the fitted dissipation exponent (seed 001); seed 002
// Tables 2-4 beside the plots; CSV, SVG and PNG exports. Numbers from GET /trends.

import { api } from '../api.js';
import { h, note } from '../dom.js';
import { plotXY } from '../plot/plot.js';
import { color } from '../plot/svg.js';
import { display, fmt } from '../units.js';
import { selectedRuns } from './runs.js';
import { download, plotsSvg, svgToPng, trendsCsv } from './trendexport.js';

const STATUSES = ['', 'complete', 'running', 'failed', 'aborted', 'limit', 'incomplete'];
const FILTERS = ['plan', 'frequency_hz', 'vpp_min', 'vpp_max', 'torque_nm', 'status', 'since', 'until'];
const METHODS = [
  { key: 'loop', prefix: '', name: 'Hysteresis loop (measured)', color: color(0) },
  { key: 'stickslip', prefix: 'stickslip_', name: 'Stick-slip model (Eqs. 6-9)', color: color(1) },
];
const QUANTITIES = [
  { key: 'energy_loss_j', label: 'energy loss', unit: 'J' },
  { key: 'damping_ns_per_m', label: 'joint damping', unit: 'N s/m' },
  { key: 'stiffness_n_per_m', label: 'joint stiffness', unit: 'N/m' },
];

function field(label, input) {
  return h('label', { class: 'field' }, h('span', {}, label), input);
}

function filtersForm(query, plans, onSubmit) {
  const v = (k) => query.get(k) || '';
  const num = (name) => h('input', { name, type: 'number', step: 'any', min: 0, value: v(name) });
  const ticked = selectedRuns();
  const form = h('form', { class: 'filters', id: 'trend-filters' },
    field('Plan', h('select', { name: 'plan' }, h('option', { value: '' }, 'any'),
      plans.map((p) => h('option', { value: p, selected: v('plan') === p }, p)))),
    field('Frequency (Hz)', num('frequency_hz')),
    field('Amplitude from (Vpp)', num('vpp_min')),
    field('to (Vpp)', num('vpp_max')),
    field('Torque (N m)', num('torque_nm')),
    field('Status', h('select', { name: 'status' },
      STATUSES.map((s) => h('option', { value: s, selected: (v('status') || 'complete') === s }, s || 'any')))),
    field('Started from', h('input', { name: 'since', type: 'date', value: v('since') })),
    field('until', h('input', { name: 'until', type: 'date', value: v('until') })),
    h('label', { class: 'field inline' }, h('input', { type: 'checkbox', name: 'ticked', value: '1',
      checked: v('ticked') === '1', disabled: !ticked.length && v('ticked') !== '1' }),
    h('span', {}, `only the ${ticked.length} run${ticked.length === 1 ? '' : 's'} ticked on the Runs page`)),
    h('div', { class: 'buttons' }, h('button', { type: 'submit', id: 'trend-show' }, 'Show trends')));
  form.addEventListener('submit', (ev) => {
    ev.preventDefault();
    const q = new URLSearchParams();
    for (const [k, val] of new FormData(form)) if (val !== '') q.set(k, val);
    if (query.get('x')) q.set('x', query.get('x'));
    onSubmit(q);
  });
  return form;
}

// The REST query of the view's hash query: the runs' filters, or the ticked runs by name.
function restQuery(query) {
  if (query.get('ticked') === '1') return { run: selectedRuns() };
  const q = { status: 'complete', order: 'excitation_vpp', limit: 500 };
  for (const k of FILTERS) if (query.get(k)) q[k] = query.get(k);
  if (q.until && /^\d{4}-\d{2}-\d{2}$/.test(q.until)) q.until += 'T23:59:59';
  return q;
}

// Default x axis: torque for a torque series, else the force amplitude (Segalman's F).
function defaultAxis(body) {
  return body.varying.length === 1 && body.varying[0] === 'torque_nm' ? 'torque_nm' : 'force_amplitude_n';
}

// Vertical bars (+-1 standard uncertainty) as one pen-lifted path.
function bars(xs, ys, us, log) {
  const x = [];
  const y = [];
  xs.forEach((xv, i) => {
    const v = ys[i];
    const u = us[i];
    if (xv == null || v == null || u == null || !Number.isFinite(u)) return;
    const lo = log ? Math.max(v - u, v / 10) : v - u;
    x.push(xv, xv, null);
    y.push(lo, v + u, null);
  });
  return { x, y };
}

function usable(r, m, q) {
  return !(m.key === 'loop' && r.below_resolution && q.key !== 'stiffness_n_per_m');
}

function fitFor(body, method, axis) {
  return (body.fits || []).find((f) => f.method === method && f.against === axis) || null;
}

export function describeFit(f, axisLabel) {
  if (!f) return 'no exponent: W is a power law of an amplitude, not of the torque';
  if (f.error) return f.error;
  const [lo, hi] = f.exponent_ci95;
  return `n = ${fmt(f.exponent, 3)} (95 % CI ${fmt(lo, 3)} to ${fmt(hi, 3)}) for W ~ (${axisLabel})^n, `
    + `${f.n_points} runs at ${f.n_amplitudes} amplitudes, ${f.weighted ? 'weighted' : 'unweighted'} least squares on log axes`;
}

// A run's series: its frequency (3 significant digits) and bolt torque, as the server
// groups them (identify/trends.py series_key); one exponent never spans two series.
const seriesKey = (r) => `${r.frequency_hz == null ? '?' : fmt(r.frequency_hz, 3)} Hz, ${r.torque_nm == null ? '?' : fmt(r.torque_nm, 3)} N m`;

export function seriesOf(rows) {
  return [...new Set(rows.map(seriesKey))];
}

// Refusals grouped by reason: the run names and numbers taken out of each message.
export function groupErrors(errors) {
  const groups = new Map();
  for (const e of errors) {
    const reason = String(e.error).split(e.run).join('RUN').replace(/\(([^()]*)\)/g, '')
      .replace(/-?\d+(\.\d+)?(e[-+]?\d+)?/gi, '#').replace(/\s+/g, ' ').split(':').slice(0, 2).join(':').trim();
    if (!groups.has(reason)) groups.set(reason, { reason, example: e.error, runs: [] });
    groups.get(reason).runs.push(e.run);
  }
  return [...groups.values()].sort((a, b) => b.runs.length - a.runs.length);
}

function errorList(errors) {
  if (!errors.length) return null;
  const groups = groupErrors(errors);
  return h('div', { class: 'note error', id: 'trend-errors' },
    h('p', {}, `${errors.length} run(s) could not be analysed, for ${groups.length} reason(s):`),
    h('ul', {}, groups.map((g) => h('li', { 'data-runs': g.runs.length },
      h('strong', {}, `${g.runs.length} run${g.runs.length === 1 ? '' : 's'}`), `: ${g.example.split(g.runs[0]).join('(run)')} `,
      h('details', {}, h('summary', {}, 'which runs'), h('p', { class: 'caption' }, g.runs.join(', ')))))));
}

function plotOne(body, q, axis) {
  const ax = body.axes[axis];
  const dx = display(ax.unit);
  const dy = display(q.unit);
  const rows = body.runs.filter((r) => r[axis] != null);
  const logx = ax.power_law;
  const logy = logx && q.key === 'energy_loss_j';
  const series = [];
  const groups = seriesOf(rows);
  for (const m of METHODS.filter((mm) => body.methods.includes(mm.key))) {
    const ok = rows.filter((r) => usable(r, m, q) && r[m.prefix + q.key] != null);
    const xs = ok.map((r) => r[axis] * dx.k);
    const ys = ok.map((r) => r[m.prefix + q.key] * dy.k);
    const us = ok.map((r) => (r[`${m.prefix}${q.key}_uncertainty`] ?? NaN) * dy.k);
    if (groups.length > 1) {       // one colour per series (frequency, torque): told apart
      groups.forEach((g, gi) => {
        const mine = ok.filter((r) => seriesKey(r) === g);
        series.push({ name: `${m.key === 'loop' ? 'loop' : 'model'} · ${g}`, x: mine.map((r) => r[axis] * dx.k),
          y: mine.map((r) => r[m.prefix + q.key] * dy.k), mode: 'points', color: color(2 + gi),
          r: m.key === 'loop' ? 5 : 3 });
      });
    } else {
      series.push({ name: m.name, x: xs, y: ys, mode: 'points', color: m.color, r: m.key === 'loop' ? 5 : 3.5 });
    }
    series.push({ name: `${m.name} ±u`, ...bars(xs, ys, us, logy), mode: 'line', color: m.color, legend: false, width: 1.2 });
    const f = logy ? fitFor(body, m.key, axis) : null;
    if (f && !f.error && xs.length) {
      const lo = Math.min(...ok.map((r) => r[axis]));
      const hi = Math.max(...ok.map((r) => r[axis]));
      const fx = Array.from({ length: 40 }, (_, i) => lo * (hi / lo) ** (i / 39));
      series.push({ name: `${m.key === 'loop' ? 'loop' : 'model'} fit: n = ${fmt(f.exponent, 3)}`,
        x: fx.map((v) => v * dx.k), y: fx.map((v) => f.coefficient * v ** f.exponent * dy.k),
        mode: 'line', color: m.color, dash: '6 4' });
    }
  }
  const svg = plotXY({ id: `trend-${q.key}`, series, xlog: logx, ylog: logy, legendAt: 'tl',
    ydomain: logy ? null : headroom(series),
    xlabel: `${ax.label} (${dx.unit})`, ylabel: `${q.label} (${dy.unit})`, height: 300,
    title: `${q.label[0].toUpperCase()}${q.label.slice(1)} against ${ax.label.toLowerCase()}${logx ? ' (log axes)' : ''}`,
    empty: 'no run with this value' });
  svg.dataset.runs = String(rows.length);
  return svg;
}

// A linear y range with the top third left free for the legend (it never covers a point).
function headroom(series) {
  const ys = series.flatMap((sr) => sr.y).filter((v) => v != null && Number.isFinite(v));
  if (!ys.length) return null;
  const lo = Math.min(...ys);
  const hi = Math.max(...ys);
  const span = hi > lo ? hi - lo : Math.abs(hi) * 0.05 || 1;
  return [lo - 0.08 * span, hi + 0.55 * span];
}

const diffText = (v) => (v == null || !Number.isFinite(v) ? '–' : (Math.round(v * 10) / 10 + 0).toFixed(1));

function pm(v, u, k) {
  if (v == null) return '–';
  return u != null && Number.isFinite(u) ? `${fmt(v * k)} ± ${fmt(u * k, 2)}` : fmt(v * k);
}

// Seed 002 Tables 2-4: condition(s), property, both methods with +-u, difference in %.
function trendTable(body) {
  const t = body.table;
  const conds = t.conditions;
  const head = [...(conds.length ? conds.map((c) => `${body.axes[c].label} (${body.axes[c].unit})`) : ['Run']),
    'Joint property', 'Joint identification algorithm (stick-slip model)', 'Hysteresis loop (measured)', 'Diff. (%)'];
  const rows = [];
  t.rows.forEach((r, i) => {
    const d = display(r.unit);
    const first = i === 0 || t.rows[i - 1].run !== r.run;
    const n = t.rows.filter((x) => x.run === r.run).length;
    const tds = [];
    if (first) {
      (conds.length ? conds.map((c) => fmt(r.condition[c])) : [r.run]).forEach((c) => tds.push(
        h('td', { rowspan: n, class: 'num', title: r.run }, c)));
    }
    tds.push(h('td', {}, `${r.label} (${d.unit})`),
      h('td', { class: 'num' }, pm(r.stickslip, r.stickslip_uncertainty, d.k)),
      h('td', { class: 'num' }, r.below_resolution ? 'below resolution' : pm(r.loop, r.loop_uncertainty, d.k)),
      h('td', { class: 'num' }, diffText(r.diff_pct)));
    rows.push(h('tr', { 'data-run': r.run, 'data-property': r.property }, tds));
  });
  return h('div', { class: 'scroll' }, h('table', { id: 'trends-table', class: 'table2' },
    h('thead', {}, h('tr', {}, head.map((x) => h('th', {}, x)))), h('tbody', {}, rows)),
  h('p', { class: 'caption' }, 'Values ± one standard uncertainty of the mean over the steady cycles. ', t.note));
}

function axisPicker(body, axis, onPick) {
  const sel = h('select', { id: 'trend-axis', name: 'x' }, Object.entries(body.axes).map(([k, a]) =>
    h('option', { value: k, selected: k === axis }, `${a.label}${a.power_law ? ' (log)' : ''}`)));
  sel.addEventListener('change', () => onPick(sel.value));
  return field('Against', sel);
}

function results(el, body, query) {
  let axis = query.get('x') && body.axes[query.get('x')] ? query.get('x') : defaultAxis(body);
  const plots = h('div', { id: 'trend-plots' });
  const exponent = h('p', { id: 'trend-exponent' });
  const draw = () => {
    plots.replaceChildren(...QUANTITIES.map((q) => plotOne(body, q, axis)));
    const ax = body.axes[axis];
    const loop = ax.power_law ? fitFor(body, 'loop', axis) : null;
    const model = ax.power_law ? fitFor(body, 'stickslip', axis) : null;
    exponent.replaceChildren(h('strong', {}, 'Dissipation exponent: '), describeFit(loop, ax.label.toLowerCase()),
      model && !model.error ? ` · stick-slip model: n = ${fmt(model.exponent, 3)}` : '',
      (body.series_fits || []).length ? h('ul', { id: 'trend-series' }, body.series_fits.map((f) => h('li',
        { 'data-frequency': f.frequency_hz, 'data-torque': f.torque_nm, 'data-exponent': f.error ? '' : f.exponent },
        `${fmt(f.frequency_hz, 3)} Hz, ${fmt(f.torque_nm, 3)} N m: `, describeFit(f, ax.label.toLowerCase())))) : null,
      h('span', { class: 'caption' }, body.fit.reference));
    exponent.dataset.exponent = loop && !loop.error ? String(loop.exponent) : '';
  };
  const exports = h('div', { class: 'buttons' },
    h('button', { id: 'export-csv', class: 'secondary', onclick: () => download(
      new Blob([trendsCsv(body)], { type: 'text/csv' }), 'labjoint-trends.csv') }, 'CSV'),
    h('button', { id: 'export-svg', class: 'secondary', onclick: () => download(
      new Blob([plotsSvg([...plots.querySelectorAll('svg.plot')])], { type: 'image/svg+xml' }),
      'labjoint-trends.svg') }, 'SVG'),
    h('button', { id: 'export-png', class: 'secondary', onclick: async () => {
      download(await svgToPng(plotsSvg([...plots.querySelectorAll('svg.plot')])), 'labjoint-trends.png');
    } }, 'PNG'));
  const pick = axisPicker(body, axis, (k) => { axis = k; draw(); });
  const problems = errorList(body.errors);
  el.append(h('div', { class: 'grid2' },
    h('section', { class: 'card' }, h('h2', {}, 'Against amplitude and torque'),
      h('div', { class: 'toolbar' }, pick, h('span', { class: 'count' }, 'Export:'), exports),
      exponent, plots,
      h('p', { class: 'caption' }, 'Bars: ± one standard uncertainty. Log axes where W is a power law of the amplitude '
        + '(seed 001); a loop W below its resolution is left out of the plots and the fit.')),
    h('section', { class: 'card' }, h('h2', {}, 'Seed 002 Tables 2-4'), trendTable(body),
      body.notes.map((n) => h('p', { class: 'caption' }, n)), problems)));
  draw();
}

export async function show(el, routeInfo) {
  const query = routeInfo.query;
  const msg = h('p', { hidden: true, id: 'trend-msg' });
  let plans = [];
  try {
    plans = (await api('/plan-types')).map((p) => p.name);
  } catch {
    plans = [];
  }
  el.append(h('section', { class: 'card' }, h('h2', {}, 'Trends'),
    filtersForm(query, plans, (q) => { window.location.hash = `#/trends?${q}`; }), msg));
  if (![...query.keys()].length) {
    note(msg, 'Pick runs: a filter (an amplitude sweep: plan amplitude_sweep; a torque series: '
      + 'plan torque_series) or the runs ticked on the Runs page, then Show trends.');
    return null;
  }
  note(msg, 'Analysing the runs (both methods)…', 'busy');
  try {
    const body = await api('/trends', { query: restQuery(query) });
    note(msg, body.runs.length ? `${body.runs.length} run(s): ${body.methods.join(' and ')}`
      + `${body.selection.truncated ? ' (more match: narrow the filter)' : ''}` : 'No run matches these filters.');
    if (body.runs.length) results(el, body, query);
  } catch (err) {
    note(msg, `Could not get the trends: ${err.message}`, 'error');
  }
  return null;
}
