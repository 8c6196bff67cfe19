// Exports of the trends view: the per-run numbers as CSV (SI, exactly the REST values),
// and the plots as one SVG (styles inlined, so it stands alone) or PNG (the SVG drawn
// on a canvas at twice the size).

// Columns of the CSV, in order: every value and its standard uncertainty (SI units).
export const CSV_COLUMNS = ['run', 'excitation_vpp', 'torque_nm', 'frequency_hz', 'cycles',
  'displacement_amplitude_m', 'displacement_amplitude_m_uncertainty',
  'force_amplitude_n', 'force_amplitude_n_uncertainty',
  'energy_loss_j', 'energy_loss_j_uncertainty', 'damping_ns_per_m', 'damping_ns_per_m_uncertainty',
  'stiffness_n_per_m', 'stiffness_n_per_m_uncertainty', 'below_resolution',
  'stickslip_energy_loss_j', 'stickslip_energy_loss_j_uncertainty',
  'stickslip_damping_ns_per_m', 'stickslip_damping_ns_per_m_uncertainty',
  'stickslip_stiffness_n_per_m', 'stickslip_stiffness_n_per_m_uncertainty',
  'energy_loss_diff_pct', 'damping_diff_pct', 'stiffness_diff_pct'];

function cell(v) {
  if (v == null) return '';
  const t = String(v);                                  // numbers: shortest exact form
  return /[",\n]/.test(t) ? `"${t.replace(/"/g, '""')}"` : t;
}

// '# key: value' lines (the fits), a header row, one row per run.
export function trendsCsv(body) {
  const lines = [];
  for (const f of body.fits || []) {
    const key = `${f.method}_energy_loss_exponent_vs_${f.against}`;
    lines.push(f.error ? `# ${key}: none (${f.error.replace(/\n/g, ' ')})`
      : `# ${key}: ${f.exponent} (95 % CI ${f.exponent_ci95[0]} to ${f.exponent_ci95[1]}; coefficient ${f.coefficient})`);
  }
  lines.push(CSV_COLUMNS.join(','));
  for (const r of body.runs || []) lines.push(CSV_COLUMNS.map((c) => cell(r[c])).join(','));
  return `${lines.join('\n')}\n`;
}

export function download(blob, filename) {
  const a = document.createElement('a');
  a.href = URL.createObjectURL(blob);
  a.download = filename;
  document.body.append(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(a.href), 10000);
}

const STYLE_KEYS = ['fill', 'fill-opacity', 'stroke', 'stroke-width', 'stroke-opacity',
  'stroke-dasharray', 'font-size', 'font-family', 'font-weight', 'opacity'];

// A standalone copy of a drawn plot: the computed styles written onto each element as
// SVG presentation attributes (the page's CSP refuses inline style attributes).
function inlined(svg) {
  const copy = svg.cloneNode(true);
  const src = [svg, ...svg.querySelectorAll('*')];
  const dst = [copy, ...copy.querySelectorAll('*')];
  src.forEach((el, i) => {
    const cs = getComputedStyle(el);
    for (const k of STYLE_KEYS) {
      const v = cs.getPropertyValue(k);
      if (v) dst[i].setAttribute(k, v);
    }
  });
  return copy;
}

// The plots stacked in one SVG document (text).
export function plotsSvg(svgs) {
  const NS = 'http://www.w3.org/2000/svg';
  const root = document.createElementNS(NS, 'svg');
  let y = 0;
  let width = 0;
  for (const svg of svgs) {
    const [, , w, hgt] = svg.getAttribute('viewBox').split(/\s+/).map(Number);
    const one = inlined(svg);
    one.setAttribute('x', '0');
    one.setAttribute('y', String(y));
    one.setAttribute('width', String(w));
    one.setAttribute('height', String(hgt));
    root.append(one);
    y += hgt;
    width = Math.max(width, w);
  }
  root.setAttribute('xmlns', NS);
  root.setAttribute('width', String(width));
  root.setAttribute('height', String(y));
  root.setAttribute('viewBox', `0 0 ${width} ${y}`);
  const bg = document.createElementNS(NS, 'rect');
  Object.entries({ x: 0, y: 0, width, height: y, fill: '#ffffff' }).forEach(([k, v]) => bg.setAttribute(k, v));
  root.prepend(bg);
  return new XMLSerializer().serializeToString(root);
}

// The SVG text rendered to a PNG blob at ``scale`` times its size.
export function svgToPng(text, scale = 2) {
  return new Promise((resolve, reject) => {
    const img = new Image();
    img.onload = () => {
      const canvas = document.createElement('canvas');
      canvas.width = Math.round(img.width * scale);
      canvas.height = Math.round(img.height * scale);
      const ctx = canvas.getContext('2d');
      ctx.scale(scale, scale);
      ctx.drawImage(img, 0, 0);
      canvas.toBlob((b) => (b ? resolve(b) : reject(new Error('PNG encoding failed'))), 'image/png');
    };
    img.onerror = () => reject(new Error('the plots could not be rendered to PNG'));
    img.src = `data:image/svg+xml;charset=utf-8,${encodeURIComponent(text)}`;
  });
}
