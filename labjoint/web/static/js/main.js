// The dashboard's entry: a hash router over the views, the control-token box and the
// service line in the header.

import { api, forget, prefetch, setToken, token } from './api.js';

// Each view's module and every module it imports (under /static/js/), loaded only when
// the view is shown: the first page fetches its own few files, not all twenty. All of a
// view's files are preloaded at once (one round of requests instead of one per import
// level); tests/test_web_mount.py checks each list against the modules' imports.
export const VIEWS = {
  runs: ['views/runs.js', 'dom.js', 'units.js'],
  run: ['views/run.js', 'dom.js', 'plot/plot.js', 'plot/axes.js', 'plot/svg.js', 'units.js',
    'views/loops.js', 'views/table2.js', 'words.js'],
  models: ['views/models.js', 'dom.js', 'units.js', 'views/runs.js', 'views/modelplots.js',
    'plot/bars.js', 'plot/axes.js', 'plot/svg.js', 'plot/heatmap.js', 'plot/plot.js', 'words.js'],
  predict: ['views/predict.js', 'dom.js', 'units.js', 'plot/plot.js', 'plot/axes.js',
    'plot/svg.js', 'views/runs.js'],
  live: ['views/live.js', 'dom.js', 'units.js', 'views/loops.js', 'plot/plot.js',
    'plot/axes.js', 'plot/svg.js'],
  trends: ['views/trends.js', 'dom.js', 'plot/plot.js', 'plot/axes.js', 'plot/svg.js',
    'units.js', 'views/runs.js', 'views/trendexport.js'],
  structure: ['views/structure.js', 'dom.js', 'units.js', 'words.js', 'views/modelplots.js',
    'views/structcurves.js', 'plot/plot.js', 'plot/heatmap.js', 'plot/bars.js', 'plot/axes.js',
    'plot/svg.js'],
  reprocess: ['views/reprocess.js', 'dom.js'],
  frf: ['views/frf.js', 'dom.js', 'units.js', 'plot/plot.js', 'plot/axes.js', 'plot/svg.js'],
  backbone: ['views/backbone.js', 'dom.js', 'units.js', 'plot/plot.js', 'plot/axes.js', 'plot/svg.js'],
};
// The first requests of a view that takes a while to load, asked for while its modules
// load (the view's own identical requests take these replies; a reply the view does not
// ask for, such as the steady loops of a run still being recorded, is dropped). The
// queries are the views' own (run.js: 8 loops of 200 points, the whole run's signals
// at 1500 points); if they ever differ, the view simply asks again.
const FIRST = {
  run: (r) => {
    const run = `/runs/${encodeURIComponent(r.arg)}`;
    prefetch(run);
    prefetch(`${run}/loops`, { max_cycles: 8, points_per_cycle: 200 });
    prefetch(`${run}/channels`).then((c) => prefetch(`${run}/data`,
      { start: 0, stop: c.duration_s, max_points: 1500 }), () => {});
  },
};
const preloaded = new Set(['main.js', ...[...document.querySelectorAll('link[rel=modulepreload]')]
  .map((l) => new URL(l.href).pathname.replace('/static/js/', ''))]);

function loadView(name) {
  for (const f of VIEWS[name]) {
    if (preloaded.has(f)) continue;
    preloaded.add(f);
    document.head.append(Object.assign(document.createElement('link'),
      { rel: 'modulepreload', href: `/static/js/${f}` }));
  }
  return import(`./${VIEWS[name][0]}`);
}

let current = null;

export function parseHash(hash) {
  const raw = hash.replace(/^#\/?/, '');
  const q = raw.indexOf('?');
  const path = q < 0 ? raw : raw.slice(0, q);
  const [view, ...rest] = path.split('/');
  return { view: view || 'runs', arg: rest.map(decodeURIComponent).join('/'),
    query: new URLSearchParams(q < 0 ? '' : raw.slice(q + 1)) };
}

let generation = 0;

// Show the view named by the hash in a fresh container; a view that finishes loading
// after the user moved on only ever touches its own detached container, and is left.
async function route() {
  if (current && current.leave) current.leave();
  current = null;
  generation += 1;
  const mine = generation;
  const r = parseHash(window.location.hash);
  const name = Object.hasOwn(VIEWS, r.view) ? r.view : 'runs';
  document.body.dataset.view = name;
  document.querySelectorAll('nav a').forEach((a) => a.classList.toggle('active',
    a.dataset.view === (name === 'run' ? 'runs' : name)));
  const box = document.createElement('div');
  document.getElementById('view').replaceChildren(box);
  let shown = null;
  try {
    if (FIRST[name]) FIRST[name](r);
    const mod = await loadView(name);
    shown = (await mod.show(box, r)) || null;
  } catch (err) {
    const p = document.createElement('p');
    p.className = 'note error';
    p.textContent = `This view failed: ${err.message}`;
    box.append(p);
  }
  if (mine === generation) forget();
  if (mine === generation) current = shown;
  else if (shown && shown.leave) shown.leave();
}

function tokenBox() {
  const input = document.getElementById('token');
  const state = document.getElementById('token-state');
  const show = () => {
    state.textContent = token() ? 'set (this tab only)' : 'not set: read-only';
    state.classList.toggle('set', !!token());
  };
  document.getElementById('token-form').addEventListener('submit', (ev) => {
    ev.preventDefault();
    setToken(input.value.trim());
    input.value = '';
    show();
  });
  window.addEventListener('labjoint:token', () => { show(); route(); });   // reads may need it
  show();
}

// The emergency stop sits in the header of every page. From the machine itself the
// service accepts it without a token (loopback); from elsewhere the control token is sent.
// The header follows the rig (every STATUS_MS): "STOPPED" while a stop is latched, gone
// once it is cleared (from any page, the CLI or another browser), and the output state.
const STATUS_MS = 2000;
let pressed = 0;          // stop presses so far: a status asked for before one is stale

function estopButton() {
  const btn = document.getElementById('estop');
  const out = document.getElementById('estop-msg');
  btn.addEventListener('click', async () => {
    pressed += 1;
    try {
      const r = await api('/estop', { method: 'POST', body: { reason: 'emergency stop from the dashboard' } });
      out.textContent = `STOPPED: ${r.estop}. Output off; queued plans held.`;
      out.className = 'estop-msg sent';
    } catch (err) {
      out.textContent = `NOT sent: ${err.message}. Switch the amplifier off at its interlock.`;
      out.className = 'estop-msg failed';
    }
    window.dispatchEvent(new Event('labjoint:estop'));
  });
}

function rigStatus(rig) {
  const out = document.getElementById('estop-msg');
  const state = document.getElementById('rig-output');
  if (rig.estop) {
    out.textContent = `STOPPED: ${rig.estop}. Output off; queued plans held.`;
    out.className = 'estop-msg sent';
  } else if (out.classList.contains('sent')) {
    out.textContent = '';
    out.className = 'estop-msg';
  }
  const g = (rig.daemon || {}).generator || {};
  state.textContent = rig.mode === 'none' ? '' : `output ${g.output == null ? '?' : g.output ? 'ON' : 'off'}`;
  state.className = `rig-output${g.output ? ' on' : ''}`;
}

function followRig() {
  let refused = false;       // reads need a token this page does not hold: wait for one
  window.addEventListener('labjoint:token', () => { refused = false; });
  const refresh = async () => {
    if (refused) return;
    const asked = pressed;
    try {
      const rig = await api('/rig');
      if (asked === pressed) rigStatus(rig);
    } catch (err) {
      refused = err.status === 401 || err.status === 403;
      // otherwise the service line says when the service is unreachable
    }
  };
  const tick = async () => {
    await refresh();
    setTimeout(tick, STATUS_MS);
  };
  tick();
  window.addEventListener('labjoint:estop-cleared', refresh);
}

async function service() {
  const el = document.getElementById('service');
  try {
    const h = await api('/health');
    el.textContent = `v${h.version} · daemon: ${h.daemon}`;
  } catch (err) {
    el.textContent = `service unreachable: ${err.message}`;
    el.classList.add('bad');
  }
}

tokenBox();
estopButton();
service();
followRig();
window.addEventListener('hashchange', route);
route();
