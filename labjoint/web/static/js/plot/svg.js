// SVG element builder and the colours every plot shares.

const NS = 'http://www.w3.org/2000/svg';

export function s(tag, attrs = {}, ...children) {
  const el = document.createElementNS(NS, tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (v != null && v !== false) el.setAttribute(k, String(v));
  }
  for (const c of children.flat(Infinity)) {
    if (c == null || c === false) continue;
    el.append(c instanceof Node ? c : document.createTextNode(String(c)));
  }
  return el;
}

export const PALETTE = ['#1f5fa8', '#c8352e', '#2a8a3e', '#d9822b', '#7b4bb0', '#8c5a3c',
  '#1b9aaa', '#6b6b6b'];

export function color(i) {
  return PALETTE[i % PALETTE.length];
}

let uid = 0;
export function nextId(prefix) {
  uid += 1;
  return `${prefix}${uid}`;
}
