// Reprocess: rerun a pipeline over the catalogued runs a filter selects, as a job of the
// service (on its Dask cluster or in process); progress while it runs, cancel between
// tasks, then each run's outcome. Runs whose result is current are skipped.

import { api, needToken } from '../api.js';
import { h, note, section, table } from '../dom.js';

const PIPELINES = ['analyze', 'stickslip', 'fit', 'diagnose', 'ladder'];
const state = { job: null };
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

function body(form) {
  const b = { pipeline: form.pipeline.value, recompute: form.recompute.checked, query: {}, options: {} };
  const torque = form.torque.value.trim();
  if (torque) b.query.torque_nm = Number(torque);
  if (['fit', 'diagnose', 'ladder'].includes(b.pipeline)) {
    b.options.model = form.model.value.trim();
    if (form.groupBy.value.trim()) b.group_by = form.groupBy.value.trim();
  }
  return b;
}

function report(res) {
  const rows = res.runs.map((r) => [r.run, r.group || '–', r.status === 'not_applicable' ? 'not applicable' : r.status, r.error || '']);
  return h('div', { id: 'reprocess-report' },
    h('p', { id: 'reprocess-summary' }, `${res.computed} computed, ${res.skipped} skipped (current), `
      + `${res.not_applicable ?? 0} not applicable (not what ${res.pipeline} handles), `
      + `${res.failed} failed · pipeline version ${res.version}`),
    h('div', { class: 'scroll' }, table(['run', 'group', 'status', 'reason'], rows, { id: 'reprocess-runs' })));
}

export async function show(el) {
  const form = {
    pipeline: h('select', { id: 'reprocess-pipeline' }, PIPELINES.map((p) => h('option', { value: p }, p))),
    torque: h('input', { id: 'reprocess-torque', size: 6, placeholder: 'all' }),
    model: h('input', { id: 'reprocess-model', value: 'linear_stiffness+viscous', size: 40 }),
    groupBy: h('input', { id: 'reprocess-group-by', placeholder: 'e.g. torque_nm', size: 14 }),
    recompute: h('input', { id: 'reprocess-recompute', type: 'checkbox' }),
  };
  const msg = h('div', { id: 'reprocess-msg' });
  const bar = h('progress', { id: 'reprocess-progress', max: 1, value: 0 });
  const out = h('div', { id: 'reprocess-out' });
  const go = h('button', { id: 'reprocess-go', type: 'button' }, 'Reprocess');
  const stop = h('button', { id: 'reprocess-cancel', type: 'button', disabled: true }, 'Cancel');
  stop.addEventListener('click', async () => {
    if (!state.job) return;
    try {
      await api(`/reprocess/${state.job}/cancel`, { method: 'POST' });
      note(msg, 'cancelling: the tasks running finish, no more start');
    } catch (err) { note(msg, err.message, 'error'); }
  });
  go.addEventListener('click', async () => {
    go.disabled = true;
    out.replaceChildren();
    try {
      needToken();
      let job = await api('/reprocess', { method: 'POST', body: body(form) });
      state.job = job.id;
      stop.disabled = false;
      while (job.status === 'queued' || job.status === 'running') {
        bar.value = job.progress;
        note(msg, `${job.status} ${Math.round(100 * job.progress)} %${job.message ? `: ${job.message}` : ''}`, 'busy');
        await sleep(300);
        job = await api(`/reprocess/${job.id}`);
      }
      bar.value = job.progress;
      if (job.status === 'complete') {
        note(msg, 'done');
        out.replaceChildren(report(job.result));
      } else {
        note(msg, job.status === 'cancelled' ? 'cancelled' : (job.error || {}).message || job.status,
          job.status === 'cancelled' ? 'info' : 'error');
      }
    } catch (err) {
      note(msg, err.message, 'error');
    } finally {
      go.disabled = false;
      stop.disabled = true;
      state.job = null;
    }
  });
  el.append(section('Reprocess the archive',
    h('p', { class: 'note' }, 'Runs a pipeline over the catalogued runs (all, or one torque); a run '
      + 'whose result was made by the current code with the same options is skipped.'),
    h('label', {}, 'pipeline ', form.pipeline), h('label', {}, ' torque (N m) ', form.torque),
    h('label', {}, ' model ', form.model), h('label', {}, ' one group per ', form.groupBy),
    h('label', {}, form.recompute, ' recompute current results'),
    h('div', {}, go, stop, bar), msg), out);
}
