// Structure: a joint model inside a structure against measured constant-force FRFs.
// Pick a structure file and an FRF set of the data directory, diagnose a model on it or
// climb a ladder (a job), and read the verdict as the pipeline gives it (inconclusive,
// refused effects, flagged parameters). Then see, for the baseline, any candidate or any
// ladder step (selectable), the measured steps of every sensor against the model's FRF
// evaluated densely by harmonic balance (a second job), magnitude and phase, every force
// level overlaid; and the residual over the FRF's noise per frequency and level.

import { api, runJob } from '../api.js';
import { h, note, section, table } from '../dom.js';
import { fmt, nrmse } from '../units.js';
import { onPage } from '../words.js';
import { determination, parameters } from './modelplots.js';
import { curvePlots, residualMaps } from './structcurves.js';

// frequencies per sweep of the dense model curve (the reduced model: seconds per sweep)
const POINTS = 200;
// model curves kept for switching back and forth (the oldest is dropped first)
const MAX_CACHED = 16;
const state = { model: 'linear_stiffness', candidates: 'viscous,iwan,cubic_stiffness', op: 'diagnose',
  result: null, files: null, choice: 0, harmonic: 1, curves: new Map() };

const select = (id, names, chosen) => h('select', { id },
  ...names.map((n) => h('option', { value: n, selected: n === chosen }, n)));
const values = (ps) => Object.fromEntries(Object.entries(ps || {}).map(([k, p]) => [k, p.value]));
// Flagged: the pipeline's own flag, or the page's rule for a standard error (modelplots.js).
const flagged = (ps) => Object.entries(ps || {}).filter(([, p]) => p.flag || determination(p)[0] !== 'ok')
  .map(([k]) => k);

// The parameter table of the models page, with the pipeline's flag in its words where it gives one.
function paramTable(o) {
  const t = parameters(o);
  for (const [k, p] of Object.entries(o.parameters || {})) {
    const row = [...t.querySelectorAll('tr[data-param]')].find((r) => r.dataset.param === k);
    if (!p.flag || !row) continue;
    row.classList.add('flagged');
    row.dataset.flag = p.flag;
    row.lastElementChild.className = 'verdict bad';
    row.lastElementChild.textContent = p.flag;
  }
  return t;
}
const scroll = (el) => h('div', { class: 'scroll' }, el);

// The models whose curves can be drawn: the baseline and each candidate, or each ladder step.
function choices(res) {
  if (res.steps) {
    return res.steps.map((s, i) => ({ label: i === 0 ? `step 0: ${s.model}` : `step ${i}: + ${s.added} (${s.model})`,
      model: s.model, parameters: s.parameters }));
  }
  return [{ label: `baseline: ${res.model}`, model: res.model, parameters: res.parameters },
    ...(res.candidates || []).map((c) => ({ label: `+ ${c.effect}${c.significant ? ' (significant)' : ''}: ${c.model}`,
      model: c.model, parameters: c.parameters }))];
}

// Adequate in green, a verdict that the data cannot decide in plain text, the rest in red.
const verdictClass = (dg) => (dg.adequate ? 'good' : String(dg.verdict).startsWith('inconclusive') ? '' : 'bad');

// What the diagnosis says, in its own words: verdict, tie, where the model fails, the
// effects refused or not tried (with the reason), and the candidates with their flags.
function verdictView(dg, ladder) {
  const refused = Object.entries(dg.not_applicable || {});
  const cands = (dg.candidates || []).map((c) => [c.effect, nrmse(c.nrmse_after_validation),
    c.significant ? 'yes' : 'no', fmt(c.p_value, 2), flagged(c.parameters).join(', ') || '–']);
  return h('div', { id: 'frf-verdict-box' },
    h('p', { id: 'frf-summary' }, `${dg.model}: NRMSE ${nrmse(dg.nrmse)}, noise floor `
      + `${nrmse(dg.noise_floor)}; validation NRMSE ${nrmse(dg.nrmse_validation)} (${onPage(dg.split)}).`),
    h('p', { id: 'frf-verdict', class: `verdict ${verdictClass(dg)}` }, onPage(dg.verdict)),
    dg.tie ? h('p', { class: 'caption', id: 'frf-tie' }, `tied: ${dg.tie.effects.join(', ')}: ${dg.tie.reason}`) : null,
    ladder ? h('p', { class: 'caption', id: 'frf-stop' }, `ladder stopped: ${onPage(ladder.stop_reason)}`) : null,
    h('ul', { id: 'frf-failures' }, ...(dg.failures || []).map((f) => h('li', {}, f.text))),
    refused.length ? h('div', {}, h('h3', {}, 'Not tried'), h('ul', { id: 'frf-refused' },
      ...refused.map(([e, why]) => h('li', { dataset: { effect: e } }, `${e}: ${onPage(why)}`)))) : null,
    cands.length ? scroll(table(['candidate', 'validation NRMSE', 'significant', 'p', 'flagged parameters'],
      cands, { id: 'frf-candidates', class: 'table2' })) : null);
}

function ladderTable(res) {
  const rows = res.steps.map((s, i) => [String(i), s.added || '–', s.model, nrmse(s.nrmse),
    nrmse(s.nrmse_validation), flagged(s.parameters).join(', ') || '–']);
  return scroll(table(['step', 'added', 'model', 'NRMSE', 'validation NRMSE', 'flagged parameters'], rows,
    { id: 'frf-steps', class: 'table2' }));
}

function resultView(res, msg) {
  const dg = res.steps ? res.final_diagnosis || null : res;
  const opts = choices(res);
  state.choice = Math.min(state.choice, opts.length - 1);
  const pick = h('select', { id: 'frf-curve-pick' },
    ...opts.map((o, i) => h('option', { value: i, selected: i === state.choice }, o.label)));
  const harm = h('select', { id: 'frf-harmonic' });
  const params = h('div', { id: 'frf-curve-params' });
  const plots = h('div', { id: 'frf-plots' });
  let generation = 0;

  function draw(curves) {
    const H = Math.max(...curves.sweeps.map((sw) => sw.harmonics));
    state.harmonic = Math.min(state.harmonic, H);
    harm.replaceChildren(...Array.from({ length: H }, (_, i) => h('option',
      { value: i + 1, selected: i + 1 === state.harmonic }, `harmonic ${i + 1}`)));
    plots.replaceChildren(curvePlots(curves, state.harmonic));
  }
  async function showCurves() {
    const o = opts[state.choice];
    params.replaceChildren(h('p', { class: 'caption' }, `Parameters of ${o.model}`), scroll(paramTable(o)));
    const key = JSON.stringify([state.files, o.model, values(o.parameters)]);
    generation += 1;
    const mine = generation;
    if (!state.curves.has(key)) {
      note(msg, `evaluating ${o.model} densely…`, 'busy');
      try {
        const body = { frfsets: [state.files[1]], model: o.model, parameters: values(o.parameters), points: POINTS };
        if (state.curves.size >= MAX_CACHED) state.curves.delete(state.curves.keys().next().value);
        state.curves.set(key, await runJob(`/structures/${encodeURIComponent(state.files[0])}/curves`,
          '/structures/jobs', body, (job) => note(msg, `model curves: ${job.status}`, 'busy')));
      } catch (err) {
        if (mine === generation) note(msg, err.message, 'error');
        return;
      }
    }
    if (mine !== generation) return;
    note(msg, '');
    draw(state.curves.get(key));
  }
  pick.addEventListener('change', () => { state.choice = Number(pick.value); showCurves(); });
  harm.addEventListener('change', () => {
    state.harmonic = Number(harm.value);
    const o = opts[state.choice];
    const c = state.curves.get(JSON.stringify([state.files, o.model, values(o.parameters)]));
    if (c) draw(c);
  });
  showCurves();
  const cells = (dg && dg.maps && dg.maps.cells) || [];
  return h('div', { id: 'frf-result' },
    res.steps ? ladderTable(res) : null,
    dg ? verdictView(dg, res.steps ? res : null) : h('p', { id: 'frf-verdict' }, onPage(res.stop_reason)),
    h('h3', {}, 'Measured and model FRFs'),
    h('div', { class: 'toolbar' }, h('label', { class: 'field' }, 'model curves of', pick),
      h('label', { class: 'field' }, 'response harmonic', harm)),
    params, plots,
    cells.length ? h('h3', {}, 'Residual over the noise') : null, cells.length ? residualMaps(cells) : null);
}

export async function show(el) {
  const files = await api('/structures');
  const msg = h('div', { id: 'frf-msg' });
  const curveMsg = h('div', { id: 'frf-curve-msg' });
  const out = h('div', { id: 'frf-out' }, state.result ? resultView(state.result, curveMsg) : '');
  if (!files.structures.length || !files.frfsets.length) {
    el.append(section('Structure FRFs', h('p', { class: 'note' }, 'Put a structure file in the data '
      + "directory's structures/ folder and an FRF set (JSON) in its frf/ folder.")));
    return;
  }
  const [st0, fs0] = state.files || [];
  const st = select('frf-structure', files.structures, st0);
  const fs = select('frf-set', files.frfsets, fs0);
  const expr = h('input', { id: 'frf-model', value: state.model, size: 30 });
  const cand = h('input', { id: 'frf-candidates-input', value: state.candidates, size: 30 });
  const op = select('frf-op', ['diagnose', 'ladder'], state.op);
  const go = h('button', { id: 'frf-go', type: 'button' }, 'Run');
  go.addEventListener('click', async () => {
    state.model = expr.value.trim();
    state.candidates = cand.value.trim();
    state.op = op.value;
    const candidates = state.candidates ? state.candidates.split(',').map((x) => x.trim()) : undefined;
    go.disabled = true;
    note(msg, `${state.op}…`, 'busy');
    try {
      const files = [st.value, fs.value];
      const res = await runJob(`/structures/${encodeURIComponent(files[0])}/models/${state.op}`,
        '/models/jobs', { frfsets: [files[1]], model: state.model, options: { full: true, candidates } },
        (job) => note(msg, `${job.status}${job.message ? `: ${job.message}` : ''}`, 'busy'));
      Object.assign(state, { result: res, files, choice: res.steps ? res.steps.length - 1 : 0 });
      out.replaceChildren(resultView(res, curveMsg));
      note(msg, 'done', 'ok');
    } catch (err) {
      note(msg, err.message, 'error');
    } finally {
      go.disabled = false;
    }
  });
  el.append(section('Joint model in a structure against measured FRFs',
    h('p', { class: 'note' }, 'Constant-force stepped-sine FRFs (response harmonics 1-3) compared '
      + 'with the joint model inside the structure (Craig-Bampton + harmonic balance).'),
    h('div', { class: 'toolbar' }, h('label', { class: 'field' }, 'structure', st),
      h('label', { class: 'field' }, 'FRF set', fs), h('label', { class: 'field' }, 'model', expr),
      h('label', { class: 'field' }, 'candidates', cand), h('label', { class: 'field' }, 'operation', op), go),
    msg, curveMsg), out);
}
