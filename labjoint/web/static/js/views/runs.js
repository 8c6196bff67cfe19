// Runs: the catalog with filters (plan, frequency, amplitude, torque, status, date),
// a page at a time; tick runs to compare models on them.

import { api } from '../api.js';
import { clear, h, note } from '../dom.js';
import { fmt, when } from '../units.js';

const STATUSES = ['', 'complete', 'running', 'failed', 'aborted', 'limit', 'incomplete'];
const PAGE = 50;
const SELECTED = 'labjoint.selected';

export function selectedRuns() {
  try {
    return JSON.parse(sessionStorage.getItem(SELECTED) || '[]');
  } catch {
    return [];
  }
}

export function setSelectedRuns(names) {
  sessionStorage.setItem(SELECTED, JSON.stringify([...new Set(names)]));
}

function field(label, input) {
  return h('label', { class: 'field' }, h('span', {}, label), input);
}

function filtersForm(query, plans, onSubmit) {
  const v = (k) => query.get(k) || '';
  const form = h('form', { class: 'filters', id: 'run-filters' },
    field('Name contains', h('input', { name: 'search', type: 'search', value: v('search'), size: 16 })),
    field('Plan', h('select', { name: 'plan' }, h('option', { value: '' }, 'any'),
      plans.map((p) => h('option', { value: p, selected: v('plan') === p }, p)))),
    field('Frequency (Hz)', h('input', { name: 'frequency_hz', type: 'number', step: 'any', min: 0, value: v('frequency_hz') })),
    field('Amplitude from (Vpp)', h('input', { name: 'vpp_min', type: 'number', step: 'any', min: 0, value: v('vpp_min') })),
    field('to (Vpp)', h('input', { name: 'vpp_max', type: 'number', step: 'any', min: 0, value: v('vpp_max') })),
    field('Torque (N m)', h('input', { name: 'torque_nm', type: 'number', step: 'any', min: 0, value: v('torque_nm') })),
    field('Status', h('select', { name: 'status' },
      STATUSES.map((s) => h('option', { value: s, selected: v('status') === s }, s || 'any')))),
    field('Started from', h('input', { name: 'since', type: 'date', value: v('since') })),
    field('until', h('input', { name: 'until', type: 'date', value: v('until') })),
    h('div', { class: 'buttons' }, h('button', { type: 'submit' }, 'Filter'),
      h('button', { type: 'reset', class: 'secondary' }, 'Clear')));
  form.addEventListener('submit', (ev) => {
    ev.preventDefault();
    const q = new URLSearchParams();
    for (const [k, val] of new FormData(form)) if (val !== '') q.set(k, val);
    onSubmit(q);
  });
  form.addEventListener('reset', () => setTimeout(() => onSubmit(new URLSearchParams()), 0));
  return form;
}

// Dates from the form are whole days: 'until' includes that day.
function apiQuery(query) {
  const q = Object.fromEntries(query);
  if (q.until && /^\d{4}-\d{2}-\d{2}$/.test(q.until)) q.until += 'T23:59:59';
  return q;
}

// A run's latest stored loop result in words: analysed, not applicable or refused (why).
export function resultText(res) {
  if (!res || !res.status) return 'not analysed';
  if (res.status === 'complete') return res.below_resolution ? 'analysed: W below resolution' : 'analysed';
  const why = (res.error || '').replace(/^[^:]*'[^']*': /, '');
  const short = why.length > 90 ? `${why.slice(0, 90)}…` : why;
  return res.status === 'not_applicable' ? `not applicable: ${short}` : `refused: ${short}`;
}

function row(r, selected) {
  const box = h('input', { type: 'checkbox', checked: selected.has(r.name), 'aria-label': `select ${r.name}` });
  box.addEventListener('change', () => {
    const cur = new Set(selectedRuns());
    if (box.checked) cur.add(r.name); else cur.delete(r.name);
    setSelectedRuns([...cur]);
    document.dispatchEvent(new CustomEvent('labjoint:selection'));
  });
  const dur = r.n_samples && r.sample_rate_hz ? r.n_samples / r.sample_rate_hz : null;
  const res = r.result || {};
  const ok = res.status === 'complete';
  const below = ok && res.below_resolution;
  return h('tr', { 'data-run': r.name },
    h('td', {}, box),
    h('td', {}, h('a', { href: `#/run/${encodeURIComponent(r.name)}` }, r.name)),
    h('td', {}, r.plan || '–', r.plan_step != null ? ` #${r.plan_step}` : ''),
    h('td', { class: 'num' }, fmt(r.frequency_hz)),
    h('td', { class: 'num' }, fmt(r.excitation_vpp)),
    h('td', { class: 'num' }, fmt(r.torque_nm)),
    h('td', { class: 'num' }, dur == null ? '–' : fmt(dur, 3)),
    h('td', {}, h('span', { class: `status ${r.status}` }, r.status || '–')),
    h('td', { class: 'num' }, ok && !below ? fmt(res.energy_loss_j * 1e3) : '–'),
    h('td', { class: 'num' }, ok && !below ? fmt(res.damping_ns_per_m) : '–'),
    h('td', { class: 'num' }, ok ? fmt(res.stiffness_n_per_m * 1e-6) : '–'),
    h('td', { class: 'result', 'data-result': res.status || 'none', title: res.error || '' }, resultText(res)),
    h('td', {}, when(r.start_time)));
}

export async function show(el, routeInfo) {
  const query = routeInfo.query;
  const msg = h('p', { hidden: true });
  const body = h('tbody', { id: 'runs-body' });
  const more = h('button', { class: 'secondary', hidden: true }, 'More runs');
  const count = h('span', { class: 'count' });
  const compare = h('button', { id: 'compare-selected' }, 'Compare models on ticked runs');
  const selCount = h('span', { class: 'count' });
  let offset = 0;
  const listPage = () => api('/runs', { query: { ...apiQuery(query), order: '-start_time', limit: PAGE, offset } });
  let first = listPage();               // the first page is asked for with the plan types
  first.catch(() => {});                // (its error is shown by load)
  let plans = [];
  try {
    plans = (await api('/plan-types')).map((p) => p.name);
  } catch {
    plans = [];
  }
  const showSel = () => { selCount.textContent = `${selectedRuns().length} ticked`; };
  document.addEventListener('labjoint:selection', showSel);
  compare.addEventListener('click', () => { window.location.hash = '#/models'; });
  el.append(h('section', { class: 'card' }, h('h2', {}, 'Runs'),
    filtersForm(query, plans, (q) => { window.location.hash = `#/runs?${q}`; }),
    msg,
    h('div', { class: 'toolbar' }, count, selCount, compare),
    h('div', { class: 'scroll' }, h('table', { class: 'runs' },
      h('thead', {}, h('tr', {}, ['', 'Run', 'Plan', 'f (Hz)', 'Vpp', 'Torque (N m)', 'Duration (s)',
        'Status', 'W (mJ)', 'C (Ns/m)', 'K (MN/m)', 'Result (reprocess analyze)', 'Started (UTC)'].map((x) => h('th', {}, x)))),
      body)),
    more));
  showSel();
  let shown = 0;
  async function load() {
    note(msg, 'Loading runs…', 'busy');
    try {
      const asked = first || listPage();
      first = null;
      const page = await asked;
      const selected = new Set(selectedRuns());
      page.items.forEach((r) => body.append(row(r, selected)));
      shown += page.items.length;
      count.textContent = `${shown} run${shown === 1 ? '' : 's'}${page.next_offset != null ? '+' : ''}`;
      more.hidden = page.next_offset == null;
      offset = page.next_offset ?? offset;
      note(msg, shown ? '' : 'No run matches these filters.');
    } catch (err) {
      note(msg, `Could not list runs: ${err.message}`, 'error');
    }
  }
  more.addEventListener('click', load);
  clear(body);
  await load();
  return { leave: () => document.removeEventListener('labjoint:selection', showSel) };
}
