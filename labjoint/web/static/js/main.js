// The dashboard's entry: a hash router over the views, the control-token box and the
// service line in the header.

import { api, setToken, token } from './api.js';
import * as live from './views/live.js';
import * as models from './views/models.js';
import * as predict from './views/predict.js';
import * as reprocess from './views/reprocess.js';
import * as run from './views/run.js';
import * as runs from './views/runs.js';
import * as structure from './views/structure.js';
import * as trends from './views/trends.js';

const VIEWS = { runs, run, models, predict, structure, live, trends, reprocess };
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
  const mod = VIEWS[r.view] || runs;
  const name = VIEWS[r.view] ? r.view : 'runs';
  document.body.dataset.view = name;
  document.querySelectorAll('nav a').forEach((a) => a.classList.toggle('active',
    a.dataset.view === (name === 'run' ? 'runs' : name)));
  const box = document.createElement('div');
  document.getElementById('view').replaceChildren(box);
  let shown = null;
  try {
    shown = (await mod.show(box, r)) || null;
  } catch (err) {
    const p = document.createElement('p');
    p.className = 'note error';
    p.textContent = `This view failed: ${err.message}`;
    box.append(p);
  }
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
function estopButton() {
  const btn = document.getElementById('estop');
  const out = document.getElementById('estop-msg');
  btn.addEventListener('click', async () => {
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
window.addEventListener('hashchange', route);
route();
