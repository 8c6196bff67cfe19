// Both identification methods side by side in the shape of seed 002 Table 2:
// property, unit, stick-slip-boundary model, hysteresis loop, difference in %.
// The stick-slip column is a model value (Eqs. 6-9: W = 2 K_t U^2, C = K / (pi omega)),
// fixed by the loop's stiffness, U and omega; the loop column is measured.

import { h, table } from '../dom.js';
import { fmt, pct } from '../units.js';

const diff = (loop, ss) => (loop && ss != null && Number.isFinite(ss) ? (loop - ss) / loop * 100 : null);

function pm(v, sd, k) {
  if (v == null) return '–';
  return sd != null && Number.isFinite(sd) ? `${fmt(v * k)} ± ${fmt(sd * k, 2)}` : fmt(v * k);
}

// The fraction of a measured cycle spent sliding: steps on the loop's flat tops, where
// the force stays within 3 % of its extreme and its slope dF/du is under 5 % of the
// loop's secant stiffness (a plateau; an elliptic, viscous loop has none).
export function slidingFraction(cycles) {
  let slid = 0;
  let total = 0;
  for (const c of cycles || []) {
    const u = c.displacement_m;
    const F = c.force_n;
    const fmax = Math.max(...F.map(Math.abs));
    const secant = fmax / ((Math.max(...u) - Math.min(...u)) / 2);
    for (let i = 1; i < F.length; i += 1) {
      total += 1;
      const du = Math.abs(u[i] - u[i - 1]);
      if (Math.abs(F[i]) >= 0.97 * fmax && du > 0 && Math.abs(F[i] - F[i - 1]) <= 0.05 * secant * du) slid += 1;
    }
  }
  return total ? slid / total : null;
}

export function identificationTable(r, measured = {}) {
  const ss = (key) => r[`stickslip_${key}`];
  const below = r.below_resolution === true;
  const loopW = below ? 'below resolution' : pm(r.energy_loss_j, r.energy_loss_j_std, 1e3);
  const loopC = below ? 'below resolution' : pm(r.damping_ns_per_m, r.damping_ns_per_m_std, 1);
  const rows = [
    ['Energy loss', 'mJ', fmt(ss('energy_loss_j') * 1e3), loopW,
      below ? '–' : pct(r.energy_loss_diff_pct ?? diff(r.energy_loss_j, ss('energy_loss_j')))],
    ['Joint damping', 'Ns/m', fmt(ss('damping_ns_per_m')), loopC,
      below ? '–' : pct(r.damping_diff_pct ?? diff(r.damping_ns_per_m, ss('damping_ns_per_m')))],
    ['Joint stiffness', 'MN/m', fmt(ss('stiffness_n_per_m') * 1e-6),
      pm(r.stiffness_n_per_m, r.stiffness_n_per_m_std, 1e-6), pct(diff(r.stiffness_n_per_m, ss('stiffness_n_per_m')))],
    ['Displacement amplitude', 'µm', fmt(ss('displacement_amplitude_m') * 1e6),
      pm(r.displacement_amplitude_m, r.displacement_amplitude_m_std, 1e6), '–'],
    ['Force amplitude', 'N', '–', pm(r.force_amplitude_n, r.force_amplitude_n_std, 1), '–'],
    ['Steady cycles', '', fmt(ss('cycles')), fmt(r.cycles ?? r.n_cycles), '–'],
  ];
  const extra = [];
  if (r.friction_coefficient != null) {
    extra.push(`friction coefficient μ = ${fmt(r.friction_coefficient, 3)} ± ${fmt(r.friction_coefficient_uncertainty, 2)} (${r.friction_source || '–'})`);
  }
  if (ss('min_boundary_radius_m') != null) extra.push(`smallest stick-slip boundary radius ${fmt(ss('min_boundary_radius_m') * 1e3)} mm`);
  const sliding = measured.sliding;
  const contradicted = ss('macro_slip_fraction') != null && sliding != null && sliding > 0.05
    && ss('macro_slip_fraction') < 0.01;
  if (ss('macro_slip_fraction') != null && !contradicted) extra.push(`macro-slip fraction ${pct(100 * ss('macro_slip_fraction'))}`);
  if (r.warnings && r.warnings.length) extra.push(`warnings: ${r.warnings.join('; ')}`);
  if (below) extra.push('the loop\'s energy loss is below its resolution (sensor phase and cycle-to-cycle scatter): not a result');
  const basis = 'Stick-slip column: model values from seed 002 Eqs. 6-9 with K_t = K/2 from the loop slope, μ and the contact law; '
    + 'in micro-slip W = 2 K_t U² and C = K/(πω) exactly, so they follow from the loop\'s stiffness, U and ω. '
    + 'Hysteresis-loop column: measured (loop area and slope). The difference between the two is not an independent confirmation.';
  const flags = [];
  if (contradicted) {
    flags.push(h('p', { class: 'note error', id: 'macro-slip-flag' }, `The stick-slip model finds no macro-slip `
      + `(fraction ${pct(100 * ss('macro_slip_fraction'))}), but the measured loop slides on its plateaus over `
      + `${pct(100 * sliding)} of the cycle: the joint slips as a whole, which Eqs. 6-9 (micro-slip) do not describe; `
      + 'the stick-slip column is not a result for this run.'));
  }
  if (r.friction_flag) flags.push(h('p', { class: 'note error', id: 'friction-flag' }, `Friction coefficient: ${r.friction_flag}.`));
  return h('div', {}, ...flags, table(['Joint property', 'Unit', 'Stick-slip model (Eqs. 6-9)', 'Hysteresis loop (measured)', 'Loop − model (%)'],
    rows, { class: 'table2', id: 'table2' }),
  h('p', { class: 'caption', id: 'table2-basis' }, basis),
  extra.length ? h('p', { class: 'caption' }, extra.join(' · ')) : null);
}
