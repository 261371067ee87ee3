// frontseat web scope and commander. Everything arrives pushed over one EventSource
// (/api/events); the page keeps its model in `window.frontseat.model` (tests read it) and
// renders from it at most ten times a second. No library, no network but this server.
"use strict";
(function () {
  const $ = (id) => document.getElementById(id);
  const params = new URLSearchParams(location.hash.slice(1));
  if (params.get("token")) sessionStorage.setItem("frontseat-token", params.get("token"));
  const token = sessionStorage.getItem("frontseat-token") || "";
  const q = (path) => token ? path + (path.includes("?") ? "&" : "?") + "token=" + encodeURIComponent(token) : path;
  const authHeaders = () => token ? { Authorization: "Bearer " + token } : {};

  const model = {
    connected: false,
    groups: new Map(), // name -> {info, latest, count}
    track: [],
    statusHistory: [],
    timeline: [],
    sent: [],
    stats: {},
    navCount: 0,
    lastNav: null,
    lastNavReceivedAt: 0,
    commander: null,
    responses: [],
  };
  const ui = { expanded: new Set(), historyGroup: null, history: [], dirty: true, filter: null };
  // What the vehicle did against what it was asked (plots.js): bounded rings.
  const plots = new FrontseatPlots.Recorder();
  window.frontseat = { model, ui, plots };

  // ---------- events ----------
  function applyMsg(ev) {
    let g = model.groups.get(ev.group);
    if (!g) { g = { info: { group: ev.group, type: ev.type }, latest: null, count: 0 }; model.groups.set(ev.group, g); }
    g.latest = ev;
    g.count += 1;
    if (ev.msg) plotMsg(ev);
    if (ev.group === "goby::middleware::frontseat::node_status" && ev.msg) {
      model.navCount += 1;
      model.lastNav = ev;
      model.lastNavReceivedAt = Date.now();
      const lf = ev.msg.local_fix;
      if (lf && typeof lf.x === "number") {
        const last = model.track[model.track.length - 1];
        if (!last || Math.hypot(lf.x - last[0], lf.y - last[1]) >= 0.5) model.track.push([lf.x, lf.y]);
        if (model.track.length > 5000) model.track.shift();
      }
    }
    if (ev.group === "goby::middleware::frontseat::status" && ev.msg) statusChange(ev);
    if (ev.group === "goby::middleware::frontseat::command_response" && ev.msg) {
      model.responses.push(ev);
      matchResponse(ev);
    }
    if (ui.historyGroup === ev.group) {
      ui.history.push(ev);
      if (ui.history.length > 1000) ui.history.shift();
    }
  }

  function plotMsg(ev) {
    if (ev.group === "goby::middleware::frontseat::node_status") plots.nav(ev.time, ev.msg);
    else if (ev.group === "goby::middleware::frontseat::desired_course") plots.course(ev.time, ev.msg);
    else if (ev.group === "goby::middleware::frontseat::command_request" && ev.msg.desired_course) plots.course(ev.time, ev.msg.desired_course);
    else if (ev.group === "goby::middleware::frontseat::status") plots.state(ev.time, ev.msg.state);
  }

  function statusChange(ev) {
    model.statusHistory.push(ev);
    if (model.statusHistory.length > 1000) model.statusHistory.shift();
    const prev = model.statusHistory.length > 1 ? model.statusHistory[model.statusHistory.length - 2].msg : {};
    const changes = [];
    for (const k of ["state", "frontseat_state", "helm_state", "helm_error", "frontseat_error"]) {
      if (ev.msg[k] !== prev[k]) changes.push(k + ": " + (prev[k] || "—") + " → " + (ev.msg[k] || "—"));
    }
    if (changes.length) {
      model.timeline.push({ time: ev.time, text: changes.join("; "), error: /ERROR_(?!.*NONE)|_ERROR\b/.test(changes.join(" ")) });
      if (model.timeline.length > 500) model.timeline.shift();
    }
  }

  function onSnapshot(s) {
    model.groups.clear();
    for (const info of s.groups) model.groups.set(info.group, { info, latest: null, count: info.count });
    for (const ev of s.latest) { const g = model.groups.get(ev.group); if (g) g.latest = ev; }
    // A reconnect starts the plots again from what the server kept.
    plots.clear();
    for (const ev of s.status_history) if (ev.msg) plotMsg(ev);
    for (const ev of s.latest.slice().sort((a, b) => a.time - b.time)) if (ev.msg && ev.group !== "goby::middleware::frontseat::status") plotMsg(ev);
    model.track = s.track.slice();
    model.statusHistory = []; model.timeline = [];
    for (const ev of s.status_history) statusChange(ev);
    model.sent = s.sent.map((e) => Object.assign(e, { request_id: e.message ? e.message.request_id : undefined }));
    const nav = model.groups.get("goby::middleware::frontseat::node_status");
    if (nav && nav.latest) model.lastNav = nav.latest;
  }

  // A send of this tab comes back as an echo (every tab sees every send): keep one row.
  function onSent(e) {
    const key = JSON.stringify(e.message);
    const mine = model.sent.find((s) => s.local && !s.echoed && s.group === e.group && JSON.stringify(s.message) === key);
    if (mine) { mine.echoed = true; return; }
    e.request_id = e.message ? e.message.request_id : undefined;
    model.sent.push(e);
    if (model.sent.length > 100) model.sent.shift();
    for (const r of model.responses) matchResponse(r);
  }

  function connect() {
    const es = new EventSource(q("/api/events"));
    es.onopen = () => { model.connected = true; setConn(); };
    es.onerror = () => { model.connected = false; setConn(); };
    es.onmessage = (m) => {
      let ev;
      try { ev = JSON.parse(m.data); } catch (e) { return; }
      if (ev.kind === "snapshot") onSnapshot(ev);
      else if (ev.kind === "msg") applyMsg(ev);
      else if (ev.kind === "stats") model.stats = ev;
      else if (ev.kind === "sent") onSent(ev.entry);
      ui.dirty = true;
    };
  }
  function setConn() {
    $("conn").textContent = model.connected ? "live" : "disconnected";
    $("conn").className = "conn " + (model.connected ? "up" : "down");
  }

  // ---------- rendering helpers ----------
  const fmtTime = (ms) => ms ? new Date(ms).toISOString().slice(11, 23) : "";
  const el = FrontseatForm.el;
  const tree = FrontseatForm.tree;


  // ---------- scope ----------
  // Rows are made once per group and updated in place, so a click is never lost to a row
  // replaced under the pointer at 10 Hz.
  const rows = new Map();
  function scopeRow(name) {
    let r = rows.get(name);
    if (r) return r;
    const cells = {};
    const td = (k) => (cells[k] = el("td", { class: k }));
    const row = el("tr", { class: "group-row", "data-group": name },
      el("td", {}, el("code", {}, name)), td("type"), td("layer"), td("count"), td("time"), td("origin"),
      el("td", {}, el("button", { class: "hist", onclick: (e) => { e.stopPropagation(); openHistory(name); } }, "history")));
    row.addEventListener("click", () => { ui.expanded.has(name) ? ui.expanded.delete(name) : ui.expanded.add(name); render(true); });
    const fields = el("tr", { class: "fields", "data-fields-of": name }, el("td", { colspan: 7 }));
    r = { row, cells, fields, shownSeq: -1 };
    rows.set(name, r);
    return r;
  }
  function renderScope() {
    const body = $("groups").querySelector("tbody");
    const names = [...model.groups.keys()].sort();
    const order = names.join("\n");
    if (ui.order !== order) {
      ui.order = order;
      body.replaceChildren();
      for (const n of names) { const r = scopeRow(n); body.append(r.row, r.fields); }
    }
    for (const name of names) {
      const g = model.groups.get(name); const r = scopeRow(name); const l = g.latest;
      const visible = !ui.filter || ui.filter.test(name) || ui.filter.test(g.info.type || "");
      r.row.hidden = !visible;
      r.cells.type.textContent = g.info.type || ""; r.cells.layer.textContent = g.info.layer || "";
      r.cells.count.textContent = g.count; r.cells.time.textContent = l ? fmtTime(l.time) : "";
      r.cells.origin.textContent = l ? l.origin : "";
      const open = visible && ui.expanded.has(name);
      r.fields.hidden = !open;
      if (open && r.shownSeq !== (l ? l.seq : 0)) {
        r.shownSeq = l ? l.seq : 0;
        const pubs = (g.info.publishers || []).join(", ");
        const content = l ? (l.msg ? tree(l.msg) : el("span", { class: "bad-text" }, l.error || "")) : el("span", { class: "muted" }, "no message yet");
        r.fields.firstChild.replaceChildren(el("div", { class: "muted" }, "published by: " + (pubs || "—") + (l ? " · seq " + l.seq + " · " + l.bytes + " bytes" : "")), content);
      }
      if (!open) r.shownSeq = -1;
    }
  }
  async function openHistory(group) {
    ui.historyGroup = group; ui.history = [];
    $("history").hidden = false; $("history-group").textContent = group;
    try {
      const r = await fetch(q("/api/history?group=" + encodeURIComponent(group)), { headers: authHeaders() });
      const h = await r.json();
      ui.history = (h.history || []).concat(ui.history.filter((e) => !(h.history || []).some((x) => x.seq === e.seq)));
    } catch (e) { /* the live part still fills in */ }
    ui.dirty = true; render(true);
  }
  function renderHistory() {
    if (!ui.historyGroup) return;
    const body = $("history-rows");
    body.replaceChildren();
    for (const ev of ui.history.slice(-200).reverse()) {
      body.append(el("tr", {}, el("td", {}, ev.seq), el("td", {}, fmtTime(ev.time)), el("td", {}, ev.origin),
        el("td", {}, el("code", {}, JSON.stringify(ev.msg !== undefined ? ev.msg : ev.error)))));
    }
  }

  // ---------- commander ----------
  async function loadCommander() {
    try {
      const r = await fetch(q("/api/commander"), { headers: authHeaders() });
      if (!r.ok) { $("cmd-cannot").textContent = "commander unavailable: " + r.status; return; }
      model.commander = await r.json();
    } catch (e) { $("cmd-cannot").textContent = "commander unavailable"; return; }
    const sel = $("cmd-group");
    sel.replaceChildren();
    for (const g of model.commander.groups) sel.append(el("option", { value: g.group }, g.group));
    if (!model.commander.can_send) $("cmd-cannot").textContent = "this server refuses sends (no token configured on a non-loopback address)";
    buildForm();
  }
  function currentCommand() { return model.commander && model.commander.groups.find((g) => g.group === $("cmd-group").value); }
  function buildForm() {
    const g = currentCommand();
    const form = $("cmd-form");
    form.replaceChildren();
    if (!g) return;
    $("cmd-type").textContent = g.type;
    form.append(FrontseatForm.fieldsOf(g.schema, "", validate));
    validate();
  }
  // The interface's command gate ([limits]) as the server reports it, per group and field.
  function limitFor(path) {
    const lim = model.commander && model.commander.limits;
    const g = lim && lim[$("cmd-group").value];
    return g && g[path];
  }
  const collect = () => FrontseatForm.collect($("cmd-form"), limitFor);
  function validate() {
    const { errors } = collect();
    $("cmd-result").textContent = errors.length ? errors.join("; ") : "";
    $("cmd-result").className = errors.length ? "bad-text" : "";
    $("cmd-send").disabled = errors.length > 0 || !(model.commander && model.commander.can_send);
  }
  async function send() {
    const g = currentCommand(); if (!g) return;
    const { message, errors } = collect();
    if (errors.length) return;
    const entry = { local: true, time: Date.now(), group: g.group, message, result: "sending…", response: null, request_id: message.request_id };
    model.sent.push(entry); ui.localSent = (ui.localSent || 0) + 1;
    try {
      const r = await fetch("/api/send", { method: "POST", headers: Object.assign({ "Content-Type": "application/json" }, authHeaders()), body: JSON.stringify({ group: g.group, message }) });
      const text = await r.text();
      let j = null; try { j = JSON.parse(text); } catch (e) { /* plain-text refusal */ }
      if (r.ok && j && j.ok) { entry.result = "published, " + j.sent.delivered + " subscriber(s)"; entry.ok = true; }
      else { entry.result = "refused (" + r.status + "): " + (j ? j.error : text); entry.ok = false; }
    } catch (e) { entry.result = "failed: " + e; entry.ok = false; }
    $("cmd-result").textContent = entry.result;
    $("cmd-result").className = entry.ok ? "ok-text" : "bad-text";
    for (const resp of model.responses) matchResponse(resp);
    ui.dirty = true; render(true);
  }
  function matchResponse(ev) {
    for (const s of model.sent) {
      if (s.response || s.request_id === undefined || s.group !== "goby::middleware::frontseat::command_request") continue;
      if ((ev.msg.request_id || 0) === s.request_id && ev.time >= s.time - 1000) {
        s.response = ev.msg; ui.dirty = true;
      }
    }
  }
  function renderLog() {
    const body = $("cmd-log").querySelector("tbody");
    body.replaceChildren();
    for (const s of model.sent.slice(-100).reverse()) {
      const resp = s.response ? (s.response.request_successful ? "accepted" : "refused: " + (s.response.error_string || s.response.error_code)) : "";
      body.append(el("tr", { class: "sent-row" }, el("td", {}, fmtTime(s.time)), el("td", {}, el("code", {}, s.group)),
        el("td", {}, el("code", {}, JSON.stringify(s.message))), el("td", { class: "result" }, s.result || (s.delivered !== undefined ? "published, " + s.delivered + " subscriber(s)" : "")),
        el("td", { class: "response" }, resp)));
    }
  }

  // ---------- vehicle ----------
  function renderVehicle() {
    const st = model.groups.get("goby::middleware::frontseat::status");
    const m = (st && st.latest && st.latest.msg) || {};
    $("st-interface").textContent = m.state || "?"; $("st-frontseat").textContent = m.frontseat_state || "?";
    $("st-helm").textContent = m.helm_state || "?"; $("st-helm-error").textContent = m.helm_error || (m.state ? "none" : "?");
    $("st-fs-error").textContent = m.frontseat_error || (m.state ? "none" : "?");
    const det = model.groups.get("frontseat::interface::detail");
    const d = (det && det.latest && det.latest.msg) || {};
    const dbody = $("detail").querySelector("tbody"); dbody.replaceChildren();
    for (const [k, v] of Object.entries(d)) if (typeof v !== "object") dbody.append(el("tr", {}, el("td", {}, k), el("td", { "data-detail": k }, String(v))));
    const tbody = $("timeline").querySelector("tbody"); tbody.replaceChildren();
    for (const t of model.timeline.slice(-100).reverse()) tbody.append(el("tr", { class: t.error ? "bad-text" : "" }, el("td", {}, fmtTime(t.time)), el("td", {}, t.text)));
    drawMap();
    if (!$("vehicle").hidden) FrontseatPlots.draw($("plots"), plots, Number($("plot-minutes").value) || 5, Date.now());
  }
  function drawMap() {
    const c = $("map"); const ctx = c.getContext("2d"); const W = c.width, H = c.height;
    ctx.clearRect(0, 0, W, H);
    const pts = model.track.slice();
    const nav = model.lastNav && model.lastNav.msg;
    if (nav && nav.local_fix) pts.push([nav.local_fix.x, nav.local_fix.y]);
    let minx = -50, maxx = 50, miny = -50, maxy = 50;
    for (const [x, y] of pts) { minx = Math.min(minx, x); maxx = Math.max(maxx, x); miny = Math.min(miny, y); maxy = Math.max(maxy, y); }
    const span = Math.max(maxx - minx, maxy - miny) * 1.15;
    const cx = (minx + maxx) / 2, cy = (miny + maxy) / 2, s = W / span;
    const X = (x) => W / 2 + (x - cx) * s, Y = (y) => H / 2 - (y - cy) * s;
    const step = Math.pow(10, Math.floor(Math.log10(span / 5)));
    const grid = span / step > 20 ? step * 5 : step;
    ctx.strokeStyle = "#e3e8ee"; ctx.lineWidth = 1; ctx.beginPath();
    for (let gx = Math.floor((cx - span / 2) / grid) * grid; gx <= cx + span / 2; gx += grid) { ctx.moveTo(X(gx), 0); ctx.lineTo(X(gx), H); }
    for (let gy = Math.floor((cy - span / 2) / grid) * grid; gy <= cy + span / 2; gy += grid) { ctx.moveTo(0, Y(gy)); ctx.lineTo(W, Y(gy)); }
    ctx.stroke();
    ctx.strokeStyle = "#abc"; ctx.beginPath(); ctx.moveTo(X(0), 0); ctx.lineTo(X(0), H); ctx.moveTo(0, Y(0)); ctx.lineTo(W, Y(0)); ctx.stroke();
    // scale bar
    ctx.fillStyle = "#333"; ctx.fillRect(10, H - 20, grid * s, 3); ctx.fillText(grid + " m", 10, H - 25);
    ctx.strokeStyle = "#36c"; ctx.lineWidth = 2; ctx.beginPath();
    pts.forEach(([x, y], i) => (i ? ctx.lineTo(X(x), Y(y)) : ctx.moveTo(X(x), Y(y)))); ctx.stroke();
    if (nav && nav.local_fix) {
      const vx = X(nav.local_fix.x), vy = Y(nav.local_fix.y);
      const hdg = ((nav.pose && nav.pose.heading) || 0) * Math.PI / 180;
      ctx.save(); ctx.translate(vx, vy); ctx.rotate(hdg); ctx.fillStyle = "#c30";
      ctx.beginPath(); ctx.moveTo(0, -12); ctx.lineTo(6, 8); ctx.lineTo(-6, 8); ctx.closePath(); ctx.fill(); ctx.restore();
      // The newest commanded course, whichever way it came (desired_course or command_request).
      const dc = model.groups.get("goby::middleware::frontseat::desired_course");
      const cr = model.groups.get("goby::middleware::frontseat::command_request");
      const a = dc && dc.latest && dc.latest.msg ? dc.latest : null;
      const b = cr && cr.latest && cr.latest.msg && cr.latest.msg.desired_course ? cr.latest : null;
      const newest = a && b ? (a.seq > b.seq ? a : b) : a || b;
      const d = newest ? (newest === b ? b.msg.desired_course : a.msg) : null;
      if (d) {
        const dh = (d.heading || 0) * Math.PI / 180;
        ctx.strokeStyle = "#2a2"; ctx.setLineDash([6, 4]); ctx.beginPath(); ctx.moveTo(vx, vy);
        ctx.lineTo(vx + Math.sin(dh) * 60, vy - Math.cos(dh) * 60); ctx.stroke(); ctx.setLineDash([]);
      }
      $("map-legend").textContent = "x " + nav.local_fix.x.toFixed(1) + " m, y " + nav.local_fix.y.toFixed(1) + " m, heading " +
        ((nav.pose && nav.pose.heading) || 0).toFixed(1) + "°" + (d ? ", commanded " + (d.heading || 0).toFixed(1) + "° at " + (d.speed || 0) + " m/s" : "") + " · grid " + grid + " m";
    }
  }

  // ---------- loop ----------
  function render(force) {
    if (!ui.dirty && !force) return;
    ui.dirty = false;
    const s = model.stats;
    $("stats").textContent = s.messages !== undefined ? s.messages + " msgs · missed by this tab " + s.dropped_here + " · nav " + model.navCount : "";
    if (!$("pause").checked || force) { renderScope(); renderHistory(); }
    renderLog(); renderVehicle();
  }
  setInterval(() => render(false), 100);

  for (const b of document.querySelectorAll("button.tab")) {
    b.addEventListener("click", () => {
      for (const x of document.querySelectorAll("button.tab")) x.classList.toggle("active", x === b);
      for (const p of document.querySelectorAll(".panel")) p.hidden = p.id !== b.dataset.tab;
      render(true);
    });
  }
  $("filter").addEventListener("input", () => {
    const v = $("filter").value;
    try { ui.filter = v ? new RegExp(v) : null; $("filter-error").textContent = ""; } catch (e) { $("filter-error").textContent = "bad regex"; }
    render(true);
  });
  $("pause").addEventListener("change", () => render(true));
  $("plot-legend").append(FrontseatPlots.legend());
  $("plot-minutes").addEventListener("change", () => render(true));
  $("history-close").addEventListener("click", () => { ui.historyGroup = null; $("history").hidden = true; });
  $("cmd-group").addEventListener("change", buildForm);
  $("cmd-send").addEventListener("click", send);
  fetch("/api/info").then((r) => r.json()).then((i) => { $("vehicle-name").textContent = i.name; }).catch(() => {});
  connect();
  loadCommander();
})();
