// Predict: identify a model by simulation error (force in, displacement out) on the
// ticked records and plot what it predicts against what was measured, on the records it
// was fitted on and on held-out records it never saw; the residual's RMS along each
// whole record shows where in time the prediction fails.

import { api, runJob } from '../api.js';
import { h, note, section, table } from '../dom.js';
import { fmt, nrmse, paramDisplay, um } from '../units.js';
import { plotXY } from '../plot/plot.js';
import { selectedRuns, setSelectedRuns } from './runs.js';

const state = { model: 'inertia+viscous+linear_stiffness', periodic: false, result: null, busy: false };

function picker(items, ticked, id) {
  const box = h('div', { class: 'run-pick', id });
  for (const r of items) {
    box.append(h('label', {}, h('input', { type: 'checkbox', value: r.name, checked: ticked.has(r.name) }),
      r.name, h('span', { class: 'count' }, ` ${r.n_samples ?? ''} samples`)));
  }
  if (!items.length) box.append(h('p', { class: 'note' }, 'No complete run yet.'));
  return box;
}

const picked = (box) => [...box.querySelectorAll('input:checked')].map((x) => x.value);

function seriesPlots(s, label) {
  const t = s.time_s;
  const fig = plotXY({
    id: `predict-${label}-${s.run}`, title: `${s.run} (${label}): last ${t.length} samples`,
    xlabel: 'time (s)', ylabel: 'displacement (µm)', legendAt: 'tr',
    series: [
      { name: 'measured', x: t, y: s.measured_m.map(um), mode: 'line' },
      { name: 'predicted', x: t, y: s.predicted_m.map(um), mode: 'line', dash: '5 3' },
      { name: 'residual', x: t, y: s.measured_m.map((m, i) => um(m - s.predicted_m[i])), mode: 'line' },
    ],
  });
  const seg = plotXY({
    id: `predict-seg-${label}-${s.run}`, title: 'residual RMS along the whole record',
    xlabel: 'time (s)', ylabel: 'RMS (µm)',
    series: [{ name: 'residual RMS', x: s.segment_time_s, y: s.segment_rms_m.map(um), mode: 'both' }],
    hlines: Number.isFinite(s.noise_std_m) ? [{ y: um(s.noise_std_m), label: 'noise' }] : [],
  });
  return h('figure', { class: 'prediction', 'data-run': s.run, 'data-role': label },
    h('p', { class: 'caption' }, `RMSE ${fmt(um(s.rmse), 3)} µm · NRMSE ${nrmse(s.nrmse)}`), fig, seg);
}

function resultView(res) {
  const params = Object.entries(res.parameters).map(([k, p]) => {
    const d = paramDisplay(p.unit);
    return [k, fmt(p.value * d.k), p.stderr == null ? '–' : fmt(p.stderr * d.k, 2), d.unit];
  });
  return h('div', { id: 'predict-result' },
    h('p', { id: 'predict-summary' }, `${res.model} by simulation error: NRMSE ${nrmse(res.nrmse)} on the `
      + `fitted records (noise floor ${nrmse(res.noise_floor)})`
      + (res.nrmse_validation == null ? '' : `, ${nrmse(res.nrmse_validation)} on the held-out ones`)),
    ...(res.warnings || []).map((w) => h('p', { class: 'note error predict-warning' }, `warning: ${w}`)),
    table(['parameter', 'value', 'stderr', 'unit'], params, { id: 'predict-params' }),
    ...(res.series || []).map((s) => seriesPlots(s, 'fitted')),
    ...(res.validation_series || []).map((s) => seriesPlots(s, 'held-out')));
}

export async function show(el) {
  const runList = await api('/runs', { query: { status: 'complete', order: '-start_time', limit: 500 } });
  const ticked = new Set(selectedRuns());
  const fitBox = picker(runList.items, ticked, 'predict-fit');
  const valBox = picker(runList.items, new Set(), 'predict-validate');
  const expr = h('input', { id: 'predict-model', value: state.model, size: 50 });
  const periodic = h('input', { id: 'predict-periodic', type: 'checkbox', checked: state.periodic });
  const msg = h('div', { id: 'predict-msg' });
  const out = h('div', { id: 'predict-out' }, state.result ? resultView(state.result) : '');
  const go = h('button', { id: 'predict-go', type: 'button' }, 'Identify and predict');
  go.addEventListener('click', async () => {
    const runs = picked(fitBox);
    if (!runs.length) { note(msg, 'Tick at least one record to fit on.', 'error'); return; }
    setSelectedRuns(runs);
    state.model = expr.value.trim();
    state.periodic = periodic.checked;
    const validate = picked(valBox).filter((n) => !runs.includes(n));
    go.disabled = true;
    note(msg, 'fitting by simulation error…');
    try {
      state.result = await runJob('/models/fit', '/models/jobs', {
        runs, model: state.model,
        options: { error: 'simulation', full: true, periodic: state.periodic, ...(validate.length ? { validate } : {}) },
      }, (job) => note(msg, `${job.status}${job.message ? `: ${job.message}` : ''}`));
      out.replaceChildren(resultView(state.result));
      note(msg, 'done');
    } catch (err) {
      note(msg, err.message, 'error');
    } finally {
      go.disabled = false;
    }
  });
  el.append(section('Predict a response it was not fitted on',
    h('p', { class: 'note' }, 'Records with the force applied to the structure (force_N) and its '
      + 'displacement (displacement_m): a model with inertia is simulated from the force; its '
      + 'parameters minimise the simulation error of the displacement.'),
    h('label', {}, 'model ', expr), h('label', {}, periodic, ' each record is whole periods of a periodic input'),
    h('h3', {}, 'fit on'), fitBox, h('h3', {}, 'predict (held out)'), valBox, go, msg), out);
}
