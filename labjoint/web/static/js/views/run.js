// A run: conditions, raw signals (decimated for the screen), the hysteresis loops of
// its steady cycles and both identification methods side by side (seed 002 Table 2).

import { api, runJob } from '../api.js';
import { h, note, section, table } from '../dom.js';
import { plotXY } from '../plot/plot.js';
import { display, fmt, pct, when } from '../units.js';
import { lastCycles, loopPlot, steadyLoops } from './loops.js';
import { identificationTable, slidingFraction } from './table2.js';
import { onPage } from '../words.js';

const SCREEN_POINTS = 1500;

function conditions(r, ch) {
  const md = r.metadata || {};
  const steady = md.steady || {};
  const wave = md.excitation && typeof md.excitation === 'object' && md.excitation.kind
    && md.excitation.kind !== 'sine' ? md.excitation : null;
  const band = wave && Array.isArray(wave.band_hz) ? ` from ${fmt(wave.band_hz[0])} Hz to ${fmt(wave.band_hz[1])} Hz` : '';
  const rows = [
    ['Status', h('span', { class: `status ${r.status}` }, r.status)],
    ['Plan', `${r.plan || '–'}${r.plan_step != null ? ` step ${r.plan_step}` : ''}`],
    ...(wave ? [['Excitation', `${wave.kind.replace('_', ' ')}${band}${wave.n_lines ? `, ${wave.n_lines} lines` : ''}: not a steady sine`],
      ['Repetition frequency', `${fmt(r.frequency_hz)} Hz (1 / period: the line spacing, not a drive frequency)`]]
      : [['Excitation frequency', `${fmt(r.frequency_hz)} Hz`]]),
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

// The raw signals over a time window [t0, t1] (s) of the run, fetched at screen
// resolution for that window: zoom (buttons or the mouse wheel) and pan (buttons or a
// drag) ask the server again, so a long run shows its cycles, not a solid band.
function rawSignals(name, into, duration, firstData = null) {
  const whole = [0, duration];
  let win = whole.slice();
  let asked = 0;
  const plots = h('div', { class: 'grid3', id: 'raw-plots' });
  const caption = h('p', { class: 'caption', id: 'raw-caption' });
  const span = h('span', { class: 'count', id: 'raw-window' });
  const set = (a, b) => {
    const w = Math.min(Math.max(b - a, Math.min(duration, 2e-3)), duration);
    a = Math.min(Math.max(a, 0), duration - w);
    win = [a, a + w];
    draw();
  };
  const zoom = (k, at = (win[0] + win[1]) / 2) => set(at - (at - win[0]) * k, at + (win[1] - at) * k);
  const pan = (k) => set(win[0] + k * (win[1] - win[0]), win[1] + k * (win[1] - win[0]));
  const btn = (id, label, title, fn) => h('button', { type: 'button', class: 'small secondary', id, title, onclick: fn }, label);
  const tools = h('div', { class: 'toolbar' },
    btn('raw-zoom-in', 'Zoom in', 'show half the time span', () => zoom(0.5)),
    btn('raw-zoom-out', 'Zoom out', 'show twice the time span', () => zoom(2)),
    btn('raw-left', '◀', 'earlier', () => pan(-0.5)), btn('raw-right', '▶', 'later', () => pan(0.5)),
    btn('raw-all', 'Whole run', 'the whole run', () => set(...whole)), span,
    h('span', { class: 'count' }, 'wheel: zoom at the pointer · drag: pan'));
  async function draw() {
    const ask = ++asked;
    const [a, b] = win;
    span.textContent = `${fmt(a, 4)}–${fmt(b, 4)} s of ${fmt(duration, 4)} s`;
    const reply = firstData || signalData(name, a, b);
    firstData = null;
    const data = await reply;
    if (ask !== asked) return;
    const ms = b - a < 2 ? 1e3 : 1;
    const t0 = (data.series[0]?.time_s || []).find((t) => t != null);
    const off = t0 == null ? 0 : t0 - data.start_sample / data.sample_rate_hz;   // the run's time origin
    plots.replaceChildren(...data.series.map((sr, i) => {
      const d = display(sr.unit);
      const svg = plotXY({
        id: `raw-${sr.name}`, height: 220, xlabel: ms > 1 ? 'time (ms)' : 'time (s)', ylabel: `${sr.name} (${d.unit})`,
        xdomain: [(a + off) * ms, (b + off) * ms],
        series: [{ x: sr.time_s.map((t) => (t == null ? null : t * ms)),
          y: sr.values.map((v) => (v == null ? null : v * d.k)), name: sr.name, legend: false, color: `hsl(${210 + 40 * i} 55% 38%)` }],
      });
      svg.dataset.window = `${a},${b}`;
      interact(svg, a, b);
      return h('figure', { class: 'small' }, svg);
    }));
    caption.textContent = data.decimated
      ? `Min/max decimated for the screen: ${data.bucket} samples per bucket, every peak kept. Zoom in to see every sample.`
      : 'Every sample of this span shown.';
  }
  // wheel zooms about the pointer, a drag pans (the frame spans 70 px to width - 14 px)
  function interact(svg, a, b) {
    const at = (ev) => {
      const r = svg.getBoundingClientRect();
      const W = svg.viewBox.baseVal.width;
      const px = ((ev.clientX - r.left) / r.width) * W;
      return a + ((px - 70) / (W - 84)) * (b - a);
    };
    svg.addEventListener('wheel', (ev) => { ev.preventDefault(); zoom(ev.deltaY < 0 ? 0.5 : 2, at(ev)); }, { passive: false });
    let from = null;
    svg.addEventListener('pointerdown', (ev) => { from = at(ev); });
    svg.addEventListener('pointerup', (ev) => {
      if (from == null) return;
      const d = from - at(ev);
      from = null;
      if (Math.abs(d) > (b - a) * 0.01) set(a + d, b + d);
    });
  }
  into.replaceChildren(tools, plots, caption);
  return draw();
}

function signalData(name, a, b) {
  return api(`/runs/${encodeURIComponent(name)}/data`,
    { query: { start: a, stop: b, max_points: SCREEN_POINTS } });
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

function identifySection(name, loopsP) {
  const out = h('div', { id: 'identification' });
  const msg = h('p', { hidden: true });
  const mu = h('input', { type: 'number', step: 'any', min: 0, max: 5, id: 'friction',
    placeholder: 'stored value', title: 'empty: the latest friction test stored on the server' });
  let measured = {};
  const render = (res) => {
    out.replaceChildren(!res ? h('p', { class: 'note' }, 'Not identified yet: start an analysis below.')
      : res.row.error ? h('p', { class: 'note error', id: 'identify-refused' }, `Refused: ${onPage(res.row.error)}`)
        : identificationTable(res.row, measured));
    if (res) out.append(h('p', { class: 'caption' }, `From the ${res.method} analysis finished ${when(res.finished)}.`));
  };
  async function start(method) {
    const options = method !== 'hysteresis' && mu.value !== '' ? { friction_coefficient: Number(mu.value) } : {};
    try {
      note(msg, 'Identifying…', 'busy');
      const result = await runJob('/analyses', '/analyses', { runs: [name], method, options },
        (job) => note(msg, `Identifying… ${Math.round(100 * job.progress)} % ${job.message || ''}`, 'busy'));
      const row = result.runs[0];
      render({ row, method, finished: new Date().toISOString() });
      note(msg, '');
    } catch (err) {
      note(msg, onPage(err.message), 'error');
    }
  }
  const bothBtn = h('button', { id: 'identify-both', onclick: () => start('both') }, 'Identify: both methods');
  const loopBtn = h('button', { class: 'secondary', onclick: () => start('hysteresis') }, 'Hysteresis loop only');
  // the measured loops say whether the joint slid as a whole (a plateau), which the
  // stick-slip model's macro-slip fraction is checked against
  const measuredP = Promise.resolve(loopsP).then((b) => { measured = { sliding: b ? slidingFraction(b.cycles) : null }; },
    () => {});
  Promise.all([latestAnalysis(name), measuredP]).then(([res]) => render(res), (err) => note(msg, err.message, 'error'));
  return section('Identification: both methods (seed 002 Table 2)', out, msg,
    h('div', { class: 'toolbar' }, h('label', { class: 'field inline' }, h('span', {}, 'Friction coefficient μ'), mu),
      bothBtn, loopBtn));
}

const LOOP_CYCLES = 8;

// A finished run: its last steady cycles as the loop pipeline found them, and their
// energy loss and stiffness.
// How the run ended, in words, when it did not end as planned (null when it did).
export function stateNote(rec, ch) {
  const upTo = `${ch.n_samples} samples (${fmt(ch.duration_s, 3)} s)`;
  if (rec.status === 'aborted') {
    return `Aborted: the recording was stopped before its plan ended (emergency stop, a limit or a cancel); it holds the first ${upTo}, everything recorded until then.`;
  }
  if (rec.status === 'limit') return `Stopped by a safety limit after ${upTo}: everything recorded until then.`;
  if (rec.status === 'incomplete') {
    return `Incomplete: the recording ended without being closed (the recording process stopped); it was closed afterwards with the ${upTo} on disk.`;
  }
  if (rec.status === 'failed') return `Failed after ${upTo}: what was recorded is shown.`;
  return null;
}

// The cycles the run holds (duration x frequency) and the whole ones the loop pipeline
// cuts between upward zero crossings of the displacement's fundamental.
function cycleCount(body, ch) {
  const f = body.frequency_hz;
  const recorded = f && ch.duration_s ? ch.duration_s * f : null;
  const rec = recorded == null ? '' : `${fmt(recorded, 4)} cycles recorded (${fmt(ch.duration_s, 3)} s at ${fmt(f)} Hz); `;
  return `${rec}${body.n_cycles} whole cycles between upward zero crossings of the displacement `
    + `(a recording that starts and ends mid-cycle has one fewer whole cycle than it holds)`;
}

// Channels that sat at their input range, in words (null when none did).
export function clippedNote(clipped) {
  if (!clipped || !clipped.length) return null;
  const each = clipped.map((c) => `${c.channel} sat at ${fmt(c.level, 4)} ${c.unit} `
    + `(flat tops over ${fmt(100 * c.fraction, 2)} % of the samples)`);
  return `Clipped: ${each.join('; ')}. Its input range was exceeded: a loop, energy loss, `
    + 'stiffness or friction coefficient taken from it would be wrong. Record it again with a larger input range.';
}

async function steadyLoopsSection(name, ch, asked, title, top) {
  const body = await asked;
  const n = body.cycles.length;
  const clip = clippedNote(body.clipped);
  if (clip) top.replaceChildren(h('p', { class: 'note error', id: 'run-clipped' }, clip));
  if (body.refused) {
    title.textContent = 'Hysteresis loops: refused';
    return [h('p', { class: 'note error', id: 'loop-refused', 'data-field': body.refused },
      `No loop is drawn and no energy loss or stiffness quoted: ${onPage(body.reason)}`)];
  }
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
    h('p', { class: 'caption', id: 'loop-caption' }, `${cycleCount(body, ch)}. Drawn: the last ${n} of the ${body.n_steady} steady ones `
      + `(cycles ${body.steady_start}–${body.steady_stop - 1}, counting from 0), `
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
  const recP = api(`/runs/${encodeURIComponent(name)}`);
  const chP = api(`/runs/${encodeURIComponent(name)}/channels`);
  // the loops and the signals are asked for as soon as what they need is in
  const loopsP = recP.then((r) => (r.status === 'running' ? null : steadyLoops(name, LOOP_CYCLES)));
  const dataP = chP.then((c) => signalData(name, 0, c.duration_s));
  loopsP.catch(() => {});
  dataP.catch(() => {});
  const [rec, ch] = await Promise.all([recP, chP]);
  const raw = h('div', { id: 'raw' }, h('p', { class: 'note busy' }, 'Loading signals…'));
  const loops = h('div', { id: 'loops' }, h('p', { class: 'note busy' }, 'Finding the steady cycles…'));
  const state = stateNote(rec, ch);
  const loopsTitle = h('h2', { id: 'loops-title' }, 'Hysteresis loops of the steady cycles');
  const top = h('div', { id: 'run-warnings' });
  el.append(h('h1', {}, name), ...(state ? [h('p', { class: 'note error', id: 'run-state' }, state)] : []), top,
    h('div', { class: 'grid2' }, section('Conditions', conditions(rec, ch),
      rec.status !== 'running' ? h('p', {}, h('a', { href: `/api/v1/runs/${encodeURIComponent(name)}/file`, download: `${name}.h5` }, 'Download the HDF5 run file')) : null),
    h('section', { class: 'card' }, loopsTitle, loops)),
    identifySection(name, loopsP),
    section('Raw signals', raw));
  rawSignals(name, raw, ch.duration_s, dataP).catch((err) => raw.replaceChildren(h('p', { class: 'note error' }, err.message)));
  const pending = rec.status === 'running' ? recordedLoops(name, rec, ch) : steadyLoopsSection(name, ch, loopsP, loopsTitle, top);
  pending.then((parts) => loops.replaceChildren(...parts.filter(Boolean)))
    .catch((err) => loops.replaceChildren(h('p', { class: 'note error' }, err.message)));
  return null;
}
