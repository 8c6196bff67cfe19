// Live: while the daemon records, the current loop updating, the plan's progress, the
// generator state, and the emergency stop (needs the control token).

import { api, needToken } from '../api.js';
import { h, note, section, table } from '../dom.js';
import { fmt, when } from '../units.js';
import { lastCycles, loopPlot } from './loops.js';

const POLL_MS = 700;
const LOOP_CYCLES = 4;

function planForm(types, msg) {
  const sel = h('select', { id: 'plan-type' }, types.map((t) => h('option', { value: t.name }, t.name)));
  const params = h('textarea', { id: 'plan-params', rows: 6, spellcheck: 'false' });
  const desc = h('p', { class: 'caption' });
  const fill = () => {
    const t = types.find((x) => x.name === sel.value);
    if (!t) return;
    const o = {};
    for (const [k, p] of Object.entries(t.parameters)) o[k] = p.default;
    params.value = JSON.stringify(o, null, 1);
    desc.textContent = `${t.description} Parameters in SI units (Hz, Vpp, N m); null marks a required one.`;
  };
  sel.addEventListener('change', fill);
  fill();
  const submit = h('button', { id: 'plan-submit', type: 'submit' }, 'Queue plan');
  const form = h('form', {}, h('div', { class: 'toolbar' }, h('label', { class: 'field inline' }, h('span', {}, 'Plan'), sel), submit),
    params, desc);
  form.addEventListener('submit', async (ev) => {
    ev.preventDefault();
    try {
      needToken();
      let parameters;
      try {
        parameters = JSON.parse(params.value || '{}');
      } catch (err) {
        throw new Error(`parameters are not valid JSON: ${err.message}`);
      }
      for (const [k, v] of Object.entries(parameters)) if (v === null) delete parameters[k];
      const job = await api('/plans', { method: 'POST', body: { plan: sel.value, parameters } });
      note(msg, `Plan ${job.plan.plan} queued as job ${job.id}.`, 'ok');
    } catch (err) {
      note(msg, err.message, 'error');
    }
  });
  return form;
}

function rigTable(rig) {
  const d = rig.daemon || {};
  const g = d.generator || {};
  return table(['', ''], [
    ['Mode', `${rig.mode}${rig.backend ? ` (${rig.backend} rig)` : ''}`],
    ['Daemon', d.state || '–'],
    ['Generator', g.frequency_hz != null ? `${fmt(g.frequency_hz)} Hz, ${fmt(g.amplitude_vpp)} Vpp` : '–'],
    ['Output', h('strong', { id: 'output-state', class: g.output ? 'verdict bad' : 'verdict good' },
      g.output == null ? 'unknown' : g.output ? 'ON' : 'off')],
    ['Recording', d.run ? `${d.run} (${d.run_status || '–'}, ${d.samples} samples)` : '–'],
    ['Last error', d.last_error || '–'],
  ], { class: 'kv', id: 'rig-state' });
}

function jobView(job, onTorque, onResume, onCancel) {
  if (!job) return h('p', { class: 'note' }, 'No plan yet.');
  const pc = Math.round(100 * (job.progress || 0));
  const bar = h('div');
  bar.style.width = `${pc}%`; // CSSOM, allowed by the page's style-src 'self'
  const parts = [h('p', {}, h('strong', {}, job.plan.plan), ` job ${job.id} · `,
    h('span', { class: `status ${job.status}`, id: 'plan-status' }, job.status), ` · ${pc} % · ${job.message || ''}`),
  h('div', { class: 'progress', role: 'progressbar', 'aria-valuenow': pc, 'aria-valuemin': 0, 'aria-valuemax': 100, id: 'plan-progress' },
    bar)];
  if (job.status === 'waiting_torque' && job.waiting_for) {
    const t = h('input', { type: 'number', step: 'any', min: 0, value: job.waiting_for.torque_nm ?? '' });
    parts.push(h('p', { class: 'note busy' }, `Set the bolt torque to ${fmt(job.waiting_for.torque_nm)} N m, then confirm: `,
      t, ' ', h('button', { class: 'small', onclick: () => onTorque(job.id, Number(t.value)) }, 'Torque applied')));
  }
  if (job.status === 'held') {
    parts.push(h('p', { class: 'note busy' }, 'Held by an emergency stop: it starts only when you resume it. ',
      h('button', { class: 'small', id: 'plan-resume', onclick: () => onResume(job.id) }, 'Resume'), ' ',
      h('button', { class: 'small secondary', id: 'plan-cancel', onclick: () => onCancel(job.id) }, 'Cancel')));
  }
  if (job.error) parts.push(h('p', { class: 'note error' }, job.error));
  if (job.runs && job.runs.length) {
    parts.push(h('p', {}, 'Runs recorded: ', job.runs.map((r, i) => [i ? ', ' : '', h('a', { href: `#/run/${encodeURIComponent(r)}` }, r)])));
  }
  parts.push(h('p', { class: 'caption' }, `submitted ${when(job.submitted_at)}${job.finished_at ? `, finished ${when(job.finished_at)}` : ''}`));
  return h('div', {}, parts);
}

// Every job that is not over (held by an e-stop, queued, running, waiting for a torque)
// and the last few that are, aborted ones with the runs they recorded: one row each,
// with Resume (held) and Cancel (not over) buttons.
const ACTIVE = ['running', 'waiting_torque', 'held', 'queued'];
const RECENT = 10;

async function allJobs() {
  const lists = await Promise.all([...ACTIVE.map((status) => api('/plans', { query: { status, limit: 200 } })),
    api('/plans', { query: { limit: RECENT } })]);
  const seen = new Map();
  for (const l of lists) for (const j of l.items) seen.set(j.id, j);
  const rank = (j) => (ACTIVE.includes(j.status) ? ACTIVE.indexOf(j.status) : ACTIVE.length);
  return [...seen.values()].sort((a, b) => rank(a) - rank(b)
    || (a.submitted_at < b.submitted_at ? 1 : a.submitted_at > b.submitted_at ? -1 : 0));
}

function jobsTable(jobs, onResume, onCancel) {
  if (!jobs.length) return h('p', { class: 'note' }, 'No plan yet.');
  const rows = jobs.map((j) => h('tr', { 'data-job': j.id, 'data-status': j.status },
    h('td', {}, h('span', { class: `status ${j.status}` }, j.status)),
    h('td', { class: 'actions' },
      j.status === 'held' ? h('button', { class: 'small', 'data-action': 'resume', onclick: () => onResume(j.id) }, 'Resume') : null,
      ACTIVE.includes(j.status) ? h('button', { class: 'small secondary', 'data-action': 'cancel', onclick: () => onCancel(j.id) }, 'Cancel') : null),
    h('td', {}, h('strong', {}, j.plan.plan), h('br'), h('span', { class: 'count' }, j.id)),
    h('td', { class: 'num' }, `${Math.round(100 * (j.progress || 0))} %`),
    h('td', { class: 'runs-cell' }, (j.runs || []).length
      ? j.runs.map((r, i) => [i ? ', ' : '', h('a', { href: `#/run/${encodeURIComponent(r)}` }, r)])
      : '–', j.error ? h('div', { class: 'caption' }, j.error) : null)));
  return h('div', { class: 'scroll' }, table(['Status', '', 'Plan', 'Done', 'Runs'], rows, { id: 'jobs-table', class: 'jobs' }));
}

export async function show(el) {
  let alive = true;
  let timer = null;
  const runInfo = new Map();
  const msg = h('p', { hidden: true, id: 'live-msg' });
  const banner = h('div', { class: 'banner', hidden: true, id: 'estop-banner' });
  const rigBox = h('div');
  const jobBox = h('div', { id: 'plan-box' });
  const jobsBox = h('div', { id: 'jobs' });
  const loopBox = h('div', { id: 'live-loop' }, loopPlot(null, { id: 'live-loop-plot' }));
  const loopCaption = h('p', { class: 'caption', id: 'live-caption' }, 'Nothing recorded yet.');
  const clearBtn = h('button', { class: 'secondary', id: 'estop-clear', type: 'button', hidden: true }, 'Clear the emergency stop');
  const types = await api('/plan-types').catch(() => []);

  clearBtn.addEventListener('click', async () => {
    try {
      needToken();
      await api('/estop/clear', { method: 'POST' });
      note(msg, 'Emergency stop cleared: plans it held wait until you resume or cancel them.', 'ok');
      window.dispatchEvent(new Event('labjoint:estop-cleared'));
    } catch (err) {
      note(msg, err.message, 'error');
    }
  });
  async function onResume(id) {
    try {
      needToken();
      await api(`/plans/${id}/resume`, { method: 'POST' });
      note(msg, `Job ${id} resumed: back in the queue.`, 'ok');
    } catch (err) {
      note(msg, err.message, 'error');
    }
  }
  async function onCancel(id) {
    try {
      needToken();
      await api(`/plans/${id}/cancel`, { method: 'POST' });
      note(msg, `Job ${id} cancelled.`, 'ok');
    } catch (err) {
      note(msg, err.message, 'error');
    }
  }
  async function onTorque(id, torque) {
    try {
      needToken();
      await api(`/plans/${id}/torque`, { method: 'POST', body: { torque_nm: torque } });
    } catch (err) {
      note(msg, err.message, 'error');
    }
  }

  async function info(name) {
    if (!runInfo.has(name)) runInfo.set(name, await api(`/runs/${encodeURIComponent(name)}`));
    return runInfo.get(name);
  }

  async function drawLoop(d) {
    const name = d.run;
    const rec = await info(name);
    const ch = await api(`/runs/${encodeURIComponent(name)}/channels`);
    const f = rec.frequency_hz || (d.generator || {}).frequency_hz;
    const lc = await lastCycles(name, ch.n_samples, ch.sample_rate_hz, f, LOOP_CYCLES);
    if (!alive) return;
    const plot = loopPlot(lc, { id: 'live-loop-plot' });
    plot.dataset.samples = String(ch.n_samples);
    loopBox.replaceChildren(plot);
    loopCaption.textContent = `${name}: last ${lc ? lc.cycles : 0} cycles up to sample ${ch.n_samples} `
      + `(${fmt(ch.n_samples / ch.sample_rate_hz, 3)} s), ${d.run_status === 'running' ? 'recording' : d.run_status}.`;
  }

  let lastDrawn = null;
  let lastRun = null;
  let lastJobs = null;
  async function poll() {
    try {
      const rig = await api('/rig');
      const d = rig.daemon || {};
      banner.hidden = !rig.estop;
      banner.textContent = rig.estop ? `Emergency stop active: ${rig.estop}` : '';
      clearBtn.hidden = !rig.estop;
      rigBox.replaceChildren(rigTable(rig));
      if (rig.mode !== 'none') {
        const job = d.job ? await api(`/plans/${d.job}`) : (await api('/plans', { query: { limit: 1 } })).items[0];
        jobBox.replaceChildren(jobView(job, onTorque, onResume, onCancel));
        const jobs = await allJobs();
        const jobsKey = JSON.stringify(jobs.map((j) => [j.id, j.status, Math.round(100 * (j.progress || 0)), j.runs, j.error]));
        if (jobsKey !== lastJobs) jobsBox.replaceChildren(jobsTable(jobs, onResume, onCancel));
        lastJobs = jobsKey;
      } else {
        jobBox.replaceChildren(h('p', { class: 'note' }, 'This service runs without a daemon: nothing to watch.'));
      }
      const key = d.run ? `${d.run}:${d.samples}:${d.run_status}` : null;
      if (d.run && key !== lastDrawn) {
        await drawLoop(d);
        lastDrawn = key;
        lastRun = d.run;
      } else if (!d.run && lastRun) {
        loopCaption.textContent = `${lastRun}: the last loop drawn; nothing is recording now.`;
        lastRun = null;
      }
    } catch (err) {
      note(msg, `Live view: ${err.message}`, 'error');
    }
    if (alive) timer = setTimeout(poll, POLL_MS);
  }

  el.append(h('h1', {}, 'Live'), banner,
    h('div', { class: 'card live-top' }, clearBtn, msg),
    h('div', { class: 'grid2' }, section('Current loop', loopBox, loopCaption),
      h('div', {}, section('Plan', jobBox), section('Rig', rigBox))),
    section('Jobs: held, queued, running, and the latest ended', jobsBox),
    section('Queue a plan', planForm(types, msg)));
  poll();
  return { leave: () => { alive = false; clearTimeout(timer); } };
}
