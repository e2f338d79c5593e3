"""The web HMI's page: one HTML document, its script and styles inline (no build step, nothing
fetched from elsewhere). It opens ``/ws`` and redraws on every snapshot; the buttons call
``/api/call`` and are enabled once logged in."""

PAGE = """<!doctype html>
<html lang="en">
<head>
<meta charset="utf-8">
<title>motionplc HMI</title>
<meta name="viewport" content="width=device-width, initial-scale=1">
<style>
  :root { --bg:#f4f5f7; --panel:#fff; --ink:#1d2430; --mute:#6b7480; --line:#d8dce2;
          --ok:#1f8a4c; --bad:#c0392b; --warn:#b7791f; --acc:#2563eb; }
  * { box-sizing: border-box; }
  body { margin:0; font: 14px/1.35 system-ui, sans-serif; background:var(--bg); color:var(--ink); }
  header { display:flex; gap:18px; align-items:center; padding:8px 16px; background:#1d2430;
           color:#fff; }
  header h1 { font-size:16px; margin:0; font-weight:600; }
  header .stat { font-variant-numeric: tabular-nums; color:#cfd6e0; }
  #conn.up { color:#7ee2a8; } #conn.down { color:#ff9c8f; }
  main { display:grid; grid-template-columns: minmax(560px, 1fr) 400px; gap:12px; padding:12px; }
  section { background:var(--panel); border:1px solid var(--line); border-radius:6px;
            padding:10px 12px; }
  h2 { font-size:13px; text-transform:uppercase; letter-spacing:.05em; color:var(--mute);
       margin:0 0 8px; }
  table { border-collapse:collapse; width:100%; font-variant-numeric: tabular-nums; }
  th, td { text-align:right; padding:3px 6px; border-bottom:1px solid var(--line);
           white-space:nowrap; }
  th:first-child, td:first-child, td.state, th.state { text-align:left; }
  td.state { font-weight:600; }
  .st-STANDSTILL, .st-GROUP_STANDBY { color:var(--ok); }
  .st-ERROR_STOP, .st-GROUP_ERROR_STOP { color:var(--bad); }
  .st-DISABLED, .st-GROUP_DISABLED { color:var(--mute); }
  .st-DISCRETE_MOTION, .st-CONTINUOUS_MOTION, .st-GROUP_MOVING, .st-SYNCHRONIZED_MOTION
    { color:var(--acc); }
  .err { color:var(--bad); font-size:12px; text-align:left; max-width:260px;
         overflow:hidden; text-overflow:ellipsis; }
  .controls { display:flex; flex-wrap:wrap; gap:4px; align-items:center; margin:4px 0 10px; }
  .controls b { min-width:28px; }
  button { font:inherit; padding:3px 9px; border:1px solid #9aa3af; border-radius:4px;
           background:#eef1f5; cursor:pointer; }
  button:hover:enabled { background:#dfe5ee; }
  button:disabled { color:#a0a7b1; cursor:not-allowed; }
  input { font:inherit; width:70px; padding:2px 4px; }
  #login input { width:120px; }
  #login-status.bad { color:var(--bad); font-weight:600; } #login-status.ok { color:var(--ok); }
  canvas { width:100%; background:#fbfcfd; border:1px solid var(--line); border-radius:4px; }
  #log { font: 12px ui-monospace, monospace; max-height:140px; overflow:auto; color:var(--mute); }
  #log .bad { color:var(--bad); } #log .ok { color:var(--ok); }
  .kv { display:grid; grid-template-columns: 110px 1fr; gap:2px 8px;
        font-variant-numeric: tabular-nums; }
  .kv span:nth-child(odd) { color:var(--mute); }
  progress { width:100%; }
</style>
</head>
<body>
<header>
  <h1>motionplc &middot; <span id="machine">machine</span></h1>
  <span class="stat">cycle <span id="cycle">-</span></span>
  <span class="stat">t = <span id="time">-</span> s</span>
  <span class="stat">snapshot <span id="seq">-</span></span>
  <span id="conn" class="down">connecting...</span>
</header>
<main>
<div>
  <section id="login">
    <h2>Operator</h2>
    <form id="login-form" onsubmit="return false">
      <input id="login-user" placeholder="user" autocomplete="username">
      <input id="login-password" type="password" placeholder="password"
             autocomplete="current-password">
      <button id="login-button" type="submit">Log in</button>
      <button id="logout-button" type="button" disabled>Log out</button>
      <span id="login-status">not logged in: values only</span>
    </form>
  </section>
  <section>
    <h2>Axes</h2>
    <table id="axes">
      <thead><tr><th>axis</th><th class="state">state</th><th>position</th><th>set</th>
        <th>velocity</th><th>following err.</th><th>override</th><th>power</th>
        <th>error</th></tr></thead>
      <tbody></tbody>
    </table>
    <div id="axis-controls"></div>
  </section>
  <section>
    <h2>Tasks</h2>
    <table id="tasks">
      <thead><tr><th>task</th><th>cycles</th><th>exec last</th><th>exec mean</th>
        <th>exec max</th><th>lateness max</th><th>overruns</th></tr></thead>
      <tbody></tbody>
    </table>
  </section>
  <section>
    <h2>Log</h2>
    <div id="log"></div>
  </section>
</div>
<div>
  <section>
    <h2>Program</h2>
    <div class="kv" id="program">
      <span>kind</span><span id="prog-kind">-</span>
      <span>state</span><span id="prog-state">-</span>
      <span>line</span><span id="prog-line">-</span>
      <span>moves</span><span id="prog-moves">-</span>
      <span>path</span><span id="prog-path">-</span>
      <span>message</span><span id="prog-message">-</span>
    </div>
    <progress id="prog-progress" max="1" value="0"></progress>
    <div class="controls">
      <button class="op" data-target="program" data-method="Start">Start</button>
      <button class="op" data-target="program" data-method="Stop">Stop</button>
    </div>
  </section>
  <div id="groups"></div>
</div>
</main>
<script>
"use strict";
let LAYOUT = null, LOGGED = false;
const paths = {};          // group -> [[x, y], ...]
const $ = (id) => document.getElementById(id);
const fmt = (v, d = 4) => (v === null || v === undefined) ? "-" : Number(v).toFixed(d);
const us = (s) => (s === null || s === undefined) ? "-" : (s * 1e6).toFixed(0) + " us";

function log(text, ok) {
  const el = document.createElement("div");
  el.className = ok ? "ok" : "bad";
  el.textContent = new Date().toLocaleTimeString() + "  " + text;
  $("log").prepend(el);
}

function setLogged(user) {
  LOGGED = !!user;
  document.querySelectorAll("button.op").forEach((b) => { b.disabled = !LOGGED; });
  $("logout-button").disabled = !LOGGED;
  const s = $("login-status");
  s.className = LOGGED ? "ok" : "";
  s.textContent = LOGGED ? "logged in as " + user : "not logged in: values only";
}

async function call(target, method, args) {
  const r = await fetch("/api/call", { method: "POST", credentials: "same-origin",
    headers: { "Content-Type": "application/json" },
    body: JSON.stringify({ target, method, args }) });
  let body = {};
  try { body = await r.json(); } catch (e) { body = { text: r.statusText }; }
  const what = target + "." + method + "(" + args.map((a) => JSON.stringify(a)).join(", ") + ")";
  if (r.ok) log(what + ": accepted at cycle " + body.cycle, true);
  else log(what + ": " + r.status + " " + (body.text || ""), false);
  if (r.status === 401) setLogged(null);
  return body;
}

function num(id, dflt) {
  const v = parseFloat($(id).value);
  return Number.isFinite(v) ? v : dflt;
}

function button(label, target, method, args, id) {
  const b = document.createElement("button");
  b.className = "op"; b.textContent = label; b.disabled = !LOGGED;
  if (id) b.id = id;
  b.dataset.target = target; b.dataset.method = method;
  b.onclick = () => call(target, method, args());
  return b;
}

function build(layout) {
  LAYOUT = layout;
  $("machine").textContent = layout.name;
  const tb = $("axes").querySelector("tbody");
  tb.innerHTML = "";
  const ctl = $("axis-controls");
  ctl.innerHTML = "";
  for (const a of layout.axes) {
    const tr = document.createElement("tr");
    tr.id = "axis-" + a.name;
    tr.innerHTML = "<td>" + a.name + " <small>[" + a.units + "]</small></td>" +
      "<td class='state'></td><td class='pos'></td><td class='setpos'></td><td class='vel'>" +
      "</td><td class='ferr'></td><td class='ovr'></td><td class='pwr'></td>" +
      "<td class='err'></td>";
    tb.appendChild(tr);
    const row = document.createElement("div");
    row.className = "controls"; row.id = "controls-" + a.name;
    const t = "axis:" + a.name, none = () => [];
    const name = document.createElement("b"); name.textContent = a.name;
    const step = document.createElement("input");
    step.id = "jog-step-" + a.name; step.value = a.units === "rad" ? "0.1" : "0.01";
    step.title = "jog step [" + a.units + "]";
    const ovr = document.createElement("input");
    ovr.id = "override-" + a.name; ovr.value = "1.0"; ovr.title = "velocity factor";
    row.append(name,
      button("Power on", t, "Power", () => [true], "power-on-" + a.name),
      button("Power off", t, "Power", () => [false], "power-off-" + a.name),
      button("Reset", t, "Reset", none, "reset-" + a.name),
      button("Jog \u2212", t, "Jog", () => [-1, num(step.id, 0.01), 0.0], "jog-minus-" + a.name),
      step,
      button("Jog +", t, "Jog", () => [1, num(step.id, 0.01), 0.0], "jog-plus-" + a.name),
      button("Halt", t, "Halt", none, "halt-" + a.name),
      button("Stop", t, "Stop", none, "stop-" + a.name),
      ovr,
      button("Override", t, "SetOverride", () => [num(ovr.id, 1.0)], "set-override-" + a.name));
    ctl.appendChild(row);
  }
  const gs = $("groups");
  gs.innerHTML = "";
  for (const g of layout.groups) {
    const sec = document.createElement("section");
    sec.id = "group-" + g.name;
    const t = "group:" + g.name, none = () => [];
    sec.innerHTML = "<h2>Group " + g.name + " (" + g.axes.join(", ") + ")</h2>" +
      "<canvas id='path-" + g.name + "' width='420' height='300'></canvas>" +
      "<div class='kv'><span>state</span><span class='gstate'></span>" +
      "<span>path velocity</span><span class='gvel'></span>" +
      "<span>position</span><span class='gpos'></span>" +
      "<span>override</span><span class='govr'></span>" +
      "<span>error</span><span class='gerr err'></span></div>";
    const row = document.createElement("div"); row.className = "controls";
    const ovr = document.createElement("input");
    ovr.id = "override-group-" + g.name; ovr.value = "1.0";
    row.append(
      button("Feed hold", t, "FeedHold", none, "hold-" + g.name),
      button("Continue", t, "FeedContinue", none, "continue-" + g.name),
      button("Halt", t, "Halt", none, "ghalt-" + g.name),
      button("Stop", t, "Stop", none, "gstop-" + g.name),
      ovr,
      button("Override", t, "SetOverride", () => [num(ovr.id, 1.0)], "gset-override-" + g.name));
    sec.appendChild(row);
    const mdi = document.createElement("div"); mdi.className = "controls";
    const line = document.createElement("input");
    line.id = "mdi-" + g.name; line.placeholder = "G1 X10 Y10 F3000"; line.style.width = "220px";
    mdi.append(line, button("MDI", t, "Mdi", () => [line.value], "run-mdi-" + g.name));
    sec.appendChild(mdi);
    gs.appendChild(sec);
    paths[g.name] = [];
  }
  const tt = $("tasks").querySelector("tbody");
  tt.innerHTML = "";
  for (const t of layout.tasks) {
    const tr = document.createElement("tr");
    tr.id = "task-" + t.name;
    tr.innerHTML = "<td>" + t.name + " <small>(" + (t.period * 1e3) + " ms)</small></td>" +
      "<td class='n'></td><td class='last'></td><td class='mean'></td><td class='max'></td>" +
      "<td class='late'></td><td class='over'></td>";
    tt.appendChild(tr);
  }
  document.querySelectorAll("button.op").forEach((b) => {
    if (!b.onclick) b.onclick = () => call(b.dataset.target, b.dataset.method, []);
  });
}

function drawPath(g, gv) {
  const cv = $("path-" + g.name);
  if (!cv || gv.position.length < 2) return;
  const pts = paths[g.name];
  const p = [gv.position[0], gv.position[1]];
  const last = pts[pts.length - 1];
  if (!last || Math.abs(last[0] - p[0]) + Math.abs(last[1] - p[1]) > 1e-9) pts.push(p);
  if (pts.length > 20000) pts.splice(0, pts.length - 20000);
  const ax = LAYOUT.axes.find((a) => a.name === g.axes[0]);
  const ay = LAYOUT.axes.find((a) => a.name === g.axes[1]);
  let x0 = ax.sw_limit_min, x1 = ax.sw_limit_max, y0 = ay.sw_limit_min, y1 = ay.sw_limit_max;
  if (x0 === null || x1 === null || y0 === null || y1 === null) {
    x0 = Math.min(...pts.map((q) => q[0])); x1 = Math.max(...pts.map((q) => q[0]));
    y0 = Math.min(...pts.map((q) => q[1])); y1 = Math.max(...pts.map((q) => q[1]));
    const m = Math.max(x1 - x0, y1 - y0, 1e-3) * 0.1;
    x0 -= m; x1 += m; y0 -= m; y1 += m;
  }
  const W = cv.width, H = cv.height, pad = 28;
  const s = Math.min((W - 2 * pad) / (x1 - x0), (H - 2 * pad) / (y1 - y0));
  const X = (x) => pad + (x - x0) * s, Y = (y) => H - pad - (y - y0) * s;
  const c = cv.getContext("2d");
  c.clearRect(0, 0, W, H);
  c.strokeStyle = "#d8dce2"; c.lineWidth = 1;
  c.strokeRect(X(x0), Y(y1), (x1 - x0) * s, (y1 - y0) * s);
  c.fillStyle = "#6b7480"; c.font = "12px system-ui";
  c.fillText(g.axes[0] + " [" + ax.units + "] " + fmt(x0, 3) + " .. " + fmt(x1, 3), pad, H - 8);
  c.fillText(g.axes[1] + " " + fmt(y0, 3) + " .. " + fmt(y1, 3), pad, 16);
  c.strokeStyle = "#2563eb"; c.lineWidth = 2; c.beginPath();
  pts.forEach((q, i) => (i ? c.lineTo(X(q[0]), Y(q[1])) : c.moveTo(X(q[0]), Y(q[1]))));
  c.stroke();
  c.fillStyle = "#c0392b"; c.beginPath();
  c.arc(X(p[0]), Y(p[1]), 5, 0, 2 * Math.PI); c.fill();
}

function update(s) {
  $("cycle").textContent = s.cycle; $("time").textContent = fmt(s.t, 3);
  $("seq").textContent = s.seq;
  s.axes.forEach((a) => {
    const tr = $("axis-" + a.name); if (!tr) return;
    const q = (c) => tr.querySelector("." + c);
    const st = a.state_name;
    q("state").textContent = st; q("state").className = "state st-" + st;
    q("pos").textContent = fmt(a.actual_position, 5);
    q("setpos").textContent = fmt(a.set_position, 5);
    q("vel").textContent = fmt(a.actual_velocity, 4);
    const ax = LAYOUT.axes.find((x) => x.name === a.name);
    q("ferr").textContent = fmt(a.following_error * 1e6, 1) + " \u00b5" + ax.units;
    q("ovr").textContent = fmt(100 * a.override, 0) + " %";
    q("pwr").textContent = a.powered ? "on" : "off";
    q("err").textContent = a.error_id ? a.error_id + ": " + a.error_text : "";
  });
  s.groups.forEach((gv, i) => {
    const sec = $("group-" + gv.name); if (!sec) return;
    const st = gv.state_name;
    sec.querySelector(".gstate").textContent = st;
    sec.querySelector(".gstate").className = "gstate st-" + st;
    sec.querySelector(".gvel").textContent = fmt(gv.path_velocity, 4);
    sec.querySelector(".gpos").textContent = gv.position.map((v) => fmt(v, 4)).join(", ");
    sec.querySelector(".govr").textContent = fmt(100 * gv.override, 0) + " %";
    sec.querySelector(".gerr").textContent = gv.error_id ? gv.error_id + ": " + gv.error_text : "";
    drawPath(LAYOUT.groups[i], gv);
  });
  s.tasks.forEach((t) => {
    const tr = $("task-" + t.name); if (!tr) return;
    const q = (c) => tr.querySelector("." + c);
    q("n").textContent = t.cycle_count; q("last").textContent = us(t.exec_last);
    q("mean").textContent = us(t.exec_mean); q("max").textContent = us(t.exec_max);
    q("late").textContent = us(t.lateness_max); q("over").textContent = t.overruns;
  });
  const p = s.program;
  $("prog-kind").textContent = p.kind; $("prog-state").textContent = p.state;
  $("prog-line").textContent = p.line || "-";
  $("prog-moves").textContent = p.lines_run + " / " + p.lines_total;
  $("prog-path").textContent = p.path || "-"; $("prog-message").textContent = p.message || "-";
  $("prog-progress").value = p.progress;
}

function connect() {
  const ws = new WebSocket((location.protocol === "https:" ? "wss://" : "ws://") +
                           location.host + "/ws");
  ws.onopen = () => { $("conn").textContent = "live"; $("conn").className = "up"; };
  ws.onclose = () => {
    $("conn").textContent = "disconnected"; $("conn").className = "down";
    setTimeout(connect, 1000);
  };
  ws.onmessage = (ev) => {
    const m = JSON.parse(ev.data);
    if (m.type === "layout") { if (!LAYOUT) build(m.layout); setLogged(LOGGED ? ME : null); }
    else if (m.type === "snapshot" && LAYOUT) update(m.snapshot);
  };
}

let ME = null;
$("login-button").onclick = async () => {
  const r = await fetch("/api/login", { method: "POST", credentials: "same-origin",
    headers: { "Content-Type": "application/json" },
    body: JSON.stringify({ user: $("login-user").value, password: $("login-password").value }) });
  $("login-password").value = "";
  if (r.ok) { ME = (await r.json()).user; setLogged(ME); log("logged in as " + ME, true); }
  else {
    ME = null; setLogged(null);
    $("login-status").className = "bad";
    $("login-status").textContent = r.status + ": wrong user or password";
    log("login refused (" + r.status + ")", false);
  }
};
$("logout-button").onclick = async () => {
  await fetch("/api/logout", { method: "POST", credentials: "same-origin" });
  ME = null; setLogged(null);
};
fetch("/api/me", { credentials: "same-origin" }).then(async (r) => {
  if (r.ok) { ME = (await r.json()).user; setLogged(ME); }
});
connect();
</script>
</body>
</html>
"""
