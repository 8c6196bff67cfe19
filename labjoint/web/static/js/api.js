// The REST API under /api/v1: JSON in and out, the control token from sessionStorage
// sent as "Authorization: Bearer <token>", jobs polled until they finish.

export const PREFIX = '/api/v1';
const TOKEN_KEY = 'labjoint.token';

export class ApiError extends Error {
  constructor(status, code, message, details) {
    super(message);
    this.status = status;
    this.code = code;
    this.details = details;
  }
}

export function token() {
  return sessionStorage.getItem(TOKEN_KEY) || '';
}

export function setToken(value) {
  if (value) sessionStorage.setItem(TOKEN_KEY, value);
  else sessionStorage.removeItem(TOKEN_KEY);
  window.dispatchEvent(new CustomEvent('labjoint:token'));
}

export function url(path, query = {}) {
  const u = new URL(PREFIX + path, window.location.origin);
  for (const [k, v] of Object.entries(query)) {
    if (v == null || v === '') continue;
    if (Array.isArray(v)) v.forEach((x) => u.searchParams.append(k, x));
    else u.searchParams.set(k, v);
  }
  return u;
}

// Replies asked for ahead of the view that needs them (prefetch), by URL; each is
// handed to the first identical GET and dropped once the view has shown (forget).
const early = new Map();

export function prefetch(path, query = {}) {
  const key = url(path, query).href;
  if (!early.has(key)) {
    const reply = api(path, { query });
    reply.catch(() => {});           // reported by the view's own request, if it is made
    early.set(key, reply);
  }
  return early.get(key);
}

export function forget() {
  early.clear();
}

export async function api(path, { method = 'GET', body, query } = {}) {
  if (method === 'GET' && body === undefined) {
    const key = url(path, query).href;
    const reply = early.get(key);
    if (reply) {
      early.delete(key);
      return reply;
    }
  }
  const headers = { Accept: 'application/json' };
  const t = token();
  if (t) headers.Authorization = `Bearer ${t}`;
  if (body !== undefined) headers['Content-Type'] = 'application/json';
  const resp = await fetch(url(path, query), {
    method, headers, body: body === undefined ? undefined : JSON.stringify(body),
  });
  const data = await resp.json().catch(() => null);
  if (!resp.ok) {
    const e = (data && data.error) || {};
    throw new ApiError(resp.status, e.code || `http_${resp.status}`,
      e.message || (data && data.detail) || resp.statusText, e.details);
  }
  return data;
}

// Writes need the control token: say so before the server has to.
export function needToken() {
  if (!token()) {
    throw new ApiError(401, 'no_token',
      'this needs the control token: enter it at the top of the page');
  }
}

const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

// Submit a job (POST submitPath) and poll pollPath/<id> until it ends; its result.
// onProgress(job) is called after every poll.
export async function runJob(submitPath, pollPath, body, onProgress = () => {}) {
  needToken();
  let job = await api(submitPath, { method: 'POST', body });
  let wait = 150;
  while (job.status === 'queued' || job.status === 'running') {
    onProgress(job);
    await sleep(wait);
    wait = Math.min(wait * 1.5, 1000);
    job = await api(`${pollPath}/${job.id}`);
  }
  onProgress(job);
  if (job.status !== 'complete') {
    const e = job.error || {};
    throw new ApiError(500, e.code || job.status, e.message || `job ${job.status}`, e);
  }
  return job.result;
}
