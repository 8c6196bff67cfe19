// Structure: a joint model inside a structure against measured constant-force FRFs.
// Pick a structure file and an FRF set of the data directory, diagnose a model on it
// (a job), and see measured and model FRFs per force level around each mode, where the
// model fails, and the residual over the FRF's own noise per frequency and level for
// each response harmonic.

import { api, runJob } from '../api.js';
import { h, note, section, table } from '../dom.js';
import { fmt, nrmse } from '../units.js';
import { plotXY } from '../plot/plot.js';
import { heatMap } from '../plot/heatmap.js';

const state = { model: 'linear_stiffness', candidates: 'viscous,iwan,cubic_stiffness', result: null };

const select = (id, names) => h('select', { id }, ...names.map((n) => h('option', { value: n }, n)));

// Measured (points) and model (line) response per newton at harmonic 1, one plot per mode.
function frfPlots(cells) {
  const byMode = new Map();
  for (const c of cells.filter((x) => x.harmonic === 1)) {
    if (!byMode.has(c.mode)) byMode.set(c.mode, []);
    byMode.get(c.mode).push(c);
  }
  return [...byMode.entries()].map(([mode, cs]) => plotXY({
    id: `frf-mode${mode}`, title: `mode ${mode}: ${cs[0].sensor}, harmonic 1`, legendAt: 'tr',
    xlabel: 'frequency (Hz)', ylabel: 'response / force (m/s² per N)',
    series: cs.flatMap((c) => [
      { name: `${c.level_n} N ${c.direction} measured`, x: c.frequency_hz, y: c.measured_per_n, mode: 'points' },
      { name: `${c.level_n} N model`, x: c.frequency_hz, y: c.model_per_n, mode: 'line' },
    ]),
  }));
}

// Residual over noise: rows are force levels, columns the steps' frequencies, per harmonic.
function residualMaps(cells) {
  const harmonics = [...new Set(cells.map((c) => c.harmonic))].sort();
  return harmonics.map((hn) => {
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
  });
}

function resultView(res) {
  const cells = (res.maps && res.maps.cells) || [];
  const cands = (res.candidates || []).map((c) => [c.effect, nrmse(c.nrmse_after_validation),
    c.significant ? 'yes' : 'no', fmt(c.p_value, 2)]);
  return h('div', { id: 'frf-result' },
    h('p', { id: 'frf-summary' }, `${res.model}: NRMSE ${nrmse(res.nrmse)}, noise floor `
      + `${nrmse(res.noise_floor)} (${res.split}). ${res.verdict}`),
    h('ul', { id: 'frf-failures' }, ...(res.failures || []).map((f) => h('li', {}, f.text))),
    table(['candidate', 'validation NRMSE', 'significant', 'p'], cands, { id: 'frf-candidates' }),
    ...frfPlots(cells), ...residualMaps(cells));
}

export async function show(el) {
  const files = await api('/structures');
  const msg = h('div', { id: 'frf-msg' });
  const out = h('div', { id: 'frf-out' }, state.result ? resultView(state.result) : '');
  if (!files.structures.length || !files.frfsets.length) {
    el.append(section('Structure FRFs', h('p', { class: 'note' }, 'Put a structure file in the data '
      + "directory's structures/ folder and an FRF set (JSON) in its frf/ folder.")));
    return;
  }
  const st = select('frf-structure', files.structures);
  const fs = select('frf-set', files.frfsets);
  const expr = h('input', { id: 'frf-model', value: state.model, size: 40 });
  const cand = h('input', { id: 'frf-candidates-input', value: state.candidates, size: 40 });
  const go = h('button', { id: 'frf-go', type: 'button' }, 'Diagnose');
  go.addEventListener('click', async () => {
    state.model = expr.value.trim();
    state.candidates = cand.value.trim();
    const candidates = state.candidates ? state.candidates.split(',').map((x) => x.trim()) : undefined;
    go.disabled = true;
    note(msg, 'diagnosing…');
    try {
      state.result = await runJob(`/structures/${encodeURIComponent(st.value)}/models/diagnose`,
        '/models/jobs', { frfsets: [fs.value], model: state.model, options: { full: true, candidates } },
        (job) => note(msg, `${job.status}${job.message ? `: ${job.message}` : ''}`));
      out.replaceChildren(resultView(state.result));
      note(msg, 'done');
    } catch (err) {
      note(msg, err.message, 'error');
    } finally {
      go.disabled = false;
    }
  });
  el.append(section('Joint model in a structure against measured FRFs',
    h('p', { class: 'note' }, 'Constant-force stepped-sine FRFs (response harmonics 1-3) compared '
      + 'with the joint model inside the structure (Craig-Bampton + harmonic balance).'),
    h('label', {}, 'structure ', st), h('label', {}, ' FRF set ', fs),
    h('label', {}, ' model ', expr), h('label', {}, ' candidates ', cand), go, msg), out);
}
