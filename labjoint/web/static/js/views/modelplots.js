// Model-comparison results drawn: fit summary and parameters, measured and model loops
// per run, residual maps (amplitude x frequency heat map, residual against phase,
// quadrants), dissipation and stiffness against amplitude (log axes), the candidates
// and the ladder.

import { h, table } from '../dom.js';
import { barChart } from '../plot/bars.js';
import { heatMap } from '../plot/heatmap.js';
import { plotXY } from '../plot/plot.js';
import { color } from '../plot/svg.js';
import { fmt, nrmse, paramDisplay, pct } from '../units.js';
import { onPage } from '../words.js';

// NRMSE is shown in % everywhere on the page (the server's verdicts say % too).
const P = (v) => (v == null || !Number.isFinite(v) ? null : 100 * v);
const P1 = (xs) => (xs || []).map(P);
const fmtP = (d) => (v) => `${fmt(v, d)} %`;

const scale = (xs, k) => (xs || []).map((v) => (v == null ? null : v * k));

// The residual maps of a diagnosis: the object holding by_run/by_phase/by_quadrant,
// at the top of the result or one level down.
export function findMaps(result) {
  if (!result || typeof result !== 'object') return null;
  const isMaps = (v) => v.by_run || v.by_phase || (Array.isArray(v.cells) && v.cells.length);
  if (isMaps(result)) return result;
  for (const v of Object.values(result)) {
    if (v && typeof v === 'object' && !Array.isArray(v) && isMaps(v)) return v;
  }
  return null;
}

export function summary(fit, diag) {
  const nr = fit?.nrmse ?? diag?.nrmse;
  const floor = fit?.noise_floor ?? diag?.noise_floor;
  const verdict = diag ? h('span', { class: `verdict ${diag.adequate ? 'good' : 'bad'}`, id: 'verdict' },
    diag.adequate ? 'adequate' : 'not adequate') : null;
  return h('div', {}, h('p', {}, h('strong', {}, fit?.model || diag?.model || ''), ' · NRMSE ',
    h('strong', { id: 'nrmse' }, nrmse(nr)), ' · noise floor ', nrmse(floor),
    floor ? ` (×${fmt(nr / floor, 3)})` : '', ' · ', verdict),
  diag?.verdict ? h('p', { class: 'caption', id: 'verdict-text' }, onPage(diag.verdict)) : null,
  diag?.fit_runs ? h('p', { class: 'caption' }, `Fitted on ${diag.fit_runs.length} run(s), validated on `
    + `${(diag.validation_runs || []).length}${diag.split ? ` (${onPage(diag.split)})` : ''}.`) : null,
  flagList(diag?.measurement_flags || fit?.measurement_flags));
}

// The data's likely mistakes and limits the pipeline found (negative energy loss, complex
// measured modes): shown with the fit they qualify, as the CLI's "warning:" lines.
function flagList(flags) {
  if (!flags || !flags.length) return null;
  return h('ul', { class: 'note error', id: 'measurement-flags' }, ...flags.map((f) => h('li',
    { dataset: { flag: f.flag } }, `${f.run ? `${f.run}: ` : ''}${onPage(f.message)}`)));
}

// Below this relative standard error a fitted parameter's covariance is numerically
// singular (the data do not see it), not a precise measurement: "± 1.4e-12" on a mass.
export const SINGULAR_REL = 1e-6;

// How well the runs determine a parameter: 'ok', 'poor' (std. error above the value) or
// 'undetermined' (no std. error, or a singular covariance), with the words shown.
export function determination(p) {
  const v = Math.abs(p.value);
  if (p.stderr == null || !Number.isFinite(p.stderr)) return ['undetermined', 'not determined (no standard error: the covariance is singular)'];
  if (v > 0 && p.stderr < SINGULAR_REL * v) return ['undetermined', 'not determined (the covariance is singular: a standard error this small is not an uncertainty)'];
  if (p.stderr > v) return ['poor', 'not determined by these runs: the standard error exceeds the value'];
  return ['ok', ''];
}

export function parameters(fit) {
  const rows = Object.entries(fit.parameters || {}).map(([name, p]) => {
    const d = paramDisplay(p.unit);
    const [state, why] = determination(p);
    const se = state === 'undetermined' ? 'NaN' : fmt(p.stderr * d.k, 2);
    return h('tr', { 'data-param': name, 'data-determination': state, class: state === 'ok' ? '' : 'flagged' },
      h('td', {}, name), h('td', {}, fmt(p.value * d.k)), h('td', {}, se), h('td', {}, d.unit),
      h('td', { class: state === 'ok' ? '' : 'verdict bad' }, why));
  });
  return table(['Parameter', 'Value', 'Std. error', 'Unit', ''], rows, { class: 'params', id: 'params' });
}

export function perRun(fit) {
  const rows = (fit.runs || []).map((r) => [r.run, nrmse(r.nrmse), pct(r.energy_loss_error_pct),
    pct(r.stiffness_error_pct)]);
  return table(['Run', 'NRMSE', 'Energy-loss error', 'Stiffness error'], rows, { class: 'per-run' });
}

// One measured-and-model overlay along time.
function timeOverlay(id, title, ylabel, x, measured, model) {
  return h('figure', { class: 'small' }, plotXY({
    id, title, height: 300, xlabel: 'time (s)', ylabel,
    series: [
      { name: 'measured', x, y: measured, color: color(0), width: 2 },
      { name: 'model', x, y: model, color: color(1), dash: '6 3', width: 1.5 },
    ],
  }));
}

// Measured and model force along a record (any excitation): every k-th judged sample.
function traces(byRun, names) {
  return h('div', { class: 'grid2' }, names.map((name, i) => {
    const lp = byRun[name];
    return timeOverlay(`overlay-${i}`, name, 'joint force (N)', lp.time_s, lp.force_measured_n, lp.force_model_n);
  }));
}

// Measured and model response of every compared sensor along each record (kind "modal"):
// one plot per record and sensor, in the response's own unit.
function responseTraces(byRun, names) {
  const figs = [];
  for (const name of names) {
    const lp = byRun[name];
    for (const [ch, r] of Object.entries(lp.responses || {})) {
      figs.push(timeOverlay(`overlay-${figs.length}`, `${name} · ${ch}`, `${r.quantity} (${r.unit})`,
        lp.time_s, r.measured, r.model));
    }
  }
  return h('div', { class: 'grid2' }, figs);
}

// Measured and model loop of each run (mean steady cycle), when the result carries them;
// for records (kind "record"), the force along the record; for measured modes (kind
// "modal"), every compared response along the record.
export function loops(fit) {
  const byRun = fit.loops || {};
  const names = (fit.runs || []).map((r) => r.run).filter((n) => byRun[n]);
  if (!names.length) {
    return h('p', { class: 'note' }, 'The result carries no loop arrays (loops) to overlay.');
  }
  if (fit.kind === 'record') return traces(byRun, names);
  if (fit.kind === 'modal') return responseTraces(byRun, names);
  return h('div', { class: 'grid3' }, names.map((name, i) => {
    const lp = byRun[name];
    const close = (a) => (a && a.length ? [...a, a[0]] : []);   // one whole cycle: close it
    const x = close(scale(lp.displacement_m, 1e6));
    return h('figure', { class: 'small' }, plotXY({
      id: `overlay-${i}`, title: name, height: 300, xlabel: 'relative displacement (µm)', ylabel: 'joint force (N)',
      series: [
        { name: 'measured', x, y: close(lp.force_measured_n), color: color(0), width: 2.5 },
        { name: 'model', x, y: close(lp.force_model_n), color: color(1), dash: '6 3', width: 2 },
      ],
    }));
  }));
}

// Catalog records of the runs the page has listed (name -> record): the grid's columns
// name each run's bolt torque from them.
export const knownRuns = new Map();

export function rememberRuns(items) {
  for (const r of items || []) knownRuns.set(r.name, r);
}

// The torque(s) of a grid column's runs, as a label part ('' when unknown).
function torqueOf(names) {
  const t = [...new Set(names.filter(Boolean).map((n) => knownRuns.get(n)?.torque_nm).filter((v) => v != null))];
  return t.length ? `${t.map((v) => fmt(v, 3)).join('/')} N m` : '';
}

// Heat map of NRMSE on the amplitude x frequency grid: one row per frequency class,
// amplitude ranks across (each cell labelled by its run's amplitude, and by its bolt
// torque when the runs hold several: three torques at one amplitude are told apart).
function gridMap(g) {
  const freqs = g.frequencies_hz || [];
  const cols = Math.max(0, ...(g.nrmse || []).map((r) => r.length));
  // columns are amplitude ranks within each frequency: label a column by its amplitude
  // when the rows agree (within 10 %), else by the range it spans
  const labels = [];
  for (let j = 0; j < cols; j += 1) {
    const col = (g.amplitude_m || []).map((r) => r[j]).filter((v) => v != null).map((v) => v * 1e6);
    const lo = Math.min(...col);
    const hi = Math.max(...col);
    labels.push(!col.length ? '–' : hi - lo <= 0.1 * hi ? fmt((lo + hi) / 2, 3) : `${fmt(lo, 2)}–${fmt(hi, 2)}`);
  }
  const names = g.runs || [];
  const torques = new Set(names.flat().filter(Boolean).map((n) => knownRuns.get(n)?.torque_nm).filter((v) => v != null));
  if (torques.size > 1 || new Set(labels).size < labels.length) {
    for (let j = 0; j < cols; j += 1) {
      const t = torqueOf(names.map((r) => r[j]));
      if (t) labels[j] = `${labels[j]} µm · ${t}`;
    }
  }
  return heatMap({ id: 'residual-grid', x: labels,
    y: freqs.map((f) => parseFloat(f.toPrecision(4))), z: (g.nrmse || []).map(P1), xlabel: 'displacement amplitude (µm)',
    ylabel: 'frequency (Hz)', zlabel: 'NRMSE (%)', height: 60 + 56 * Math.max(freqs.length, 2),
    format: (v) => fmt(v, 2) });
}

// The maps of records (any excitation): NRMSE per record, per frequency band and per
// class of DFT line (periodic excitation).
function recordMaps(maps) {
  const parts = [];
  const r = maps.by_run || {};
  parts.push(h('figure', {}, h('h3', {}, 'By run'), barChart({
    id: 'residual-runs', height: 260, labels: (r.runs || []).map((n, i) => `${n}\n${(r.excitation || [])[i] || ''}`),
    values: P1(r.nrmse), ylabel: 'NRMSE (%)', format: fmtP(2),
    hlines: (r.noise_floor || []).length ? [{ y: P(Math.max(...r.noise_floor.filter((v) => v != null))), label: 'noise floor' }] : [],
  })));
  const b = maps.by_band || {};
  const e = b.edges_hz || [];
  parts.push(h('figure', {}, h('h3', {}, 'By frequency band (octaves, by centre)'), barChart({
    id: 'residual-bands', height: 260, labels: e.slice(0, -1).map((a, i) => `${fmt(Math.sqrt(a * e[i + 1]), 2)} Hz`),
    values: P1(b.nrmse), ylabel: 'NRMSE share (%)', format: fmtP(2),
  })));
  if (maps.by_line) {
    const keys = ['excited', 'not_excited', 'constant', 'aperiodic'];
    parts.push(h('figure', {}, h('h3', {}, 'By DFT line of the period'), barChart({
      id: 'residual-lines', height: 260, labels: ['excited', 'not excited', 'constant', 'aperiodic'],
      values: keys.map((k) => P(maps.by_line[k])), ylabel: 'NRMSE share (%)', format: fmtP(2),
    }), h('p', { class: 'caption' }, 'Error on lines the excitation does not excite is '
      + 'nonlinear distortion the model does not reproduce.')));
  }
  return parts;
}

// The maps of measured modes: NRMSE per record and sensor, and that residual over the
// sensor's own noise (the failures list those above the diagnosis's factor).
function modalMaps(maps) {
  const cells = maps.cells || [];
  const labels = cells.map((c) => `${c.run}\n${c.channel}`);
  return [h('figure', {}, h('h3', {}, 'By record and sensor'), barChart({
    id: 'residual-cells', height: 260, labels, values: cells.map((c) => P(c.nrmse)),
    ylabel: 'NRMSE (%)', format: fmtP(2),
  })), h('figure', {}, h('h3', {}, 'Residual over the sensor\'s noise'), barChart({
    id: 'residual-noise', height: 260, labels, values: cells.map((c) => c.residual_over_noise),
    ylabel: 'rms residual / noise', format: (v) => `${fmt(v, 3)}×`,
  }))];
}

export function residualMaps(maps, failures, kind) {
  const parts = !maps ? [] : kind === 'record' ? recordMaps(maps) : kind === 'modal' ? modalMaps(maps) : [];
  if (kind !== 'record' && maps?.by_run) parts.push(h('figure', {}, h('h3', {}, 'By run: amplitude × frequency'), gridMap(maps.by_run)));
  if (maps?.by_phase) {
    const e = maps.by_phase.edges || [];
    const mid = e.slice(0, -1).map((a, i) => 180 * (a + e[i + 1]));
    parts.push(h('figure', {}, h('h3', {}, 'Against phase within the cycle'), plotXY({
      id: 'residual-phase', height: 280, xlabel: 'phase from the upward centre crossing (°)', ylabel: 'residual (% of rms F)',
      xdomain: [0, 360], xticks: [0, 45, 90, 135, 180, 225, 270, 315, 360], series: [
        { name: 'rms', x: mid, y: P1(maps.by_phase.rms), mode: 'both', color: color(1) },
        { name: 'mean (signed)', x: mid, y: P1(maps.by_phase.mean), mode: 'both', color: color(0) }],
    }), h('p', { class: 'caption' }, '90° and 270° are the reversals (largest |u|).')));
  }
  if (maps?.by_quadrant) {
    parts.push(h('figure', {}, h('h3', {}, 'By quadrant of (displacement, velocity)'), barChart({
      id: 'quadrants', height: 260, labels: (maps.by_quadrant.labels || []).map((l) => l.replace(' (', '\n(')),
      values: P1(maps.by_quadrant.nrmse), ylabel: 'NRMSE part (%)', format: fmtP(2),
    })));
  }
  const fails = (failures || []).map((f) => h('li', {}, h('strong', {}, f.where), ': ', onPage(f.text)));
  if (!parts.length && !fails.length) return h('p', { class: 'note' }, 'The diagnosis carries no residual maps.');
  return h('div', {}, fails.length ? h('ul', { class: 'failures', id: 'failures' }, fails) : null,
    h('div', { class: 'grid2' }, parts));
}

// Energy loss and loop stiffness against displacement amplitude (log-log), measured as
// points and model as lines, one colour per frequency.
export function physics(fit) {
  const runs = (fit.runs || []).filter((r) => r.displacement_amplitude_m != null);
  if (!runs.some((r) => r.energy_loss_measured_j != null)) {
    return h('p', { class: 'note' }, 'The fit result carries no measured/model energy loss per run.');
  }
  const byF = new Map();
  for (const r of runs) {
    const key = Math.round(r.frequency_hz ?? 0);
    if (!byF.has(key)) byF.set(key, []);
    byF.get(key).push(r);
  }
  const mk = (field, k) => {
    const series = [];
    [...byF.entries()].forEach(([f, rs], i) => {
      rs.sort((a, b) => a.displacement_amplitude_m - b.displacement_amplitude_m);
      const x = rs.map((r) => r.displacement_amplitude_m * 1e6);
      series.push({ name: `measured ${f} Hz`, x, y: rs.map((r) => r[`${field}_measured${field === 'energy_loss' ? '_j' : '_n_per_m'}`] * k), mode: 'points', color: color(i) });
      series.push({ name: `model ${f} Hz`, x, y: rs.map((r) => r[`${field}_model${field === 'energy_loss' ? '_j' : '_n_per_m'}`] * k), mode: 'both', r: 2, color: color(i), dash: '6 3' });
    });
    return series;
  };
  // the measured values set the scale: a model far below them (no slip yet) leaves the
  // plot at the bottom instead of squeezing the measurements into a few pixels
  const domain = (series) => {
    const pos = (sr) => sr.y.filter((v) => v > 0 && Number.isFinite(v));
    const meas = series.filter((sr) => sr.mode === 'points').flatMap(pos);
    const all = series.flatMap(pos);
    if (!meas.length) return undefined;
    return [Math.max(Math.min(...all), Math.min(...meas) / 100), Math.max(...all)];
  };
  const energy = mk('energy_loss', 1e3);
  const stiff = mk('stiffness', 1e-6);
  const figure = (id, ylabel, series, what) => {
    const svg = plotXY({ id, xlog: true, ylog: true, height: 300, xlabel: 'displacement amplitude (µm)',
      ylabel, series, ydomain: domain(series) });
    return h('figure', {}, svg, offScale(svg, series, what));
  };
  return h('div', { class: 'grid2' },
    figure('dissipation', 'energy loss per cycle (mJ)', energy, 'energy loss'),
    figure('stiffness', 'loop stiffness (MN/m)', stiff, 'stiffness'));
}

// Says which series the plot could not draw and why (plotXY leaves them out of the legend).
function offScale(svg, series, what) {
  const drawn = new Map([...svg.querySelectorAll('[data-name]')].map((e) => [e.dataset.name, Number(e.dataset.drawn)]));
  const lost = series.filter((sr) => sr.name && !(drawn.get(sr.name) > 0));
  if (!lost.length) return null;
  return h('p', { class: 'caption off-scale' }, lost.map((sr) => {
    const pos = sr.y.filter((v) => v != null && Number.isFinite(v) && v > 0);
    const why = !pos.length ? `its ${what} is zero (no place on a log axis)`
      : `its ${what} (down to ${fmt(Math.min(...pos), 2)}) is far below the measured values`;
    return `${sr.name}: not drawn, ${why}.`;
  }).join(' '));
}

const firstSentence = (t) => (t.match(/^.*?[.!?](\s|$)/) || [t])[0];

export function candidates(diag, onAdd, busy) {
  const list = diag?.candidates || [];
  if (!list.length) return h('p', { class: 'note' }, 'No candidate effect left to try.');
  return h('ol', { class: 'candidates', id: 'candidates' }, list.map((c) => h('li', {
    class: c.significant ? 'significant' : '', 'data-effect': c.effect },
  h('div', { class: 'cand-head' }, h('strong', {}, c.effect),
    h('span', { class: `status ${c.significant ? 'done' : ''}` }, c.significant ? 'significant' : 'not significant'),
    `NRMSE after ${nrmse(c.nrmse_after)}`,
    c.nrmse_after_validation != null ? ` · on validation runs ${nrmse(c.nrmse_after_validation)}` : null,
    h('button', { class: 'small add-effect', 'data-effect': c.effect, disabled: busy, onclick: () => onAdd(c.effect) },
      `Add ${c.effect} and refit`)),
  c.explanation ? h('p', { class: 'cand-why' }, firstSentence(c.explanation)) : null,
  c.tie ? h('p', { class: 'caption' }, `Cannot be told apart from ${c.tie.with.join(', ')} on these data: ${c.tie.reason}`) : null,
  h('details', {}, h('summary', {}, 'Explanation and evidence'),
    c.explanation ? h('p', {}, c.explanation) : null,
    c.test ? h('p', { class: 'caption' }, `Test: ${c.test}`) : null,
    c.evidence ? h('p', { class: 'caption' }, typeof c.evidence === 'string' ? c.evidence : JSON.stringify(c.evidence)) : null))));
}

export function ladderChart(steps, noiseFloor, id = 'ladder') {
  const v = steps.map((s) => P(s.nrmse));
  const fl = P(noiseFloor);
  return h('figure', {}, barChart({
    id, labels: steps.map((s, i) => (i === 0 || !s.added ? `${i}: ${s.model}` : `${i}: +${s.added}`)),
    values: v, ylabel: 'NRMSE (%)', ylog: v.some((x) => x > 0)
      && Math.max(...v, fl || 0) / Math.min(...v, fl || Infinity) > 8,
    hlines: fl ? [{ y: fl, label: `noise floor ${nrmse(noiseFloor)}`, color: '#b3261e' }] : [],
    format: fmtP(3),
  }), table(['Step', 'Model', 'Added', 'NRMSE'], steps.map((s, i) => [String(i), s.model, s.added || '–', nrmse(s.nrmse)]),
    { class: 'ladder-steps' }));
}

// A ladder step that made a run's energy-loss error worse (|error| up by more than
// WORSE_PCT points and by half again): [{step, added, run, before, after}], from the
// per-run errors each step carries (a diagnosis's runs, or a saved ladder's).
export const WORSE_PCT = 2;

export function worseSteps(steps) {
  const out = [];
  for (let i = 1; i < (steps || []).length; i += 1) {
    const prev = new Map((steps[i - 1].runs || []).map((r) => [r.run, r.energy_loss_error_pct]));
    for (const r of steps[i].runs || []) {
      const a = prev.get(r.run);
      const b = r.energy_loss_error_pct;
      if (a == null || b == null || !Number.isFinite(a) || !Number.isFinite(b)) continue;
      if (Math.abs(b) > Math.abs(a) + WORSE_PCT && Math.abs(b) > 1.5 * Math.abs(a)) {
        out.push({ step: i, added: steps[i].added, model: steps[i].model, run: r.run, before: a, after: b });
      }
    }
  }
  return out;
}

export function worseNote(steps, id = 'ladder-worse') {
  const worse = worseSteps(steps);
  if (!worse.length) return null;
  return h('div', { class: 'note error', id }, h('p', {}, 'Steps that made the energy loss worse on some runs '
    + '(the set\'s NRMSE fell, but these runs\' dissipation moved away from the measurement):'),
  h('ul', {}, worse.map((w) => h('li', { 'data-step': w.step, 'data-run': w.run },
    `step ${w.step} (+${w.added || w.model}): ${w.run}: energy-loss error ${pct(w.before)} → ${pct(w.after)}`))));
}
