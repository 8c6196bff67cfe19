// FRFs, modes and distortion (issue 28): tick broadband runs and compute their FRF set (a
// job, stored in the data directory's frf/ folder), or open a stored set; see magnitude,
// phase and coherence with the levels overlaid, the modes per level (LSCF/LSFD beside
// half-power), and the distortion report of steady-sine or multisine runs. Units come
// from the set's own quantity pair (m/s²/N, m/s/V, ...): a voltage is never called N.

import { api, runJob, token } from '../api.js';
import { h, note, section, table } from '../dom.js';
import { fmt } from '../units.js';
import { plotXY } from '../plot/plot.js';

const MAX_POINTS = 1500;          // per drawn series (a long record has 10^5 lines)
const state = { set: null, name: '', sensor: '', modes: null, distortion: null };

// "m/s^2/N" -> "m/s²/N"
export const pretty = (u) => String(u || '').replace(/\^2/g, '²').replace(/\^3/g, '³');

function picker(items, id) {
  const box = h('div', { class: 'run-pick', id });
  for (const r of items) {
    box.append(h('label', { class: 'field inline' },
      h('input', { type: 'checkbox', value: r.name }), r.name));
  }
  if (!items.length) box.append(h('p', { class: 'note' }, 'No complete run yet.'));
  return box;
}
const picked = (box) => [...box.querySelectorAll('input:checked')].map((x) => x.value);

// The set's lines grouped by level (a broadband set: one level per run).
function levels(d) {
  const out = new Map();
  const n = d.frequencies_hz.length;
  for (let i = 0; i < n; i += 1) {
    const key = `${(d.runs && d.runs[i]) || ''}|${d.level_n[i]}|${d.direction[i]}`;
    if (!out.has(key)) {
      const lv = d.level_n[i];
      const what = Number.isFinite(lv) ? `${fmt(lv, 3)} ${d.level_units}` : 'level ?';
      out.set(key, { label: d.runs && d.runs[i] ? `${what} (${d.runs[i]})` : what, idx: [] });
    }
    out.get(key).idx.push(i);
  }
  return [...out.values()];
}

// H = response / drive phasor at each line, for sensor s; a long set is thinned to
// MAX_POINTS lines, keeping the line of largest |H| in each stretch (no peak is lost).
function frfOf(d, s, idx) {
  const all = idx.map((i) => {
    const [rr, ri] = d.response[i][s][0];
    const [fr, fi] = d.force[i];
    const den = fr * fr + fi * fi;
    return [i, (rr * fr + ri * fi) / den, (ri * fr - rr * fi) / den];
  });
  const step = Math.max(1, Math.ceil(all.length / MAX_POINTS));
  const out = { f: [], mag: [], ph: [], coh: [] };
  for (let k = 0; k < all.length; k += step) {
    let best = all[k];
    for (let j = k + 1; j < Math.min(k + step, all.length); j += 1) {
      if (Math.hypot(all[j][1], all[j][2]) > Math.hypot(best[1], best[2])) best = all[j];
    }
    const [i, re, im] = best;
    out.f.push(d.frequencies_hz[i]);
    out.mag.push(Math.hypot(re, im));
    out.ph.push((Math.atan2(im, re) * 180) / Math.PI);
    out.coh.push(d.coherence ? d.coherence[i][s] : null);
  }
  return out;
}

function frfPlots(d, sensor) {
  const s = Math.max(0, d.sensors.indexOf(sensor));
  const lvs = levels(d).map((lv) => ({ ...lv, ...frfOf(d, s, lv.idx) }));
  const units = pretty(d.units);
  const ser = (key) => lvs.map((lv) => ({ name: lv.label, x: lv.f, y: lv[key] }));
  const opts = { xlabel: 'frequency (Hz)', height: 300 };
  const figs = [
    plotXY({ ...opts, id: 'frf-mag', title: `${d.sensors[s]}: |H| (${units})`, ylog: true,
      ylabel: `|H| (${units})`, series: ser('mag') }),
    plotXY({ ...opts, id: 'frf-phase', title: `${d.sensors[s]}: phase`, ylabel: 'phase (°)',
      ydomain: [-180, 180], series: ser('ph') }),
  ];
  if (d.coherence) {
    figs.push(plotXY({ ...opts, id: 'frf-coh', title: `${d.sensors[s]}: coherence`,
      ylabel: 'coherence', ydomain: [0, 1], series: ser('coh') }));
  }
  return h('div', { class: 'frf-plots grid2', id: 'frf-plots', 'data-units': d.units },
    ...figs.map((f) => h('figure', {}, f)));
}

function modesTable(res) {
  const rows = [];
  for (const lv of res.levels) {
    const what = lv.level == null ? '?' : `${fmt(lv.level, 3)} ${lv.level_units}`;
    lv.modes.forEach((m, i) => {
      const hp = m.half_power || {};
      rows.push(h('tr', { dataset: { level: lv.level ?? '', mode: i + 1 } },
        h('td', {}, what), h('td', {}, lv.run || ''), h('td', { class: 'num' }, i + 1),
        h('td', { class: 'num' }, fmt(m.frequency_hz, 5)),
        h('td', { class: 'num' }, fmt(100 * m.damping_ratio, 3)),
        h('td', { class: 'num' }, fmt(hp.frequency_hz, 5)),
        h('td', { class: 'num' }, hp.damping_ratio == null ? '–' : fmt(100 * hp.damping_ratio, 3))));
    });
  }
  const units = res.levels.length ? pretty(res.levels[0].units) : '';
  return h('div', { id: 'frf-modes-box' },
    h('p', { class: 'caption', id: 'frf-modes-units' }, `FRF in ${units}; damping ratio in % of critical`),
    h('div', { class: 'scroll' }, table(['level', 'run', 'mode', 'f (Hz)', 'ζ (%)',
      'half-power f (Hz)', 'half-power ζ (%)'], rows, { id: 'frf-modes', class: 'table2' })));
}

const ratio = (x) => `${fmt(x.ratio, 3)} ± ${fmt(x.stderr, 2)}`;

function distortionView(res) {
  return h('div', { id: 'distortion-out' }, ...res.runs.map((r) => {
    if (r.excitation === 'multisine') {
      return h('div', { class: 'distortion-run', dataset: { run: r.run } },
        h('h3', {}, `${r.run}: multisine, period ${fmt(r.period_s, 4)} s, drive ${r.drive}`),
        h('p', { class: 'note', id: `distortion-summary-${r.run}` }, r.summary || 'no summary'),
        h('ul', {}, ...Object.entries(r.channels).map(([n, c]) => h('li', {}, `${n} (${pretty(c.units)}): ${c.summary}`))));
    }
    const orders = Math.max(0, ...Object.values(r.channels).map((c) => c.harmonics.length));
    const heads = ['channel', 'quantity', 'amplitude'];
    for (let k = 0; k < orders; k += 1) heads.push(`h${k + 2}/h1`);
    const rows = Object.entries(r.channels).map(([n, c]) => h('tr', { dataset: { channel: n } },
      h('td', {}, n), h('td', {}, c.quantity),
      h('td', { class: 'num' }, `${fmt(c.amplitude, 4)} ${pretty(c.units)}`),
      ...c.harmonics.map((x) => h('td', { class: 'num' }, ratio(x)))));
    return h('div', { class: 'distortion-run', dataset: { run: r.run } },
      h('h3', {}, `${r.run}: sine at ${fmt(r.frequency_hz, 5)} Hz, drive ${r.drive}`),
      h('div', { class: 'scroll' }, table(heads, rows, { class: 'table2 distortion' })));
  }));
}

function frfView(out) {
  const d = state.set;
  if (!d) return;
  const sel = h('select', { id: 'frf-sensor' }, ...d.sensors.map((n) => h('option',
    { value: n, selected: n === state.sensor }, n)));
  const plots = h('div', {}, frfPlots(d, state.sensor || d.sensors[0]));
  sel.addEventListener('change', () => {
    state.sensor = sel.value;
    plots.replaceChildren(frfPlots(d, sel.value));
  });
  const how = d.metadata && d.metadata.method;
  out.replaceChildren(
    h('p', { id: 'frf-about' }, `${state.name}: ${d.estimator}, ${d.quantity} over ${d.drive_quantity}, `
      + `${pretty(d.units)}; ${levels(d).length} level(s)`),
    how ? h('p', { class: 'caption', id: 'frf-method-about' }, `estimated by ${how}`) : '',
    h('label', { class: 'field inline' }, 'sensor ', sel), plots,
    h('h3', {}, 'Modes per level'),
    state.modes ? modesTable(state.modes) : h('p', { class: 'note', id: 'frf-modes-none' },
      token() ? 'modes: press "Modes"' : 'modes need the control token (a job)'));
}

export async function show(el) {
  const [runList, sets] = await Promise.all([
    api('/runs', { query: { status: 'complete', order: '-start_time', limit: 500 } }),
    api('/spectra/frf')]);
  const msg = h('div', { id: 'frf-msg' });
  const out = h('div', { id: 'frf-view' });
  const runs = picker(runList.items, 'frf-runs');
  const name = h('input', { id: 'frf-name', placeholder: 'FRF set name', size: 16, value: state.name });
  const stored = h('select', { id: 'frf-stored' }, h('option', { value: '' }, '(stored sets)'),
    ...sets.frfsets.map((n) => h('option', { value: n, selected: n === state.name }, n)));
  const band = h('input', { id: 'frf-band', placeholder: 'lo:hi Hz', size: 10 });
  // how the FRFs are estimated (the API's FrfOptions): the method (auto: from the excitation),
  // a burst record's estimator (block: Testlab's burst H1 with the free decay; driven: the
  // driven part by the local rational method, the FRF at the burst's own amplitude) and H1/H2/Hv
  const choice = (id, label, values, title) => h('label', { class: 'field inline', title },
    `${label} `, h('select', { id }, ...values.map((v) => h('option', { value: v }, v))));
  const method = choice('frf-method', 'method', ['auto', 'welch', 'periodic', 'burst', 'block'],
    'auto: whole periods of a multisine, a burst record by its bursts, Welch over a steady random '
    + 'record, one block otherwise');
  const burstMode = choice('frf-burst', 'burst', ['block', 'driven'],
    'block: one unwindowed block per burst with its free decay (Testlab\'s burst H1); driven: '
    + 'each burst\'s driven part by the local rational method (the FRF at the burst\'s own amplitude)');
  const estimator = choice('frf-estimator', 'estimator', ['H1', 'H2', 'Hv'], 'H1: noise on the '
    + 'responses; H2: noise on the drive; Hv: both');
  const value = (label) => label.querySelector('select').value;
  const busy = (b) => { for (const x of buttons) x.disabled = b; };
  const progress = (job) => note(msg, `${job.status}${job.message ? `: ${job.message}` : ''}`, 'busy');

  async function open(n) {
    state.set = await api(`/spectra/frf/${encodeURIComponent(n)}`);
    state.name = n;
    state.sensor = state.set.sensors[0];
    state.modes = null;
    frfView(out);
  }
  async function modes() {
    const body = { frfsets: [state.name] };
    const b = band.value.trim();
    if (b) body.band = b.split(':').map(Number);
    state.modes = await runJob('/spectra/modes', '/spectra/jobs', body, progress);
    frfView(out);
  }
  const act = (fn) => async () => {
    busy(true);
    try {
      await fn();
      note(msg, '');
    } catch (err) {
      note(msg, err.message, 'error');
    } finally {
      busy(false);
    }
  };
  const compute = h('button', { id: 'frf-go', type: 'button', onclick: act(async () => {
    const chosen = picked(runs);
    const n = name.value.trim() || (chosen[0] ? `${chosen[0]}_frf` : '');
    if (!chosen.length) throw new Error('Tick at least one broadband run.');
    await runJob('/spectra/frf', '/spectra/jobs', { runs: chosen, name: n, overwrite: true,
      method: value(method), burst: value(burstMode), estimator: value(estimator) }, progress);
    if (![...stored.options].some((o) => o.value === n)) stored.append(h('option', { value: n }, n));
    stored.value = n;
    await open(n);
    await modes();
  }) }, 'FRFs and modes');
  const openBtn = h('button', { id: 'frf-open', type: 'button', class: 'secondary', onclick: act(async () => {
    if (!stored.value) throw new Error('Choose a stored FRF set.');
    await open(stored.value);
    if (token()) await modes();
  }) }, 'Open');
  const modesBtn = h('button', { id: 'frf-modes-go', type: 'button', class: 'secondary', onclick: act(async () => {
    if (!state.set) throw new Error('Open or compute an FRF set first.');
    await modes();
  }) }, 'Modes');

  const druns = picker(runList.items, 'distortion-runs');
  const dmsg = h('div', { id: 'distortion-msg' });
  const dout = h('div', {}, state.distortion ? distortionView(state.distortion) : '');
  const dgo = h('button', { id: 'distortion-go', type: 'button', onclick: async () => {
    const chosen = picked(druns);
    if (!chosen.length) { note(dmsg, 'Tick at least one steady-sine or multisine run.', 'error'); return; }
    dgo.disabled = true;
    try {
      state.distortion = await runJob('/spectra/distortion', '/spectra/jobs', { runs: chosen },
        (job) => note(dmsg, job.status, 'busy'));
      dout.replaceChildren(distortionView(state.distortion));
      note(dmsg, '');
    } catch (err) {
      note(dmsg, err.message, 'error');
    } finally {
      dgo.disabled = false;
    }
  } }, 'Distortion report');
  const buttons = [compute, openBtn, modesBtn];

  el.append(
    section('FRFs and modes',
      h('p', { class: 'note' }, 'H1 with coherence from broadband runs (random, burst, multisine, '
        + 'sweep), one level per run, stored in the frf/ folder; modes per level by LSCF/LSFD with '
        + 'half-power beside.'),
      h('h3', {}, 'broadband runs'), runs,
      h('div', { class: 'toolbar', id: 'frf-options' }, method, burstMode, estimator),
      h('div', { class: 'toolbar' }, name, compute, stored, openBtn, band, modesBtn), msg, out),
    section('Distortion report',
      h('p', { class: 'note' }, 'Harmonics h_k/h_1 of every channel of a steady sine (± one '
        + 'standard error from blocks of whole cycles); for a multisine the odd and even '
        + 'nonlinear distortion against the noise.'),
      druns, h('div', { class: 'toolbar' }, dgo), dmsg, dout));
  if (state.set) frfView(out);
  return { leave() {} };
}
