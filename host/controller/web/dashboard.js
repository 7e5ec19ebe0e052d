// The operator's dashboard (docs/dashboard.md): telemetry over Server-Sent Events read with fetch
// (so the token can go along), one stream per browser shared by its tabs, plots on canvases,
// controls that only ask: the controller decides.
'use strict';

const KEEP_S = 300;  // what the server keeps too (a reload shows it again)
const GAP_S = 0.1;   // samples come every 20 ms: a longer silence is drawn as one, not bridged
const COLOURS = ['#1f77b4', '#d62728', '#2ca02c'];
// Sample layout (dashboard.cpp): t, enc1..3, ref1..3, cur1..3, plate ref x,y,z mm, flags, fault,
// underruns, the host's marks (the operator's feed hold, a latched e-stop).
const T = 0, ENC = 1, REF = 4, CUR = 7, PLATE = 10, FLAGS = 13, MARKS = 16;

const dash = {
  samples: [], status: null, bits: { drive_enable: 1, homed: 2, holding: 4, fault: 8, homing: 64 },
  marks: { feed_held: 1, estop_latched: 2 },
  events: 0, lastEventAt: 0, connected: false, dirty: true, lastDraw: 0, lastAge: 0, draws: 0,
  role: 'starting',  // of the browser's shared stream: 'leader' (reads it), 'follower' (is told), 'alone'
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
// The token bar: in the page's flow above the plots (it covers nothing); resolves when used or
// cancelled.
let tokenAnswered = null;
function askToken() {
  const bar = $('token-bar');
  if (!bar.hidden && tokenAnswered) return tokenAnswered.promise;
  let done;
  const promise = new Promise((resolve) => { done = resolve; });
  tokenAnswered = { promise, done };
  $('token-input').value = '';
  bar.hidden = false;
  $('token-input').focus();
  return promise;
}
function tokenBarClosed(use) {
  const value = $('token-input').value.trim();
  if (use && value) sessionStorage.setItem('deltactl-token', value);
  $('token-bar').hidden = true;
  if (tokenAnswered) tokenAnswered.done();
  tokenAnswered = null;
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
  const text = response.ok ? (reply.event || 'done') : (reply.error || 'HTTP ' + response.status);
  say(text.startsWith(name + ':') ? text : name + ': ' + text, response.ok);
  if (name === 'run' || response.ok) setTimeout(listRecordings, 1500);
}

// ---- telemetry ----
function accept(event, message) {
  if (event === 'history') {
    dash.samples = message.samples || [];
    if (message.flag_bits) dash.bits = message.flag_bits;
    if (message.mark_bits) dash.marks = message.mark_bits;
  } else {
    const fresh = message.samples || [];
    if (fresh.length && dash.samples.length && fresh[0][T] < dash.samples[dash.samples.length - 1][T]) {
      dash.samples = dash.samples.filter((s) => s[T] < fresh[0][T]);  // the board restarted its clock
    }
    for (const s of fresh) dash.samples.push(s);
    if (message.status) dash.status = message.status;
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

// The leader's stream: every event is drawn here and told to the browser's other tabs.
async function stream(abort) {
  while (!abort.signal.aborted) {
    try {
      const response = await fetch('/api/telemetry', { headers: headers(false), cache: 'no-store',
                                                        signal: abort.signal });
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
          if (!data) continue;
          const message = JSON.parse(data);
          accept(event, message);
          tell({ kind: event === 'history' ? 'history' : 'event', message });
        }
      }
    } catch (e) {
      if (abort.signal.aborted) break;
      say('telemetry: ' + e.message + ' (retrying)');
    }
    dash.connected = false;
    await sleep(1000);
  }
  dash.connected = false;
}

// ---- one telemetry stream per browser ----
// A browser opens at most 6 HTTP/1.1 connections to a host: a stream in every tab would leave the
// e-stop's request none. The tabs elect one leader on a BroadcastChannel (the lowest id among
// those that claim); it alone streams and tells the others each event. Followers that hear no
// leader for LEADER_LOST_MS claim again; a leader closing says so first.
const LEADER_LOST_MS = 3000, CLAIM_MS = 400, BEAT_MS = 500;
const me = Math.random().toString(36).slice(2, 10) + '-' + Date.now().toString(36);
const channel = 'BroadcastChannel' in window ? new BroadcastChannel('deltactl-telemetry') : null;
const election = { leader: null, heardAt: 0, claimingSince: 0, abort: null };
window.dashboard.election = election;

function tell(message) {
  if (channel && dash.role === 'leader') channel.postMessage(Object.assign({ from: me }, message));
}

function lead() {
  dash.role = 'leader';
  election.leader = me;
  election.claimingSince = 0;
  election.abort = new AbortController();
  stream(election.abort);
}

function follow(leader) {
  if (dash.role === 'leader' && election.abort) election.abort.abort();
  const fresh = election.leader !== leader || dash.role !== 'follower';
  dash.role = 'follower';
  election.leader = leader;
  election.heardAt = performance.now();
  election.claimingSince = 0;
  if (fresh) channel.postMessage({ kind: 'history?', from: me, to: leader });
}

function heard(m) {
  // The token goes to a new tab of this browser from an open one (same origin only), so its E-STOP
  // is one click too.
  if (m.kind === 'token?') {
    if (token()) channel.postMessage({ kind: 'token', from: me, to: m.from, token: token() });
    return;
  }
  if (m.kind === 'token') {
    if (m.to === me && !token() && m.token) {
      sessionStorage.setItem('deltactl-token', m.token);
      if (!$('token-bar').hidden) tokenBarClosed(false);
    }
    return;
  }
  if (m.kind === 'claim') {
    if (dash.role === 'leader') {
      channel.postMessage({ kind: 'beat', from: me });
    } else if (election.claimingSince && m.from < me) {  // the lower id claims: it leads, this tab waits
      election.claimingSince = 0;
      election.heardAt = performance.now();
    }
  } else if (m.kind === 'beat' || m.kind === 'event' || m.kind === 'history') {
    if (dash.role === 'leader' && m.from > me) return;  // two leaders for a moment: the lower id stays
    if (dash.role !== 'follower' || election.leader !== m.from) follow(m.from);
    election.heardAt = performance.now();
    if (m.kind === 'event') { accept('message', m.message); dash.connected = true; }
    if (m.kind === 'history' && m.to === me) accept('history', m.message);
  } else if (m.kind === 'history?' && dash.role === 'leader' && m.to === me) {
    channel.postMessage({ kind: 'history', from: me, to: m.from,
                          message: { samples: dash.samples, flag_bits: dash.bits, mark_bits: dash.marks } });
  } else if (m.kind === 'bye' && m.from === election.leader) {
    election.heardAt = 0;
    dash.connected = false;
  }
}

function elect() {
  const now = performance.now();
  if (dash.role === 'leader') {
    channel.postMessage({ kind: 'beat', from: me });
  } else if (election.claimingSince) {
    if (now - election.claimingSince >= CLAIM_MS) lead();
  } else if (now - election.heardAt > LEADER_LOST_MS) {
    if (dash.role === 'follower') dash.connected = false;
    election.claimingSince = now;
    channel.postMessage({ kind: 'claim', from: me });
  }
}

function startTelemetry() {
  if (!channel) {  // no way to share: this tab streams for itself
    dash.role = 'alone';
    stream(new AbortController());
    return;
  }
  channel.onmessage = (e) => heard(e.data);
  if (!token()) channel.postMessage({ kind: 'token?', from: me });
  election.heardAt = performance.now() - LEADER_LOST_MS + 2 * BEAT_MS;  // a leader there is heard first
  setInterval(elect, BEAT_MS / 2);
  addEventListener('pagehide', () => { if (dash.role === 'leader') channel.postMessage({ kind: 'bye', from: me }); });
}

// ---- the status bar and the controls ----
// Written only when they change: an unchanged page costs the browser no layout and no paint.
function setText(element, text) { if (element.textContent !== text) element.textContent = text; }
function setClass(element, name) { if (element.className !== name) element.className = name; }

// A latched e-stop as the controller reports it ({latched, source, board_time_s}), or null.
function latchedEstop(s) { return s && s.estop && s.estop.latched ? s.estop : null; }

function runText(s) {
  const run = s.run;
  if (run && run.planned) {
    if (run.percent === null || run.percent === undefined) {  // held or stopping: the plan ends at rest
      return `${run.seconds.toFixed(1)} s played, ${run.feed}`;
    }
    return `${run.seconds.toFixed(1)} of ${run.total_s.toFixed(1)} s (${run.percent.toFixed(1)} %), ${run.feed}`;
  }
  if (run) return 'starting';
  return s.last_run && s.last_run.outcome ? 'last run: ' + s.last_run.outcome : 'no run';
}

function showStatus() {
  const s = dash.status;
  if (!s) return;
  const estop = latchedEstop(s);
  const state = $('state');
  setText(state, s.state || '-');
  setClass(state, 'badge ' + (estop ? 'estopped' : s.state || ''));
  setText($('homed'), s.homed ? 'yes' : 'no');
  setText($('drives'), s.drives_enabled ? 'ON' : 'off');
  const fault = $('fault');
  setText(fault, s.fault ? s.fault : 'none');
  setClass(fault, s.fault ? 'active' : '');
  setText($('run'), runText(s));
  const banner = $('estop-banner');
  banner.hidden = !estop;
  if (estop) {
    const when = typeof estop.board_time_s === 'number' ? ` at board time ${estop.board_time_s.toFixed(2)} s` : '';
    setText(banner, `E-STOPPED by ${estop.source || 'an unknown source'}${when}: the drives stay off and ` +
      'nothing moves until the e-stop is cleared ("Clear e-stop (reset)").');
  }
  const run = s.run;
  const connected = s.connection === 'connected';
  const feed = run ? run.feed : '';
  $('home').disabled = !(connected && !run && !s.drives_enabled && !s.fault && !estop);
  $('run-button').disabled = !(connected && !run && s.state === 'homed' && !s.fault && !estop);
  $('hold').disabled = !(run && (feed === 'streaming' || feed === 'resuming'));
  $('resume').disabled = !(run && (feed === 'held' || feed.startsWith('holding')));
  $('stop').disabled = !run;
  const clear = $('clear');
  clear.disabled = !(s.fault || estop);
  setText(clear, estop ? 'Clear e-stop (reset)' : 'Clear fault');
  setClass(clear, estop ? 'reset' : '');
  const b = s.board || {};
  setText($('identity'), `${s.connection} (${s.note}); port ${s.port}; weights ${s.weights} ` +
    `(CRC ${s.weights_crc}); board gateware ${b.gateware_build_id || '-'}, ` +
    (b.model === 'none' ? 'no model' : `model CRC ${b.weights_crc || '-'}`) +
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
// The samples to draw, as indices into `visible`: all, or, when there are more than two a pixel
// column (a long window), the first, last, minimum and maximum of each column's samples, so a
// spike stays visible.
function thinned(visible, lines, x) {
  const column = (s) => Math.round(x(s[T]));
  const all = visible.map((_, i) => i);
  if (visible.length <= 2 * (column(visible[visible.length - 1]) - column(visible[0]) + 1)) return all;
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
    for (const i of [...chosen].sort((a, b) => a - b)) keep.push(i);
    start = end + 1;
  }
  return keep;
}

// The bands, each a rectangle per run of samples it holds for: what the board's flags and the
// host's marks say. The board also holds at the start and end of every run (the enable and the
// stop): only the operator's feed hold is drawn as one.
const BANDS = [
  { kind: 'off', colour: '#e0e0e0', on: (s) => !(s[FLAGS] & dash.bits.drive_enable) },
  { kind: 'homing', colour: '#fff1b8', on: (s) => s[FLAGS] & dash.bits.homing },
  { kind: 'hold', colour: '#cfe3f7', on: (s) => s[MARKS] & dash.marks.feed_held },
  { kind: 'estop', colour: '#f2a6a6', on: (s) => s[MARKS] & dash.marks.estop_latched },
  { kind: 'fault', colour: '#f8c9c9', on: (s) => s[FLAGS] & dash.bits.fault },
];
const NO_DATA = '#ffe0b2';

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
  const raw = all.slice(first);
  // gaps[i]: the silences (no telemetry for more than GAP_S) up to raw[i]; no line, no band crosses one.
  const gaps = new Array(raw.length).fill(0);
  const drawn = { gap: 0 };
  for (let i = 1; i < raw.length; i += 1) {
    const silent = raw[i][T] - raw[i - 1][T] > GAP_S;
    gaps[i] = gaps[i - 1] + (silent ? 1 : 0);
    if (silent) {
      ctx.fillStyle = NO_DATA;
      ctx.fillRect(x(raw[i - 1][T]), top, Math.max(1, x(raw[i][T]) - x(raw[i - 1][T])), H - top - bottom);
      drawn.gap += 1;
    }
  }
  const kept = thinned(raw, lines, x);
  const end = (k) => (k + 1 < kept.length && gaps[kept[k + 1]] === gaps[kept[k]] ? raw[kept[k + 1]][T]
    : raw[kept[k]][T] + 0.02);
  for (const band of BANDS) {
    ctx.fillStyle = band.colour;
    drawn[band.kind] = 0;
    for (let k = 0; k < kept.length; k += 1) {
      if (!band.on(raw[kept[k]])) continue;
      let j = k;
      while (j + 1 < kept.length && band.on(raw[kept[j + 1]]) && gaps[kept[j + 1]] === gaps[kept[j]]) j += 1;
      const from = raw[kept[k]][T];
      ctx.fillRect(x(from), top, Math.max(1, x(end(j)) - x(from)), H - top - bottom);
      drawn[band.kind] += 1;
      k = j;
    }
  }
  let lo = Infinity, hi = -Infinity;
  for (const line of lines) {
    for (const k of kept) {
      const v = line.value(raw[k]);
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
  let longest = 0;  // the longest time a line joins, s
  for (const line of lines) {
    ctx.strokeStyle = line.colour; ctx.lineWidth = 1.4; ctx.setLineDash(line.dash || []);
    ctx.beginPath();
    let pen = -1;  // the index (into raw) the pen is at, or -1 when lifted
    for (const k of kept) {
      const v = line.value(raw[k]);
      if (v === null || !isFinite(v)) { pen = -1; continue; }
      if (pen >= 0 && gaps[pen] === gaps[k]) {
        ctx.lineTo(x(raw[k][T]), y(v));
        longest = Math.max(longest, raw[k][T] - raw[pen][T]);
      } else {
        ctx.moveTo(x(raw[k][T]), y(v));
      }
      pen = k;
    }
    ctx.stroke();
  }
  ctx.setLineDash([]);
  // What was drawn, for a look from outside (the browser test reads these from the DOM).
  canvas.dataset.points = String(kept.length);
  canvas.dataset.newestS = t1.toFixed(2);
  canvas.dataset.bands = JSON.stringify(drawn);
  canvas.dataset.longestLineS = longest.toFixed(3);
  canvas.dataset.colours = [...new Set(lines.map((l) => l.colour))].join(' ');
}

// The four plots, their lines and each plot's legend (the lines' own colours).
const PLOTS = [
  { id: 'plot-joints', names: ['joint 1', 'joint 2', 'joint 3'], lines: [] },
  { id: 'plot-error', names: ['joint 1', 'joint 2', 'joint 3'], lines: [] },
  { id: 'plot-currents', names: ['joint 1', 'joint 2', 'joint 3'], lines: [] },
  { id: 'plot-plate', names: ['x', 'y', 'z'], lines: [] },
];
for (let j = 0; j < 3; j += 1) {
  PLOTS[0].lines.push({ colour: COLOURS[j], value: (s) => s[ENC + j] });
  PLOTS[0].lines.push({ colour: COLOURS[j], dash: [6, 4], value: (s) => s[REF + j] });
  PLOTS[1].lines.push({ colour: COLOURS[j],
                        value: (s) => (s[FLAGS] & dash.bits.drive_enable ? s[ENC + j] - s[REF + j] : null) });
  PLOTS[2].lines.push({ colour: COLOURS[j], value: (s) => s[CUR + j] });
  PLOTS[3].lines.push({ colour: COLOURS[j], value: (s) => s[PLATE + j] });
}
for (const p of PLOTS) {
  const legend = document.createElement('span');
  legend.className = 'keys';
  p.names.forEach((name, j) => {
    const key = document.createElement('span');
    key.className = 'key';
    key.dataset.colour = COLOURS[j];
    key.style.color = COLOURS[j];
    key.textContent = '\u2501 ' + name;
    legend.append(key);
  });
  $(p.id).parentElement.querySelector('figcaption').append(legend);
}

function frame(now) {
  if (now - dash.lastAge >= 100) {  // the age: ten times a second is enough to read
    showAge();
    dash.lastAge = now;
  }
  if (dash.dirty && now - dash.lastDraw >= 40) {  // at most 25 redraws a second
    const w = Number($('window').value);
    for (const p of PLOTS) plot($(p.id), p.lines, w);
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
  const reports = [];  // [url, cell]: filled in order once the table is drawn
  for (const r of list.slice(0, 50)) {
    const row = body.insertRow();
    row.insertCell().textContent = r.name;
    row.insertCell().textContent = `${(r.bytes / 1024).toFixed(0)} KiB`;
    row.insertCell().textContent = new Date(r.modified_unix_s * 1000).toLocaleString();
    const report = row.insertCell();
    report.className = 'run-report';
    reports.push([r.report, report]);
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
  for (const [url, cell] of reports) await showReport(url, cell);
}

// A recording's run-report headline (the joint tracking; the plate when the recording has it), or
// why there is none (a drag with the drives off). The server keeps each report while the file stays.
async function showReport(url, cell) {
  try {
    const response = await fetch(url, { headers: headers(false), cache: 'no-store' });
    const report = await response.json();
    if (!response.ok) {
      cell.textContent = '-';
      cell.title = report.error;
      return;
    }
    const lines = report.headline.trim().split('\n');
    cell.textContent = report.plate_measured ? lines.join('\n') : lines[0] + '\nplate: not measured (no stage)';
    cell.title = report.plate_measured ? '' : report.plate_source;
  } catch (e) {
    cell.textContent = '-';
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
$('token-bar').onsubmit = (e) => { e.preventDefault(); tokenBarClosed(true); };
$('token-cancel').onclick = () => tokenBarClosed(false);
$('refresh').onclick = () => listRecordings();
$('window').onchange = () => { dash.dirty = true; };
for (const id of ['home', 'run-button', 'hold', 'resume', 'stop', 'clear']) $(id).disabled = true;

listTrajectories();
listRecordings();
startTelemetry();
requestAnimationFrame(frame);
// The e-stop is one click: the token is asked for once, when the page opens (in the page's flow,
// above the plots, which stay in sight), unless an open tab of this browser answers with it first.
setTimeout(() => {
  if (!token() && !new URLSearchParams(location.search).has('no-token-prompt')) askToken();
}, channel ? 300 : 0);
