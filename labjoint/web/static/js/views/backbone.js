// Backbones (issue 30): a mode's natural frequency and damping ratio against vibration
// amplitude (log amplitude axis). Measured points come from a stored backbone file
// (backbones/ folder) or are measured from ticked runs (phase_resonance levels and their
// ringdown, step_sine runs: POST /backbones, stored under a name); each method has its
// colour, with error bars of one standard uncertainty. A ladder of joint models inside
// a structure (a job on the stored backbones, FRF sets optional beside them) adds the
// model's backbone at the measured amplitudes, one dashed curve per ladder step.

import { api, runJob, token } from '../api.js';
import { h, note, section, table } from '../dom.js';
import { fmt, nrmse } from '../units.js';
import { plotXY } from '../plot/plot.js';

const state = { name: '', file: null, ladder: null, model: 'linear_stiffness', candidates: 'viscous,iwan',
  steps: 2, damping: 'file' };

export const METHODS = { phase_resonance: 'phase resonance', ringdown_hilbert: 'ringdown (Hilbert)',
  ringdown_peaks: 'ringdown (peaks)', step_sine: 'step sine', sdof_harmonic: 'single-DOF model',
  epmc: 'EPMC model' };
const label = (m) => METHODS[m] || m.replace(/_/g, ' ');

const select = (id, names, empty) => h('select', { id }, h('option', { value: '' }, empty),
  ...names.map((n) => h('option', { value: n }, n)));

// Every point of the file's backbones grouped by method (a file holds one backbone per
// method; a method's points may also come from several backbones).
export function byMethod(file) {
  const out = new Map();
  for (const b of file.backbones) {
    for (const p of b.points) {
      if (!out.has(p.method)) out.set(p.method, { a: [], f: [], fsd: [], z: [], zsd: [] });
      const g = out.get(p.method);
      g.a.push(p.amplitude);
      g.f.push(p.frequency_hz);
      g.fsd.push(p.frequency_sd_hz);
      g.z.push(100 * p.damping_ratio);
      g.zsd.push(100 * p.damping_sd);
    }
  }
  return out;
}

function plots(file, ladder) {
  const groups = [...byMethod(file).entries()];
  const units = file.backbones[0].amplitude_units;
  const sensor = file.backbones[0].sensor;
  const measured = (y, e) => groups.map(([m, g]) => ({ name: label(m), x: g.a, y: g[y], err: g[e],
    mode: 'points' }));
  // one dashed curve per ladder step: its model at every measured amplitude, ascending
  const model = (key, scale) => (ladder ? ladder.steps.map((st, i) => {
    const pts = (st.backbone_curves || []).flatMap((c) => c.amplitude_m.map((a, k) => [a, scale * c[key][k]]))
      .sort((p, q) => p[0] - q[0]);
    return { name: `step ${i}: ${st.model}`, x: pts.map((p) => p[0]), y: pts.map((p) => p[1]),
      mode: 'line', dash: '5 3' };
  }) : []);
  const opts = { xlog: true, xlabel: `amplitude at ${sensor} (${units})`, height: 320 };
  return h('div', { class: 'grid2', id: 'backbone-plots' },
    h('figure', {}, plotXY({ ...opts, id: 'backbone-frequency', title: `mode ${file.mode}: natural frequency`,
      ylabel: 'frequency (Hz)', series: [...measured('f', 'fsd'), ...model('frequency_hz', 1)] })),
    h('figure', {}, plotXY({ ...opts, id: 'backbone-damping', title: `mode ${file.mode}: damping ratio`,
      ylabel: 'damping ratio (%)', series: [...measured('z', 'zsd'), ...model('damping_ratio', 100)] })));
}

function pointsTable(file) {
  const rows = [];
  for (const [m, g] of byMethod(file)) {
    g.a.forEach((a, i) => rows.push(h('tr', { dataset: { method: m } }, h('td', {}, label(m)),
      h('td', { class: 'num' }, fmt(a, 3)), h('td', { class: 'num' }, `${fmt(g.f[i], 6)} ± ${fmt(g.fsd[i], 2)}`),
      h('td', { class: 'num' }, `${fmt(g.z[i], 3)} ± ${fmt(g.zsd[i], 2)}`))));
  }
  return h('div', { class: 'scroll' }, table(['method', `amplitude (${file.backbones[0].amplitude_units})`,
    'f (Hz)', 'ζ (%)'], rows, { id: 'backbone-points', class: 'table2' }));
}

// What remains after each step that is not adequate (the comparison's failures in the
// field's words, each with where: method and amplitude), one list per step.
function remainingList(res) {
  const steps = res.steps.map((s, i) => [i, s]).filter(([, s]) => (s.remaining || []).length);
  if (!steps.length) return '';
  return h('div', { id: 'backbone-remaining' }, h('h3', {}, 'what remains, and where'),
    ...steps.map(([i, s]) => h('div', { class: 'remaining', dataset: { step: i } },
      h('p', {}, `step ${i}: ${s.model}`),
      h('ul', {}, ...s.remaining.map((r) => h('li', {}, r))))));
}

function ladderTable(res) {
  const floorV = res.noise_floor_validation;
  const rows = res.steps.map((s, i) => h('tr', { dataset: { step: i } }, h('td', { class: 'num' }, i),
    h('td', {}, s.model), h('td', {}, s.added || '–'), h('td', { class: 'num' }, nrmse(s.nrmse)),
    h('td', { class: 'num' }, nrmse(s.nrmse_validation)),
    h('td', { class: 'num' }, floorV ? `${fmt(s.nrmse_validation / floorV, 3)}×` : '–'),
    h('td', {}, s.adequate ? 'yes' : 'no')));
  const fails = (res.final_diagnosis && res.final_diagnosis.failures) || [];
  return h('div', { id: 'backbone-ladder-out' },
    h('p', { id: 'backbone-ladder-summary' }, `noise floor ${nrmse(res.noise_floor)}`
      + `${floorV ? ` (validation ${nrmse(floorV)})` : ''}; adequate: `
      + `${res.adequate ? 'yes' : 'no'} (${res.stop_reason})`),
    h('p', { id: 'backbone-linear-damping' }, `linear damping: ${res.linear_damping
      || "the structure file's (not identified from the backbones)"}`),
    h('div', { class: 'scroll' }, table(['step', 'model', 'added', 'NRMSE', 'validation', '× floor', 'adequate'],
      rows, { id: 'backbone-ladder', class: 'table2' })),
    remainingList(res),
    fails.length ? h('ul', { id: 'backbone-failures' }, ...fails.map((f) => h('li', {}, f.text))) : '');
}

function view(out) {
  if (!state.file) return;
  const n = state.file.backbones.reduce((k, b) => k + b.points.length, 0);
  out.replaceChildren(
    h('p', { id: 'backbone-about' }, `${state.name}: mode ${state.file.mode}, ${n} point(s) by `
      + `${[...byMethod(state.file).keys()].map(label).join(', ')}`),
    plots(state.file, state.ladder), pointsTable(state.file),
    state.ladder ? ladderTable(state.ladder) : '');
}

const picked = (box) => [...box.querySelectorAll('input:checked')].map((x) => x.value);

export async function show(el) {
  const [stored, files, runList] = await Promise.all([api('/backbones'), api('/structures'),
    api('/runs', { query: { status: 'complete', order: '-start_time', limit: 500 } })]);
  const msg = h('div', { id: 'backbone-msg' });
  const out = h('div', { id: 'backbone-view' });
  const pick = select('backbone-stored', stored.backbones, '(stored backbones)');
  const usable = runList.items.filter((r) => ['phase_resonance', 'step_sine'].includes(r.plan));
  const runs = h('div', { class: 'run-pick', id: 'backbone-runs' }, ...usable
    .map((r) => h('label', { class: 'field inline' }, h('input', { type: 'checkbox', value: r.name }), r.name)));
  if (!usable.length) runs.append(h('p', { class: 'note' }, 'No complete phase_resonance or step_sine run yet.'));
  const name = h('input', { id: 'backbone-name', placeholder: 'name to store as', size: 16 });
  const st = select('backbone-structure', files.structures, '(structure)');
  const fs = h('select', { id: 'backbone-frfsets', multiple: true, size: Math.min(4, files.frfsets.length || 1) },
    ...files.frfsets.map((n) => h('option', { value: n }, n)));
  const expr = h('input', { id: 'backbone-model', value: state.model, size: 24 });
  const cand = h('input', { id: 'backbone-candidates', value: state.candidates, size: 24 });
  const steps = h('input', { id: 'backbone-steps', type: 'number', min: 1, max: 5, value: state.steps, size: 3 });
  const damping = h('select', { id: 'backbone-linear-damping-opt' },
    h('option', { value: 'file' }, "structure file's"), h('option', { value: 'measured' }, 'from the backbones'));
  damping.value = state.damping;
  const progress = (job) => note(msg, `${job.status}${job.message ? `: ${job.message}` : ''}`, 'busy');

  async function open(n) {
    state.file = await api(`/backbones/${encodeURIComponent(n)}`);
    state.name = n;
    state.ladder = null;
    pick.value = n;
    view(out);
  }
  const act = (btn, fn) => btn.addEventListener('click', async () => {
    btn.disabled = true;
    try {
      await fn();
      note(msg, '');
    } catch (err) {
      note(msg, err.message, 'error');
    } finally {
      btn.disabled = false;
    }
  });
  const openBtn = h('button', { id: 'backbone-open', type: 'button', class: 'secondary' }, 'Open');
  act(openBtn, async () => {
    if (!pick.value) throw new Error('Choose a stored backbone file.');
    await open(pick.value);
  });
  const measure = h('button', { id: 'backbone-measure', type: 'button' }, 'Measure and store');
  act(measure, async () => {
    const chosen = picked(runs);
    const n = name.value.trim();
    if (!chosen.length || !n) throw new Error('Tick phase_resonance or step_sine runs and give a name.');
    await api('/backbones', { method: 'POST', body: { runs: chosen, save_as: n, overwrite: true } });
    if (![...pick.options].some((o) => o.value === n)) pick.append(h('option', { value: n }, n));
    await open(n);
  });
  const go = h('button', { id: 'backbone-ladder-go', type: 'button' }, 'Ladder');
  act(go, async () => {
    if (!state.file) throw new Error('Open or measure a backbone first.');
    if (!st.value) throw new Error('Choose the structure whose joints carry the model.');
    state.model = expr.value.trim();
    state.candidates = cand.value.trim();
    state.steps = Number(steps.value) || 1;
    state.damping = damping.value;
    const candidates = state.candidates ? state.candidates.split(',').map((x) => x.trim()) : undefined;
    state.ladder = await runJob(`/structures/${encodeURIComponent(st.value)}/models/ladder`, '/models/jobs',
      { backbones: [state.name], frfsets: [...fs.selectedOptions].map((o) => o.value), model: state.model,
        max_steps: state.steps, options: { full: true, candidates, linear_damping: state.damping } }, progress);
    view(out);
  });
  el.append(section('Backbones',
    h('p', { class: 'note' }, 'Natural frequency and damping ratio against the amplitude of the '
      + "fundamental at the response sensor, by method (± one standard uncertainty); a ladder's "
      + 'steps draw the model inside the structure (extended periodic motion concept) at the '
      + 'measured amplitudes.'),
    h('div', { class: 'toolbar' }, pick, openBtn),
    h('h3', {}, 'measure from runs'), runs, h('div', { class: 'toolbar' }, name, measure),
    h('h3', {}, 'model ladder'),
    h('div', { class: 'toolbar' }, h('label', {}, 'structure ', st), h('label', {}, ' FRF sets ', fs)),
    h('div', { class: 'toolbar' }, h('label', {}, 'start ', expr), h('label', {}, ' candidates ', cand),
      h('label', {}, ' steps ', steps), h('label', {}, ' linear damping ', damping), go),
    token() ? '' : h('p', { class: 'note' }, 'measuring and the ladder need the control token (jobs)'),
    msg, out));
  if (state.file) view(out);
  return { leave() {} };
}
