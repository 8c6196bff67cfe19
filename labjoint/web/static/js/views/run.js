// A run: conditions, raw signals (decimated for the screen), the hysteresis loops of
// its steady cycles and both identification methods side by side (seed 002 Table 2).

import { api, runJob } from '../api.js';
import { h, note, section, table } from '../dom.js';
import { plotXY } from '../plot/plot.js';
import { display, fmt, pct, when } from '../units.js';
import { lastCycles, loopPlot, steadyLoops } from './loops.js';
import { identificationTable } from './table2.js';

const SCREEN_POINTS = 1500;

function conditions(r, ch) {
  const md = r.metadata || {};
  const steady = md.steady || {};
  const rows = [
    ['Status', h('span', { class: `status ${r.status}` }, r.status)],
    ['Plan', `${r.plan || '–'}${r.plan_step != null ? ` step ${r.plan_step}` : ''}`],
    ['Excitation frequency', `${fmt(r.frequency_hz)} Hz`],
    ['Excitation amplitude', `${fmt(r.excitation_vpp)} Vpp`],
    ['Bolt torque', `${fmt(r.torque_nm)} N m`],
    ['Normal force', `${fmt(r.normal_force_n)} N`],
    ['Sample rate', `${fmt(r.sample_rate_hz)} S/s`],
    ['Samples', `${ch.n_samples} (${fmt(ch.duration_s, 3)} s)`],
    ['Steady state before recording', steady.reached == null ? '–'
      : `${steady.reached ? 'reached' : 'NOT reached'} after ${steady.cycles} cycles (drift ${pct(100 * steady.drift)})`],
    ['Started', when(r.start_time)], ['Ended', when(r.end_time)], ['Source', r.source || '–'],
  ];
  return table(['', ''], rows, { class: 'kv' });
}

async function rawSignals(name, into) {
  const data = await api(`/runs/${encodeURIComponent(name)}/data`, { query: { max_points: SCREEN_POINTS } });
  const plots = data.series.map((sr, i) => {
    const d = display(sr.unit);
    return h('figure', { class: 'small' }, plotXY({
      id: `raw-${sr.name}`, height: 220, xlabel: 'time (ms)', ylabel: `${sr.name} (${d.unit})`,
      series: [{ x: sr.time_s.map((t) => (t == null ? null : t * 1e3)),
        y: sr.values.map((v) => (v == null ? null : v * d.k)), name: sr.name, legend: false, color: `hsl(${210 + 40 * i} 55% 38%)` }],
    }));
  });
  into.replaceChildren(h('div', { class: 'grid3' }, plots), h('p', { class: 'caption' }, data.decimated
    ? `Min/max decimated for the screen: ${data.bucket} samples per bucket, every peak kept.`
    : 'Every sample shown.'));
}

async function latestAnalysis(name) {
  const jobs = await api('/analyses', { query: { status: 'complete', limit: 200 } });
  const mine = jobs.items.filter((j) => (j.request.runs || []).includes(name));
  mine.sort((a, b) => (a.finished_at < b.finished_at ? 1 : -1));
  const both = mine.find((j) => j.request.method === 'both');
  const job = both || mine[0];
  if (!job) return null;
  const row = job.result.runs.find((x) => x.run === name);
  return row ? { row, method: job.request.method, finished: job.finished_at } : null;
}

function identifySection(name) {
  const out = h('div', { id: 'identification' });
  const msg = h('p', { hidden: true });
  const mu = h('input', { type: 'number', step: 'any', min: 0, max: 5, id: 'friction',
    placeholder: 'stored value', title: 'empty: the latest friction test stored on the server' });
  const render = (res) => {
    out.replaceChildren(res ? identificationTable(res.row)
      : h('p', { class: 'note' }, 'Not identified yet: start an analysis below.'));
    if (res) out.append(h('p', { class: 'caption' }, `From the ${res.method} analysis finished ${when(res.finished)}.`));
  };
  async function start(method) {
    const options = method !== 'hysteresis' && mu.value !== '' ? { friction_coefficient: Number(mu.value) } : {};
    try {
      note(msg, 'Identifying…', 'busy');
      const result = await runJob('/analyses', '/analyses', { runs: [name], method, options },
        (job) => note(msg, `Identifying… ${Math.round(100 * job.progress)} % ${job.message || ''}`, 'busy'));
      const row = result.runs[0];
      if (row.error) throw new Error(row.error);
      render({ row, method, finished: new Date().toISOString() });
      note(msg, '');
    } catch (err) {
      note(msg, err.message, 'error');
    }
  }
  const bothBtn = h('button', { id: 'identify-both', onclick: () => start('both') }, 'Identify: both methods');
  const loopBtn = h('button', { class: 'secondary', onclick: () => start('hysteresis') }, 'Hysteresis loop only');
  latestAnalysis(name).then(render, (err) => note(msg, err.message, 'error'));
  return section('Identification: both methods (seed 002 Table 2)', out, msg,
    h('div', { class: 'toolbar' }, h('label', { class: 'field inline' }, h('span', {}, 'Friction coefficient μ'), mu),
      bothBtn, loopBtn));
}

const LOOP_CYCLES = 8;

// A finished run: its last steady cycles as the loop pipeline found them, and their
// energy loss and stiffness.
async function steadyLoopsSection(name) {
  const body = await steadyLoops(name, LOOP_CYCLES);
  const n = body.cycles.length;
  if (!n) {
    return [loopPlot(body, { id: 'loop' }), h('p', { class: 'note', id: 'loop-reason' },
      `No steady cycle to draw. ${body.reason || ''}`)];
  }
  const sm = body.summary || {};
  const sc = (v, f) => (v == null ? null : v * f);
  const pm = (k, f) => `${fmt(sc(sm[k], f), 3)} ± ${fmt(sc(sm[`${k}_std`], f), 2)}`;
  const below = 'below resolution';
  const rows = body.cycles.map((c) => [String(c.index),
    c.below_resolution ? below : fmt(sc(c.energy_loss_j, 1e3)),
    c.below_resolution ? below : fmt(c.damping_ns_per_m), fmt(sc(c.stiffness_n_per_m, 1e-6))]);
  const wText = sm.below_resolution
    ? `energy loss below resolution (under ${fmt(sc(sm.energy_loss_j_resolution, 1e3), 2)} mJ: `
      + 'sensor phase and cycle-to-cycle scatter; not a result)'
    : `energy loss ${pm('energy_loss_j', 1e3)} mJ (uncertainty of the mean `
      + `${fmt(sc(sm.energy_loss_j_uncertainty, 1e3), 2)} mJ)`;
  return [loopPlot(body, { id: 'loop' }),
    h('p', { class: 'caption' }, `The last ${n} of ${body.n_steady} steady cycles `
      + `(cycles ${body.steady_start}–${body.steady_stop - 1} of ${body.n_cycles} are steady), `
      + `low-passed at ${fmt(body.cutoff_hz)} Hz as the loop pipeline does; darker is later. `
      + `Over every steady cycle: ${wText}, `
      + `stiffness ${pm('stiffness_n_per_m', 1e-6)} MN/m.`),
    (body.warnings || []).length ? h('p', { class: 'note' }, body.warnings.join(' ')) : null,
    h('details', {}, h('summary', {}, 'Per cycle'),
      table(['Cycle', 'Energy loss (mJ)', 'Damping (Ns/m)', 'Stiffness (MN/m)'], rows, { id: 'loop-cycles' }))];
}

// A run being recorded: its last cycles straight from the samples (the live view's way).
async function recordedLoops(name, rec, ch) {
  const f = rec.frequency_hz || (rec.metadata.generator || {}).frequency_hz;
  const lc = await lastCycles(name, ch.n_samples, ch.sample_rate_hz, f);
  return [loopPlot(lc, { id: 'loop' }), h('p', { class: 'caption' }, lc
    ? `Still recording: the last ${lc.cycles} cycles as recorded so far (unfiltered); darker is later.`
    : 'Too few samples for a whole cycle.')];
}

export async function show(el, routeInfo) {
  const name = routeInfo.arg;
  const [rec, ch] = await Promise.all([api(`/runs/${encodeURIComponent(name)}`),
    api(`/runs/${encodeURIComponent(name)}/channels`)]);
  const raw = h('div', { id: 'raw' }, h('p', { class: 'note busy' }, 'Loading signals…'));
  const loops = h('div', { id: 'loops' }, h('p', { class: 'note busy' }, 'Finding the steady cycles…'));
  el.append(h('h1', {}, name),
    h('div', { class: 'grid2' }, section('Conditions', conditions(rec, ch),
      rec.status !== 'running' ? h('p', {}, h('a', { href: `/api/v1/runs/${encodeURIComponent(name)}/file`, download: `${name}.h5` }, 'Download the HDF5 run file')) : null),
    section('Hysteresis loops of the steady cycles', loops)),
    identifySection(name),
    section('Raw signals', raw));
  rawSignals(name, raw).catch((err) => raw.replaceChildren(h('p', { class: 'note error' }, err.message)));
  const pending = rec.status === 'running' ? recordedLoops(name, rec, ch) : steadyLoopsSection(name);
  pending.then((parts) => loops.replaceChildren(...parts.filter(Boolean)))
    .catch((err) => loops.replaceChildren(h('p', { class: 'note error' }, err.message)));
  return null;
}
