// The operator's dashboard (docs/dashboard.md): telemetry over Server-Sent Events read with fetch
// (so the token can go along), plots on canvases, controls that only ask: the controller decides.
'use strict';

const KEEP_S = 300;  // what the server keeps too (a reload shows it again)
const COLOURS = ['#1f77b4', '#d62728', '#2ca02c'];
// Sample layout (dashboard.cpp): t, enc1..3, ref1..3, cur1..3, plate ref x,y,z mm, flags, fault, underruns.
const T = 0, ENC = 1, REF = 4, CUR = 7, PLATE = 10, FLAGS = 13;

const dash = {
  samples: [], status: null, bits: { drive_enable: 1, homed: 2, holding: 4, fault: 8 },
  events: 0, lastEventAt: 0, connected: false, dirty: true, lastDraw: 0, lastAge: 0, draws: 0,
};
window.dashboard = dash;  // for the browser test and the curious

const $ = (id) => document.getElementById(id);
const sleep = (ms) => new Promise((done) => setTimeout(done, ms));

// ---- the token (sessionStorage: this tab only) ----
function token() { return sessionStorage.getItem('deltactl-token') || ''; }
function headers(json) {
  const h = {};
  if (token()) h.Authorization = 'Bearer ' + token();
  if (json) h['Content-Type'] = 'application/json';
  return h;
}
function askToken() {
  return new Promise((done) => {
    const dialog = $('token-dialog');
    $('token-input').value = '';
    dialog.onclose = () => {
      const value = $('token-input').value.trim();
      if (dialog.returnValue === 'ok' && value) sessionStorage.setItem('deltactl-token', value);
      done();
    };
    dialog.showModal();
  });
}

function say(text, ok) {
  const m = $('message');
  m.textContent = text;
  m.className = ok ? 'ok' : '';
}

// ---- commands: the controller answers; the page only reports ----
async function command(name, body) {
  if (!token()) await askToken();
  if (!token()) { say(name + ': no token given'); return; }
  let reply = {}, response;
  try {
    response = await fetch('/api/' + name, {
      method: 'POST', headers: headers(body !== undefined), cache: 'no-store',
      body: body === undefined ? undefined : JSON.stringify(body),
    });
    try { reply = await response.json(); } catch (e) { reply = {}; }
  } catch (e) {
    say(name + ': ' + e);
    return;
  }
  if (response.status === 401) sessionStorage.removeItem('deltactl-token');
  say(name + ': ' + (response.ok ? (reply.event || 'done') : (reply.error || 'HTTP ' + response.status)), response.ok);
  if (name === 'run' || response.ok) setTimeout(listRecordings, 1500);
}

// ---- telemetry ----
function accept(event, message) {
  if (event === 'history') {
    dash.samples = message.samples || [];
    if (message.flag_bits) dash.bits = message.flag_bits;
  } else {
    const fresh = message.samples || [];
    if (fresh.length && dash.samples.length && fresh[0][T] < dash.samples[dash.samples.length - 1][T]) {
      dash.samples = dash.samples.filter((s) => s[T] < fresh[0][T]);  // the board restarted its clock
    }
    for (const s of fresh) dash.samples.push(s);
    dash.status = message.status;
    dash.lastEventAt = performance.now();
    dash.events += 1;
    showStatus();
  }
  if (dash.samples.length) {
    const oldest = dash.samples[dash.samples.length - 1][T] - KEEP_S;
    let drop = 0;
    while (drop < dash.samples.length && dash.samples[drop][T] < oldest) drop += 1;
    if (drop) dash.samples.splice(0, drop);
  }
  dash.dirty = true;
}

async function stream() {
  for (;;) {
    try {
      const response = await fetch('/api/telemetry', { headers: headers(false), cache: 'no-store' });
      if (response.status === 401) {
        say('reading from another host needs the token');
        await askToken();
        continue;
      }
      if (!response.ok) throw new Error('telemetry: HTTP ' + response.status);
      dash.connected = true;
      const reader = response.body.getReader();
      const decoder = new TextDecoder();
      let buffer = '';
      for (;;) {
        const { value, done } = await reader.read();
        if (done) break;
        buffer += decoder.decode(value, { stream: true });
        let end;
        while ((end = buffer.indexOf('\n\n')) >= 0) {
          const block = buffer.slice(0, end);
          buffer = buffer.slice(end + 2);
          let event = 'message', data = '';
          for (const line of block.split('\n')) {
            if (line.startsWith('event:')) event = line.slice(6).trim();
            else if (line.startsWith('data:')) data += line.slice(5).trim();
          }
          if (data) accept(event, JSON.parse(data));
        }
      }
    } catch (e) {
      say('telemetry: ' + e.message + ' (retrying)');
    }
    dash.connected = false;
    await sleep(1000);
  }
}

// ---- the status bar and the controls ----
// Written only when they change: an unchanged page costs the browser no layout and no paint.
function setText(element, text) { if (element.textContent !== text) element.textContent = text; }
function setClass(element, name) { if (element.className !== name) element.className = name; }

function showStatus() {
  const s = dash.status;
  if (!s) return;
  const state = $('state');
  setText(state, s.state || '-');
  setClass(state, 'badge ' + (s.state || ''));
  setText($('homed'), s.homed ? 'yes' : 'no');
  setText($('drives'), s.drives_enabled ? 'ON' : 'off');
  const fault = $('fault');
  setText(fault, s.fault ? s.fault : 'none');
  setClass(fault, s.fault ? 'active' : '');
  const run = s.run;
  setText($('run'), run && run.planned
    ? `${run.seconds.toFixed(1)} of ${run.total_s.toFixed(1)} s (${run.percent.toFixed(1)} %), ${run.feed}`
    : run ? 'starting' : (s.last_run && s.last_run.outcome ? 'last run: ' + s.last_run.outcome : 'no run'));
  const connected = s.connection === 'connected';
  const feed = run ? run.feed : '';
  $('home').disabled = !(connected && !run && !s.drives_enabled && !s.fault);
  $('run-button').disabled = !(connected && !run && s.state === 'homed' && !s.fault);
  $('hold').disabled = !(run && (feed === 'streaming' || feed === 'resuming'));
  $('resume').disabled = !(run && (feed === 'held' || feed.startsWith('holding')));
  $('stop').disabled = !run;
  $('clear').disabled = !s.fault;
  const b = s.board || {};
  setText($('identity'), `${s.connection} (${s.note}); port ${s.port}; weights ${s.weights} ` +
    `(CRC ${s.weights_crc}); board gateware ${b.gateware_build_id || '-'}, weights CRC ${b.weights_crc || '-'}` +
    (s.counters ? `; underruns ${s.counters.underruns}, bad frames ${s.counters.bad_frames}` : ''));
}

function showAge() {
  const age = $('age');
  if (!dash.connected || !dash.status || dash.status.data_age_ms === null) {
    setText(age, dash.connected ? 'no data' : 'no stream');
    setClass(age, 'stale');
    return;
  }
  const ms = dash.status.data_age_ms + (performance.now() - dash.lastEventAt);
  setText(age, ms < 1000 ? `${Math.round(ms)} ms` : `${(ms / 1000).toFixed(1)} s`);
  setClass(age, ms > 500 ? 'stale' : '');
}

// ---- plots ----
// The samples to draw: all in the window, or, when there are more than two a pixel column (a long
// window), the first, minimum and maximum of each column's samples, so a spike stays visible.
function thinned(visible, lines, x) {
  const column = (s) => Math.round(x(s[T]));
  if (visible.length <= 2 * (column(visible[visible.length - 1]) - column(visible[0]) + 1)) return visible;
  const keep = [];
  for (let start = 0; start < visible.length;) {
    let end = start;
    while (end + 1 < visible.length && column(visible[end + 1]) === column(visible[start])) end += 1;
    const chosen = new Set([start, end]);
    for (const line of lines) {
      let low = -1, high = -1;
      for (let i = start; i <= end; i += 1) {
        const v = line.value(visible[i]);
        if (v === null || !isFinite(v)) continue;
        if (low < 0 || v < line.value(visible[low])) low = i;
        if (high < 0 || v > line.value(visible[high])) high = i;
      }
      if (low >= 0) chosen.add(low).add(high);
    }
    for (const i of [...chosen].sort((a, b) => a - b)) keep.push(visible[i]);
    start = end + 1;
  }
  return keep;
}

function plot(canvas, lines, windowS) {
  const ctx = canvas.getContext('2d');
  const W = canvas.width, H = canvas.height, left = 60, right = 10, top = 6, bottom = 20;
  ctx.clearRect(0, 0, W, H);
  const all = dash.samples;
  if (!all.length) return;
  const t1 = all[all.length - 1][T], t0 = t1 - windowS;
  let first = all.length - 1;
  while (first > 0 && all[first - 1][T] >= t0) first -= 1;
  const x = (t) => left + (t - t0) / windowS * (W - left - right);
  const visible = thinned(all.slice(first), lines, x);
  // Bands: drives off, feed hold, fault (flags); one rectangle for each run of samples.
  const bands = [['#e0e0e0', (f) => !(f & dash.bits.drive_enable)], ['#cfe3f7', (f) => f & dash.bits.holding],
    ['#f8c9c9', (f) => f & dash.bits.fault]];
  for (const [colour, on] of bands) {
    ctx.fillStyle = colour;
    for (let i = 0; i < visible.length; i += 1) {
      if (!on(visible[i][FLAGS])) continue;
      let j = i;
      while (j + 1 < visible.length && on(visible[j + 1][FLAGS])) j += 1;
      const end = j + 1 < visible.length ? visible[j + 1][T] : visible[j][T] + 0.02;
      ctx.fillRect(x(visible[i][T]), top, Math.max(1, x(end) - x(visible[i][T])), H - top - bottom);
      i = j;
    }
  }
  let lo = Infinity, hi = -Infinity;
  for (const line of lines) {
    for (const s of visible) {
      const v = line.value(s);
      if (v === null || !isFinite(v)) continue;
      lo = Math.min(lo, v); hi = Math.max(hi, v);
    }
  }
  if (!isFinite(lo)) { lo = -1; hi = 1; }
  if (hi - lo < 1e-6) { lo -= 0.5; hi += 0.5; }
  const pad = (hi - lo) * 0.08;
  lo -= pad; hi += pad;
  const y = (v) => top + (hi - v) / (hi - lo) * (H - top - bottom);
  ctx.strokeStyle = '#ddd'; ctx.fillStyle = '#444'; ctx.font = '11px sans-serif'; ctx.lineWidth = 1;
  const decimals = Math.max(0, Math.min(6, 2 - Math.floor(Math.log10(hi - lo))));
  for (let k = 0; k <= 4; k += 1) {
    const v = lo + (hi - lo) * k / 4;
    ctx.beginPath(); ctx.moveTo(left, y(v)); ctx.lineTo(W - right, y(v)); ctx.stroke();
    ctx.fillText((Math.abs(v) < (hi - lo) * 1e-6 ? 0 : v).toFixed(decimals), 2, y(v) + 4);
  }
  for (let k = 0; k <= 5; k += 1) {
    const t = t0 + windowS * k / 5;
    ctx.fillText(t.toFixed(1) + ' s', x(t) - 14, H - 5);
  }
  for (const line of lines) {
    ctx.strokeStyle = line.colour; ctx.lineWidth = 1.4; ctx.setLineDash(line.dash || []);
    ctx.beginPath();
    let pen = false;
    for (const s of visible) {
      const v = line.value(s);
      if (v === null || !isFinite(v)) { pen = false; continue; }
      if (pen) ctx.lineTo(x(s[T]), y(v)); else ctx.moveTo(x(s[T]), y(v));
      pen = true;
    }
    ctx.stroke();
  }
  ctx.setLineDash([]);
  // What was drawn, for a look from outside (the browser test reads these from the DOM).
  canvas.dataset.points = String(visible.length);
  canvas.dataset.newestS = t1.toFixed(2);
}

const joints = [], errors = [], currents = [], plate = [];
for (let j = 0; j < 3; j += 1) {
  joints.push({ colour: COLOURS[j], value: (s) => s[ENC + j] });
  joints.push({ colour: COLOURS[j], dash: [6, 4], value: (s) => s[REF + j] });
  errors.push({ colour: COLOURS[j], value: (s) => (s[FLAGS] & dash.bits.drive_enable ? s[ENC + j] - s[REF + j] : null) });
  currents.push({ colour: COLOURS[j], value: (s) => s[CUR + j] });
  plate.push({ colour: COLOURS[j], value: (s) => s[PLATE + j] });
}

function frame(now) {
  if (now - dash.lastAge >= 100) {  // the age: ten times a second is enough to read
    showAge();
    dash.lastAge = now;
  }
  if (dash.dirty && now - dash.lastDraw >= 40) {  // at most 25 redraws a second
    const w = Number($('window').value);
    plot($('plot-joints'), joints, w);
    plot($('plot-error'), errors, w);
    plot($('plot-currents'), currents, w);
    plot($('plot-plate'), plate, w);
    dash.dirty = false;
    dash.lastDraw = now;
    dash.draws += 1;
  }
  requestAnimationFrame(frame);
}

// ---- recordings ----
async function fetchBlobUrl(url) {
  const response = await fetch(url, { headers: headers(false), cache: 'no-store' });
  if (!response.ok) throw new Error(url + ': ' + (await response.text()).trim());
  return URL.createObjectURL(await response.blob());
}

async function listRecordings() {
  let list = [];
  try {
    const response = await fetch('/api/recordings', { headers: headers(false), cache: 'no-store' });
    if (!response.ok) return;
    list = await response.json();
  } catch (e) { return; }
  const body = $('recording-list');
  body.textContent = '';
  for (const r of list.slice(0, 50)) {
    const row = body.insertRow();
    row.insertCell().textContent = r.name;
    row.insertCell().textContent = `${(r.bytes / 1024).toFixed(0)} KiB`;
    row.insertCell().textContent = new Date(r.modified_unix_s * 1000).toLocaleString();
    const actions = row.insertCell();
    const show = document.createElement('button');
    show.textContent = 'plot';
    show.onclick = async () => {
      say('plotting ' + r.name + ' ...', true);
      try { $('recording-plot').src = await fetchBlobUrl(r.plot); say(r.name, true); } catch (e) { say(e.message); }
    };
    const download = document.createElement('button');
    download.textContent = 'download';
    download.onclick = async () => {
      try {
        const a = document.createElement('a');
        a.href = await fetchBlobUrl(r.csv);
        a.download = r.name;
        a.click();
      } catch (e) { say(e.message); }
    };
    actions.append(show, ' ', download);
  }
}

async function listTrajectories() {
  try {
    const response = await fetch('/api/trajectories', { headers: headers(false), cache: 'no-store' });
    const list = await response.json();
    const select = $('trajectory');
    for (const t of list) {
      const option = document.createElement('option');
      option.value = t.name;
      option.textContent = t.name;
      option.title = t.description;
      select.append(option);
    }
  } catch (e) { /* the list stays empty */ }
}

// ---- wiring ----
$('estop').onclick = () => command('estop');
$('home').onclick = () => command('home');
$('run-button').onclick = () => {
  const duration = Number($('duration').value);
  command('run', { trajectory: $('trajectory').value, duration: duration > 0 ? duration : null });
};
$('hold').onclick = () => command('hold');
$('resume').onclick = () => command('resume');
$('stop').onclick = () => command('stop');
$('clear').onclick = () => command('clear');
$('token').onclick = () => askToken();
$('refresh').onclick = () => listRecordings();
$('window').onchange = () => { dash.dirty = true; };
for (const id of ['home', 'run-button', 'hold', 'resume', 'stop', 'clear']) $(id).disabled = true;

listTrajectories();
listRecordings();
stream();
requestAnimationFrame(frame);
// The e-stop is one click: the token is asked for once, when the page opens.
if (!token() && !new URLSearchParams(location.search).has('no-token-prompt')) askToken();
