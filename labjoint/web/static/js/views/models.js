// Models: choose runs and a model expression, fit and diagnose it, add a missing effect
// from the ranked candidates and refit; the ladder of NRMSE per step against the noise
// floor grows by one step each time. Ladders saved in the ticked runs' files (by a
// ladder job or `labjoint ladder`) are shown as saved, without recomputing.

import { api, runJob } from '../api.js';
import { h, note, section } from '../dom.js';
import { when } from '../units.js';
import { selectedRuns, setSelectedRuns } from './runs.js';
import * as draw from './modelplots.js';
import { onPage } from '../words.js';

// Kept while the tab lives, so leaving the view and coming back shows the same work.
const state = { model: 'linear_stiffness+viscous', fit: null, diag: null, ladder: [], noiseFloor: null, busy: false };

async function effects() {
  const resp = await fetch('/web/effects.json');
  return resp.ok ? resp.json() : [];
}

// Ladders saved in the files of `runs`, one per question (key): those on exactly these
// runs first, then newest first.
async function savedLadders(runs) {
  const lists = await Promise.all(runs.map((n) => api(`/runs/${encodeURIComponent(n)}/ladders`)));
  const byKey = new Map();
  for (const l of lists.flatMap((b) => b.ladders)) if (!byKey.has(l.key)) byKey.set(l.key, l);
  const same = (l) => l.runs.length === runs.length && l.runs.every((r) => runs.includes(r));
  return [...byKey.values()].map((l) => ({ ...l, exact: same(l) }))
    .sort((a, b) => (b.exact - a.exact) || ((a.saved_at || '') < (b.saved_at || '') ? 1 : -1));
}

const SAVED_SHOWN = 4;

function savedView(list, runs, onUse) {
  if (!runs.length) return h('p', { class: 'note' }, 'Tick runs to see the ladders saved in their files.');
  if (!list.length) return h('p', { class: 'note' }, 'No ladder saved in the ticked runs yet: the automatic ladder saves one.');
  return h('div', { class: 'saved-grid', id: 'saved-ladders-list' }, list.slice(0, SAVED_SHOWN).map((l, i) => h('figure', {
    class: 'saved-ladder', 'data-key': l.key },
  h('h3', {}, `${l.start} → ${l.final_model}`),
  h('p', { class: 'caption' }, `${l.exact ? 'These runs' : `${l.runs.length} run(s): ${l.runs.join(', ')}`} · `
    + `${l.adequate ? 'adequate' : 'not adequate'}${l.stop_reason ? ` (${onPage(l.stop_reason)})` : ''} · saved ${when(l.saved_at)}`),
  ladderChart(l, i), draw.worseNote(l.steps, `saved-ladder-worse-${i}`),
  h('button', { type: 'button', class: 'small secondary use-ladder', onclick: () => onUse(l) },
    'Continue from this ladder'))));
}

function ladderChart(l, i) {
  return draw.ladderChart(l.steps, l.noise_floor, `saved-ladder-${i}`);
}

const PICK_PAGE = 50;

// The complete runs a page at a time, searchable by name; ticks are kept across pages
// and searches (the selection lives in sessionStorage).
function runPicker(onChange) {
  const list = h('div', { class: 'run-pick', id: 'run-pick' });
  const search = h('input', { type: 'search', id: 'run-search', placeholder: 'search run names',
    'aria-label': 'search run names', size: 22 });
  const prev = h('button', { type: 'button', class: 'small secondary', id: 'run-prev' }, '‹ Newer');
  const next = h('button', { type: 'button', class: 'small secondary', id: 'run-next' }, 'Older ›');
  const where = h('span', { class: 'count', id: 'run-page' });
  const tickedN = h('span', { class: 'count', id: 'run-ticked' });
  let offset = 0;
  let asked = 0;
  let items = [];
  const showTicked = () => { tickedN.textContent = `${selectedRuns().length} ticked`; };
  async function load() {
    const ask = ++asked;
    const page = await api('/runs', { query: { status: 'complete', order: '-start_time', limit: PICK_PAGE,
      offset, search: search.value.trim() } });
    if (ask !== asked) return;
    items = page.items;
    draw.rememberRuns(items);
    const sel = new Set(selectedRuns());
    list.replaceChildren(...items.map((r) => {
      const cb = h('input', { type: 'checkbox', value: r.name, checked: sel.has(r.name) });
      cb.addEventListener('change', () => {
        const cur = new Set(selectedRuns());
        if (cb.checked) cur.add(r.name); else cur.delete(r.name);
        setSelectedRuns([...cur]);
        showTicked();
        onChange();
      });
      return h('label', {}, cb, `${r.name}`, h('span', { class: 'count' },
        ` ${r.frequency_hz ?? '–'} Hz · ${r.excitation_vpp ?? '–'} Vpp · ${r.torque_nm ?? '–'} N m`));
    }));
    if (!items.length) list.append(h('p', { class: 'note' }, search.value.trim() ? 'No complete run matches.' : 'No complete run yet.'));
    where.textContent = page.total ? `${offset + 1}–${offset + items.length} of ${page.total}` : '';
    prev.disabled = offset === 0;
    next.disabled = page.next_offset == null;
  }
  let typing = null;
  search.addEventListener('input', () => {
    clearTimeout(typing);
    typing = setTimeout(() => { offset = 0; load(); }, 200);
  });
  prev.addEventListener('click', () => { offset = Math.max(0, offset - PICK_PAGE); load(); });
  next.addEventListener('click', () => { offset += PICK_PAGE; load(); });
  const tickPage = h('button', { type: 'button', class: 'secondary small', id: 'tick-page', onclick: () => {
    setSelectedRuns([...selectedRuns(), ...items.map((r) => r.name)]);
    list.querySelectorAll('input').forEach((c) => { c.checked = true; });
    showTicked();
    onChange();
  } }, 'Tick this page');
  const untick = h('button', { type: 'button', class: 'secondary small', id: 'untick-all', onclick: () => {
    setSelectedRuns([]);
    list.querySelectorAll('input').forEach((c) => { c.checked = false; });
    showTicked();
    onChange();
  } }, 'Untick all');
  showTicked();
  const box = h('div', {}, search, list, h('div', { class: 'toolbar' }, prev, where, next),
    h('div', { class: 'toolbar' }, tickPage, untick, tickedN));
  return { box, load };
}

// The ticked runs (on every page of the picker).
function picked() {
  return selectedRuns();
}

// A structure nobody can describe (a frame, a beam of another lab: accelerometers, a
// vibrometer, a voltage drive): the model acts on the measured modes of a stored FRF set or
// modes file (frf/), on mode 1's coordinate or between two of its sensors; the REST
// options modal, modal_band, responses and between (the CLI's --modal, --between, ...).
async function modalBox() {
  const sets = await api('/spectra/frf');
  const pick = h('select', { id: 'modal-set', 'aria-label': 'measured modes' },
    h('option', { value: '' }, '(none: the joint-level kinds)'),
    ...sets.frfsets.map((n) => h('option', { value: n }, n)));
  const field = (id, placeholder, label, title) => h('label', { class: 'field inline', title },
    `${label} `, h('input', { id, placeholder, size: 12, spellcheck: 'false' }));
  const band = field('modal-band', 'lo:hi Hz', 'band', 'the band the set\'s modes are found in');
  const resp = field('modal-responses', 'a,b', 'responses', 'the channels compared (default: '
    + 'every motion channel of the runs that the modes have)');
  const between = field('modal-between', 'A,B', 'joint between', 'two sensors of the modes the '
    + 'joint acts between (default: on mode 1\'s coordinate)');
  const box = h('details', { id: 'modal-opts' },
    h('summary', {}, 'Measured modes (a structure without a model)'),
    h('div', { class: 'toolbar' }, pick, band, resp, between),
    h('p', { class: 'caption' }, 'The FRFs tab stores a set; its modes carry the structure, the '
      + 'model is the joint acting on them.'));
  const list = (x) => x.value.split(',').map((v) => v.trim()).filter(Boolean);
  function options() {
    if (!pick.value) return {};
    const out = { modal: pick.value };
    const b = band.querySelector('input').value.trim();
    if (b) out.modal_band = b.split(':').map(Number);
    const r = list(resp.querySelector('input'));
    if (r.length) out.responses = r;
    const w = list(between.querySelector('input'));
    if (w.length) out.between = w;
    return out;
  }
  return { box, options };
}

export async function show(el) {
  const vocab = await effects();
  const saved = h('div', { id: 'saved-ladders' });
  let savedAsked = 0;
  // the ladders saved in the ticked runs' files; the latest answer wins
  async function refreshSaved() {
    const ask = ++savedAsked;
    const runs = picked();
    try {
      const list = runs.length ? await savedLadders(runs) : [];
      if (ask === savedAsked) saved.replaceChildren(savedView(list, runs, useLadder));
    } catch (err) {
      if (ask === savedAsked) saved.replaceChildren(h('p', { class: 'note error' }, err.message));
    }
  }
  const picker = runPicker(() => refreshSaved());
  await picker.load();
  const expr = h('input', { id: 'model-expr', type: 'text', value: state.model, size: 50, spellcheck: 'false',
    'aria-label': 'model expression' });
  const chips = h('div', { class: 'chips' }, vocab.map((e) => h('button', { type: 'button', class: 'chip',
    title: `${e.kind}: ${e.params.map((p) => `${p.name} (${p.unit})`).join(', ')}`,
    onclick: () => { expr.value = expr.value.trim() ? `${expr.value.trim()}+${e.name}` : e.name; } }, e.name)));
  const limit = h('details', { id: 'limit' }, h('summary', {}, 'Try only some candidate effects (faster)'),
    h('div', { class: 'chips' }, vocab.map((e) => h('label', { class: 'chip' },
      h('input', { type: 'checkbox', value: e.name }), ` ${e.name}`))),
    h('p', { class: 'caption' }, 'None ticked: every effect of the vocabulary that fits the model is tried.'));
  const modal = await modalBox();
  const msg = h('p', { hidden: true, id: 'models-msg' });
  const fitBtn = h('button', { id: 'fit' }, 'Fit and diagnose');
  const ladderBtn = h('button', { id: 'auto-ladder', class: 'secondary' }, 'Automatic ladder');
  const out = {
    summary: h('div', { id: 'fit-summary' }), params: h('div'), perRun: h('div'), loops: h('div', { id: 'overlays' }),
    maps: h('div', { id: 'maps' }), physics: h('div', { id: 'physics' }), cands: h('div'), ladder: h('div', { id: 'ladder-box' }),
  };

  function render() {
    const { fit, diag } = state;
    out.summary.replaceChildren(fit || diag ? draw.summary(fit, diag) : h('p', { class: 'note' }, 'Choose runs and a model, then fit.'));
    out.params.replaceChildren(fit ? draw.parameters(fit) : '');
    out.perRun.replaceChildren(fit ? draw.perRun(fit) : '');
    out.loops.replaceChildren(fit ? draw.loops(fit) : '');
    out.maps.replaceChildren(diag ? draw.residualMaps(draw.findMaps(diag), diag.failures, diag.kind) : '');
    out.physics.replaceChildren(fit ? draw.physics(fit) : '');
    out.cands.replaceChildren(diag ? draw.candidates(diag, addEffect, state.busy) : state.ladder.length
      ? h('p', { class: 'note' }, 'Fit and diagnose the last model to see its candidates.') : '');
    out.ladder.replaceChildren(...(state.ladder.length ? [draw.ladderChart(state.ladder, state.noiseFloor),
      draw.worseNote(state.ladder)].filter(Boolean)
      : [h('p', { class: 'note' }, 'The ladder starts with the first fit.')]));
    results.forEach((x, i) => { x.hidden = !(fit || diag || (i === 0 && state.ladder.length)); });
    [fitBtn, ladderBtn].forEach((b) => { b.disabled = state.busy; });
  }

  state.render = render;   // a job outlives a visit to another view: redraw the current one

  async function work(label, fn) {
    if (state.busy) return;
    state.busy = true;
    render();
    note(msg, `${label}…`, 'busy');
    try {
      await fn((job) => note(msg, `${label}… ${Math.round(100 * (job.progress || 0))} % ${job.message || ''}`, 'busy'));
      note(msg, '');
    } catch (err) {
      note(msg, onPage(err.message), 'error');
    } finally {
      state.busy = false;
      state.render();
    }
  }

  // Options of every comparison job: the arrays the page draws (full) and, if any are
  // ticked, the only candidate effects to try.
  function options() {
    const only = [...limit.querySelectorAll('input:checked')].map((x) => x.value);
    return { ...kindOptions(), ...(only.length ? { candidates: only } : {}) };
  }
  // what every job of this view sends besides the candidates: the arrays the page draws
  // (full) and, with measured modes chosen, the modal kind's options
  const kindOptions = () => ({ full: true, ...modal.options() });

  // Fit and diagnose `model` on the ticked runs; a new ladder, or one more step.
  function fitDiagnose(model, added) {
    const runs = picked();
    return work(`Fitting ${model} and trying the candidates`, async (progress) => {
      if (!runs.length) throw new Error('tick at least one run');
      const diag = await runJob('/models/diagnose', '/models/jobs', { runs, model, options: options() }, progress);
      // a diagnosis fits the model itself; the plain fit only for what it does not carry
      const fit = diag.parameters && diag.runs && diag.loops ? diag
        : await runJob('/models/fit', '/models/jobs', { runs, model, options: kindOptions() }, progress);
      state.model = diag.model || model;
      expr.value = state.model;
      state.fit = { ...fit, ...(diag.parameters ? { parameters: diag.parameters, runs: diag.runs } : {}),
        loops: diag.loops || fit.loops, curves: diag.curves || fit.curves };
      state.diag = diag;
      state.noiseFloor = diag.noise_floor ?? fit.noise_floor ?? state.noiseFloor;
      const step = { model: state.model, added: added || null, nrmse: diag.nrmse ?? fit.nrmse,
        runs: (state.fit.runs || []).map((r) => ({ run: r.run, energy_loss_error_pct: r.energy_loss_error_pct })) };
      state.ladder = added ? [...state.ladder, step] : [step];
    });
  }

  // a saved ladder as the current one: its steps and noise floor, its last model to go on from
  function useLadder(l) {
    state.ladder = l.steps.map((st) => ({ model: st.model, added: st.added, nrmse: st.nrmse, runs: st.runs }));
    state.noiseFloor = l.noise_floor;
    state.model = l.final_model;
    expr.value = state.model;
    state.fit = null;
    state.diag = null;
    render();
  }

  function addEffect(effect) {
    const cand = (state.diag?.candidates || []).find((c) => c.effect === effect);
    return fitDiagnose(cand?.model || `${state.model}+${effect}`, effect);
  }

  fitBtn.addEventListener('click', () => fitDiagnose(expr.value.replace(/\s+/g, '')));
  ladderBtn.addEventListener('click', () => work('Automatic ladder', async (progress) => {
    const runs = picked();
    if (!runs.length) throw new Error('tick at least one run');
    const res = await runJob('/models/ladder', '/models/jobs', { runs, model: expr.value.replace(/\s+/g, ''),
      options: options() }, progress);
    state.ladder = res.steps || [];
    state.noiseFloor = res.noise_floor ?? state.noiseFloor;
    const diag = res.final_diagnosis;
    if (diag) {
      const fit = diag.loops ? diag
        : await runJob('/models/fit', '/models/jobs', { runs, model: diag.model, options: kindOptions() }, progress);
      state.diag = diag;
      state.fit = { ...diag, loops: fit.loops };
    }
    if (state.ladder.length) {
      state.model = state.ladder[state.ladder.length - 1].model;
      expr.value = state.model;
    }
    refreshSaved();
  }));

  const results = [
    h('div', { class: 'grid2' }, section('Missing effects, most promising first', out.cands),
      section('Ladder: NRMSE per step', out.ladder)),
    section('Measured and model loops', out.loops),
    section('Where the model fails: residual maps', out.maps),
    section('Dissipation and stiffness against amplitude', out.physics),
    h('div', { class: 'grid2' }, section('Parameters', out.params), section('Per run', out.perRun))];
  el.append(h('h1', {}, 'Models'),
    section('Runs and model', h('div', { class: 'models-form' },
      h('div', {}, h('h3', {}, 'Runs'), picker.box),
      h('div', {}, h('h3', {}, 'Model: effects joined by +'), expr, chips,
        limit, modal.box, h('div', { class: 'toolbar' }, fitBtn, ladderBtn), msg, out.summary))),
    ...results,
    section('Ladders saved in the ticked runs', saved));
  render();
  refreshSaved();
  return null;
}
