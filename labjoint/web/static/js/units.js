// Units at the display edge: SI inside, µm / N / mJ / MN/m / Ns/m on the screen.

const DISPLAY = {
  m: { unit: 'µm', k: 1e6 },
  N: { unit: 'N', k: 1 },
  J: { unit: 'mJ', k: 1e3 },
  'N/m': { unit: 'MN/m', k: 1e-6 },
  'N s/m': { unit: 'Ns/m', k: 1 },
  'Ns/m': { unit: 'Ns/m', k: 1 },
  s: { unit: 's', k: 1 },
  Hz: { unit: 'Hz', k: 1 },
  V: { unit: 'V', k: 1 },
};

// {unit, k}: the display unit of an SI unit and the factor to multiply by.
export function display(unit) {
  return DISPLAY[unit] || { unit: unit || '', k: 1 };
}

// Parameter units are shown as is except the common ones above; delays in µs.
export function paramDisplay(unit) {
  if (unit === 's') return { unit: 'µs', k: 1e6 };
  return display(unit);
}

export const um = (m) => (m == null ? null : m * 1e6);
export const mJ = (j) => (j == null ? null : j * 1e3);
export const MNm = (k) => (k == null ? null : k * 1e-6);

export function fmt(v, digits = 4) {
  if (v == null || typeof v !== 'number' || !Number.isFinite(v)) return '–';
  if (v === 0) return '0';
  const a = Math.abs(v);
  if (a >= 1e6 || a < 1e-3) return v.toExponential(digits - 1);
  return String(parseFloat(v.toPrecision(digits)));
}

export function pct(v) {
  return v == null || !Number.isFinite(v) ? '–' : `${v.toFixed(1)} %`;
}

// An NRMSE (a fraction inside) as the page shows every NRMSE: in %.
export function nrmse(v, digits = 3) {
  return v == null || !Number.isFinite(v) ? '–' : `${fmt(100 * v, digits)} %`;
}

export function when(iso) {
  if (!iso) return '–';
  const d = new Date(iso);
  return Number.isNaN(d.getTime()) ? iso : d.toISOString().replace('T', ' ').slice(0, 19) + 'Z';
}
