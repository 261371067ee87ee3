// What a vehicle did against what it was asked, over the last N minutes: heading, speed and
// depth (node_status) each with its desired value (desired_course), under a band of the
// interface's state (status). Shared by the vehicle's own page (fed by its event stream) and
// the topside's vehicle view (fed by its scope polls). Memory is bounded: every series is a
// fixed-size ring, so a page left open for days holds the same few hundred kilobytes.
"use strict";
(function () {
  // Samples closer than this to the previous one of their series are not kept (NAV at 50 Hz
  // would otherwise fill the ring in minutes). Unit: ms.
  const MIN_STEP_MS = 100;
  // 30 minutes at one sample per MIN_STEP_MS, the longest window offered.
  const CAPACITY = 18000;
  const STATE_CAPACITY = 2000;
  const QUANTITIES = ["heading", "speed", "depth"];
  const ACTUAL = "#1f77b4", DESIRED = "#ff7f0e";
  const STATE_COLOURS = {
    INTERFACE_STANDBY: "#bdbdbd", INTERFACE_LISTEN: "#6baed6", INTERFACE_COMMAND: "#31a354",
    INTERFACE_HELM_ERROR: "#fd8d3c", INTERFACE_FS_ERROR: "#de2d26",
  };
  const STATE_OTHER = "#9e9ac8";

  // A fixed-size ring of (time, value) pairs; NaN marks a missing value.
  class Ring {
    constructor(capacity) { this.t = new Float64Array(capacity); this.v = new Float64Array(capacity); this.start = 0; this.length = 0; }
    push(t, v) {
      const cap = this.t.length, i = (this.start + this.length) % cap;
      this.t[i] = t; this.v[i] = v;
      if (this.length < cap) this.length += 1; else this.start = (this.start + 1) % cap;
    }
    at(k) { const i = (this.start + k) % this.t.length; return [this.t[i], this.v[i]]; }
    lastTime() { return this.length ? this.at(this.length - 1)[0] : -Infinity; }
    clear() { this.start = 0; this.length = 0; }
  }

  const num = (v) => (typeof v === "number" && isFinite(v) ? v : NaN);

  class Recorder {
    constructor() {
      this.actual = {}; this.desired = {};
      for (const q of QUANTITIES) { this.actual[q] = new Ring(CAPACITY); this.desired[q] = new Ring(CAPACITY); }
      this.states = []; // [{t, state}], changes only, bounded
      this.lastDraw = null;
    }
    clear() {
      for (const q of QUANTITIES) { this.actual[q].clear(); this.desired[q].clear(); }
      this.states = [];
    }
    add(which, t, values, force) {
      for (const q of QUANTITIES) {
        const r = which[q], v = num(values[q]);
        if (isNaN(v) && !force) continue;
        if (!force && t - r.lastTime() < MIN_STEP_MS) continue;
        r.push(t, v);
      }
    }
    // node_status as JSON (proto field names).
    nav(t, msg) {
      if (!msg) return;
      this.add(this.actual, t, { heading: msg.pose && msg.pose.heading, speed: msg.speed && msg.speed.over_ground, depth: msg.global_fix && msg.global_fix.depth });
    }
    // desired_course as JSON: a new setpoint is always kept (it is what the plot is about).
    course(t, msg) {
      if (!msg) return;
      this.add(this.desired, t, { heading: msg.heading, speed: msg.speed, depth: msg.depth }, false);
    }
    state(t, state) {
      if (typeof state !== "string") return;
      const last = this.states[this.states.length - 1];
      if (last && last.state === state) return;
      this.states.push({ t, state });
      if (this.states.length > STATE_CAPACITY) this.states.shift();
    }
  }

  function niceRange(lo, hi) {
    if (!isFinite(lo) || !isFinite(hi)) return [0, 1];
    if (hi - lo < 1e-6) return [lo - 0.5, hi + 0.5];
    const pad = (hi - lo) * 0.08;
    return [lo - pad, hi + pad];
  }

  // Draws the band and the three panels on `canvas` for the window ending at `now`; returns
  // (and keeps in recorder.lastDraw) what was drawn, for tests and the page's legend.
  function draw(canvas, rec, minutes, now) {
    const ctx = canvas.getContext("2d");
    const W = canvas.width, H = canvas.height;
    const left = 56, right = 10, bandTop = 18, bandH = 16, gap = 22;
    const panelH = Math.floor((H - bandTop - bandH - gap * 3 - 18) / 3);
    const span = minutes * 60000, t0 = now - span;
    const X = (t) => left + (t - t0) / span * (W - left - right);
    ctx.clearRect(0, 0, W, H);
    ctx.fillStyle = "#fff"; ctx.fillRect(0, 0, W, H);
    ctx.font = "11px sans-serif"; ctx.textBaseline = "alphabetic";
    const drawn = { minutes, band: [] };
    // The interface's state as a band: each state holds until the next change.
    ctx.fillStyle = "#333"; ctx.fillText("interface state", 2, bandTop - 4);
    for (let i = 0; i < rec.states.length; i++) {
      const s = rec.states[i], end = i + 1 < rec.states.length ? rec.states[i + 1].t : now;
      if (end < t0) continue;
      const a = X(Math.max(s.t, t0)), b = X(Math.min(end, now));
      ctx.fillStyle = STATE_COLOURS[s.state] || STATE_OTHER;
      ctx.fillRect(a, bandTop, Math.max(1, b - a), bandH);
      drawn.band.push(s.state);
      if (b - a > 90) { ctx.fillStyle = "#000"; ctx.fillText(s.state.replace("INTERFACE_", ""), a + 3, bandTop + 12); }
    }
    ctx.strokeStyle = "#bbb"; ctx.strokeRect(left, bandTop, W - left - right, bandH);
    QUANTITIES.forEach((q, k) => {
      const top = bandTop + bandH + gap + k * (panelH + gap);
      const series = [[rec.actual[q], ACTUAL, false], [rec.desired[q], DESIRED, true]];
      let lo = Infinity, hi = -Infinity;
      if (q === "heading") { lo = 0; hi = 360; } else {
        for (const [r] of series) for (let i = 0; i < r.length; i++) { const [t, v] = r.at(i); if (t >= t0 && !isNaN(v)) { lo = Math.min(lo, v); hi = Math.max(hi, v); } }
        [lo, hi] = niceRange(lo, hi);
        if (q === "speed" || q === "depth") lo = Math.min(lo, 0);
      }
      // Depth grows downwards, as under the sea.
      const Y = q === "depth" ? (v) => top + (v - lo) / (hi - lo) * panelH : (v) => top + panelH - (v - lo) / (hi - lo) * panelH;
      ctx.strokeStyle = "#bbb"; ctx.lineWidth = 1; ctx.strokeRect(left, top, W - left - right, panelH);
      ctx.fillStyle = "#333";
      ctx.fillText({ heading: "heading (deg)", speed: "speed (m/s)", depth: "depth (m)" }[q], left, top - 5);
      const fmt = (v) => (Math.abs(hi - lo) >= 10 ? v.toFixed(0) : v.toFixed(1));
      ctx.textAlign = "right";
      ctx.fillText(fmt(q === "depth" ? lo : hi), left - 4, top + 10); ctx.fillText(fmt(q === "depth" ? hi : lo), left - 4, top + panelH);
      ctx.textAlign = "left";
      drawn[q] = {};
      ctx.save(); ctx.beginPath(); ctx.rect(left, top, W - left - right, panelH); ctx.clip();
      for (const [r, colour, step] of series) {
        ctx.strokeStyle = colour; ctx.lineWidth = step ? 2 : 1.5; ctx.setLineDash(step ? [6, 3] : []);
        ctx.beginPath();
        let n = 0, prev = null;
        for (let i = 0; i < r.length; i++) {
          const [t, v] = r.at(i);
          const next = i + 1 < r.length ? r.at(i + 1)[0] : now;
          if (next < t0 || isNaN(v)) { prev = null; continue; }
          const x = X(Math.max(t, t0)), y = Y(v);
          // A heading through north is a jump, not a sweep across the panel; a long silence
          // (over 5 s between samples) is a gap.
          const broken = !prev || (q === "heading" && Math.abs(v - prev[1]) > 180) || (!step && t - prev[2] > 5000);
          if (step && prev && !broken) ctx.lineTo(x, prev[0]);
          if (broken) ctx.moveTo(x, y); else ctx.lineTo(x, y);
          if (step) ctx.lineTo(X(Math.min(next, now)), y);
          prev = [y, v, t]; n += 1;
        }
        ctx.stroke();
        drawn[q][step ? "desired" : "actual"] = n;
      }
      ctx.restore(); ctx.setLineDash([]);
    });
    // Time axis: minutes before now.
    ctx.fillStyle = "#333"; ctx.textAlign = "center";
    const yAxis = H - 4;
    for (let m = 0; m <= minutes; m += minutes > 10 ? 5 : 1) ctx.fillText(m === 0 ? "now" : "−" + m + " min", X(now - m * 60000), yAxis);
    ctx.textAlign = "left";
    rec.lastDraw = drawn;
    return drawn;
  }

  // The legend as DOM, once: the colours of actual and desired and of each state.
  function legend() {
    const span = document.createElement("span");
    const item = (colour, text, dashed) => {
      const s = document.createElement("span");
      s.style.marginRight = "1em";
      const sw = document.createElement("span");
      sw.style.cssText = "display:inline-block;width:18px;height:0;margin-right:4px;vertical-align:middle;border-top:" + (dashed ? "2px dashed " : "3px solid ") + colour;
      s.append(sw, text);
      return s;
    };
    span.append(item(ACTUAL, "actual (node_status)"), item(DESIRED, "desired (desired_course)", true));
    for (const [k, c] of Object.entries(STATE_COLOURS)) {
      const s = document.createElement("span");
      s.style.cssText = "margin-right:.6em;padding:0 4px;background:" + c;
      s.textContent = k.replace("INTERFACE_", "");
      span.append(s);
    }
    return span;
  }

  window.FrontseatPlots = { Ring, Recorder, draw, legend, CAPACITY, MIN_STEP_MS, STATE_COLOURS, ACTUAL, DESIRED };
})();
