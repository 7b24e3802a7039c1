/* coplan plan viewer: draws the embedded plan data (no network, no libraries).
   Cell: canvas. Timelines and clearance charts: SVG built here. Text from the data is only
   ever set through textContent / setAttribute, never parsed as HTML. */
(function () {
  "use strict";
  const SVGNS = "http://www.w3.org/2000/svg";
  const D = JSON.parse(document.getElementById("coplan-data").textContent);
  const P = D.problem;
  const ARMS = P.arms;
  const ARM = {};
  ARMS.forEach(function (a, i) { ARM[a.name] = i; });
  const TRAIL = 2.0; // s of tip trail
  const LABEL_W = 78;
  const PHASE_TEXT = { moving: "moving", picking: "picking", placing: "placing", idle: "waiting" };

  // ------------------------------------------------------------------ helpers
  function decode(e) {
    const bin = atob(e.b64);
    const bytes = new Uint8Array(bin.length);
    for (let i = 0; i < bin.length; i++) bytes[i] = bin.charCodeAt(i);
    if (e.dtype === "f8") return new Float64Array(bytes.buffer);
    if (e.dtype === "f4") return new Float32Array(bytes.buffer);
    if (e.dtype === "i4") return new Int32Array(bytes.buffer);
    return bytes;
  }
  function num(x, nd) {
    if (x === null || x === undefined || !isFinite(x)) return "\u2013";
    return Number(x).toFixed(nd === undefined ? 2 : nd);
  }
  function clamp(x, lo, hi) { return Math.max(lo, Math.min(hi, x)); }
  // the units of a violation's value and limit, where one kind has one (the verifier's, coplan.verify.verdict)
  const VIOLATION_UNITS = { collision: "m", clearance: "m", uncertified: "m", joint_limit: "rad", velocity: "rad/s",
    acceleration: "rad/s\u00b2", jerk: "rad/s\u00b3", pick_missed: "m", place_missed: "m" };
  function plural(n, word) { return n + " " + word + (n === 1 ? "" : "s"); }
  function el(tag, attrs, text) {
    const e = document.createElement(tag);
    if (attrs) for (const k in attrs) e.setAttribute(k, attrs[k]);
    if (text !== undefined) e.textContent = text;
    return e;
  }
  function sv(tag, attrs, text) {
    const e = document.createElementNS(SVGNS, tag);
    if (attrs) for (const k in attrs) e.setAttribute(k, attrs[k]);
    if (text !== undefined) e.textContent = text;
    return e;
  }
  function rgb(hex) { const v = parseInt(hex.slice(1), 16); return [(v >> 16) & 255, (v >> 8) & 255, v & 255]; }
  function rgba(hex, a) { const c = rgb(hex); return "rgba(" + c[0] + "," + c[1] + "," + c[2] + "," + a + ")"; }
  // WCAG relative luminance; text on an arm's colour takes black or white, whichever contrasts more
  // (white fruit ids on the orange arm's bars were 2.5:1), and an arm's name on white a shade of its
  // colour dark enough for 4.5:1 (the palette's orange, cyan and olive were 2.0-2.5:1)
  function luminance(c) { return c.map(function (v) { v /= 255; return v <= 0.03928 ? v / 12.92 : Math.pow((v + 0.055) / 1.055, 2.4); })
    .reduce(function (acc, v, i) { return acc + v * [0.2126, 0.7152, 0.0722][i]; }, 0); }
  function ink(hex) { const L = luminance(rgb(hex)); return (1.05 / (L + 0.05)) >= ((L + 0.05) / 0.05) ? "#fff" : "#000"; }
  function onWhite(hex) {
    let c = rgb(hex);
    while (1.05 / (luminance(c) + 0.05) < 4.5) c = c.map(function (v) { return Math.floor(v * 0.9); });
    return "rgb(" + c.join(",") + ")";
  }
  function blend(h1, h2) {
    const a = rgb(h1), b = rgb(h2);
    return "#" + [0, 1, 2].map(function (i) { return Math.round((a[i] + b[i]) / 2).toString(16).padStart(2, "0"); }).join("");
  }
  // a row's arms ride on the carriage: their base is shifted by its x (sh; 0 for a cell)
  function fk(arm, q, sh) {
    const b = [arm.base[0] + (sh || 0), arm.base[1]], l = arm.links;
    const ex = b[0] + l[0] * Math.cos(q[0]), ey = b[1] + l[0] * Math.sin(q[0]);
    return [[b[0], b[1]], [ex, ey], [ex + l[1] * Math.cos(q[0] + q[1]), ey + l[1] * Math.sin(q[0] + q[1])]];
  }
  function segDist(px, py, ax, ay, bx, by) {
    const ux = bx - ax, uy = by - ay, uu = ux * ux + uy * uy;
    const s = uu > 0 ? clamp(((px - ax) * ux + (py - ay) * uy) / uu, 0, 1) : 0;
    return Math.hypot(px - ax - s * ux, py - ay - s * uy);
  }

  // ------------------------------------------------------------------ plans
  function prepare(p, k) {
    const pl = Object.assign({}, p);
    pl.index = k;
    pl.track = decode(p.display.q);
    pl.exactQ = Float64Array.from(decode(p.exact.q), function (v) { return v * p.exact.scale; });
    pl.gx = p.gantry ? decode(p.gantry) : null;
    pl.K = p.display.n;
    pl.N = p.exact.n;
    pl.clear = p.clearance.map(function (c) { return { arms: c.arms, d: decode(c.d), color: blend(ARMS[ARM[c.arms[0]]].color, ARMS[ARM[c.arms[1]]].color) }; });
    pl.fruit = {};
    P.fruits.forEach(function (f) { pl.fruit[f.id] = { pick: null, place: null, arm: null }; });
    p.events.forEach(function (e) {
      const f = pl.fruit[e.fruit];
      if (!f) return;
      if (e.kind === "pick") { f.pick = e; f.arm = e.arm; } else { f.place = e; }
    });
    pl.binOrder = {};
    const places = p.events.filter(function (e) { return e.kind === "place"; }).sort(function (a, b) { return a.t_end - b.t_end; });
    places.forEach(function (e) { (pl.binOrder[e.arm] = pl.binOrder[e.arm] || []).push(e.fruit); });
    pl.placedAt = places.map(function (e) { return e.t_end; });  // (the running harvest count beside the clock)
    pl.waitNotes = {};
    Object.keys(p.waits).forEach(function (a) { pl.waitNotes[a] = p.waits[a]; });
    pl.contacts = p.violations.filter(function (v) { return v.kind === "collision" || v.kind === "clearance"; });
    return pl;
  }
  const PLANS = D.plans.map(prepare);
  function placedBy(pl, t) {  // fruit placed by t
    let n = 0;
    while (n < pl.placedAt.length && pl.placedAt[n] <= t + 1e-9) n++;
    return n;
  }
  const T_END = Math.max(1e-3, Math.max.apply(null, PLANS.map(function (p) { return p.duration; })));

  function qTrack(pl, a, t) {
    const K = pl.K, f = clamp(t, 0, pl.duration) * pl.display.rate;
    const i = clamp(Math.floor(f), 0, K - 1), j = Math.min(i + 1, K - 1), w = clamp(f - i, 0, 1);
    const o = a * K * 2;
    return [pl.track[o + 2 * i] * (1 - w) + pl.track[o + 2 * j] * w, pl.track[o + 2 * i + 1] * (1 - w) + pl.track[o + 2 * j + 1] * w];
  }
  // a row plan's carriage x at time t (0 for a cell)
  function gxAt(pl, t) {
    if (!pl.gx) return 0;
    const K = pl.gx.length, f = clamp(t, 0, pl.duration) * pl.display.rate;
    const i = clamp(Math.floor(f), 0, K - 1), j = Math.min(i + 1, K - 1), w = clamp(f - i, 0, 1);
    return pl.gx[i] * (1 - w) + pl.gx[j] * w;
  }
  // the replay (Plan.sample): linear between the plan's own samples; velocity of the interval
  function qExact(pl, a, t) {
    const N = pl.N, dt = pl.exact.dt, o = a * N * 2, Q = pl.exactQ;
    if (N < 2) return { q: [Q[o], Q[o + 1]], qd: [0, 0] };
    const tc = clamp(t, 0, pl.duration), f = tc / dt;
    const i = clamp(Math.floor(f), 0, N - 2), w = clamp(f - i, 0, 1);
    const q = [Q[o + 2 * i] * (1 - w) + Q[o + 2 * i + 2] * w, Q[o + 2 * i + 1] * (1 - w) + Q[o + 2 * i + 3] * w];
    const moving = t >= 0 && t < pl.duration;
    const qd = moving ? [(Q[o + 2 * i + 2] - Q[o + 2 * i]) / dt, (Q[o + 2 * i + 3] - Q[o + 2 * i + 1]) / dt] : [0, 0];
    return { q: q, qd: qd };
  }
  function segmentAt(pl, arm, t) {
    const ss = pl.segments[arm] || [];
    for (let i = 0; i < ss.length; i++) if (t >= ss[i].t0 && (t < ss[i].t1 || i === ss.length - 1)) return ss[i];
    return null;
  }
  function waitNote(pl, arm, s) {
    return (pl.waitNotes[arm] || []).find(function (n) { return Math.abs(n.t0 - s.t0) < 1e-9; }) || null;
  }
  function phaseText(pl, arm, s) {
    if (!s) return "at rest";
    if (s.phase === "moving") {
      if (!s.fruit) return "moving: going home";
      const f = pl.fruit[s.fruit];
      return f && f.pick && f.pick.t_end <= s.t0 + 1e-9 ? "moving: carrying " + s.fruit + " to the bin" : "moving: going to pick " + s.fruit;
    }
    if (s.phase === "picking") return "picking " + s.fruit;
    if (s.phase === "placing") return "placing " + s.fruit + " in the bin";
    const n = waitNote(pl, arm, s);
    return "waiting" + (n ? " " + n.for : "") + (n && n.until ? "; " + n.until.text : "");
  }
  function fruitState(pl, f, fact, t) {
    if (f.unreachable) return { state: "unreachable", text: "unreachable: " + f.unreachable };
    if (!fact.pick) return { state: "unharvested", text: "not harvested by this plan" + (pl.left_out && pl.left_out[f.id] ? ": " + pl.left_out[f.id] : "") };
    if (t < fact.pick.t_start) return { state: "waiting", text: "on the plant, waiting for " + fact.arm };
    if (t <= fact.pick.t_end) return { state: "picking", text: "being picked by " + fact.arm };
    if (!fact.place || t < fact.place.t_start) return { state: "carried", text: "carried by " + fact.arm };
    if (t < fact.place.t_end) return { state: "placing", text: "being placed by " + fact.arm };
    return { state: "placed", text: "in " + fact.place.arm + "'s bin" };
  }

  // ------------------------------------------------------------------ state
  let T = 0, playing = false, speed = 1, lastNow = null, dirty = true, lastHash = 0;
  const layers = { trails: true, reach: false, manip: false };
  const slider = document.getElementById("time");
  const clock = document.getElementById("clock");
  const playBtn = document.getElementById("play");
  const tip = document.getElementById("tip");
  slider.max = String(T_END);

  function setTime(t) {
    T = clamp(Number(t) || 0, 0, T_END);
    slider.value = String(T);
    slider.setAttribute("aria-valuetext", T.toFixed(2) + " s of " + T_END.toFixed(2) + " s");
    clock.textContent = T.toFixed(2) + " s";
    dirty = true;
    const now = performance.now();
    if (!playing || now - lastHash > 250) { writeHash(); lastHash = now; }
  }
  function writeHash() {
    try { history.replaceState(null, "", "#t=" + String(Number(T.toFixed(3)))); } catch (e) { /* a sandboxed frame has no address to write */ }
  }
  function readHash() {
    const m = /[#&]t=([-+0-9.eE]+)/.exec(location.hash);
    if (m && isFinite(parseFloat(m[1]))) { setTime(parseFloat(m[1])); return true; }
    return false;
  }
  function setPlaying(on) {
    playing = on;
    if (on && T >= T_END - 1e-9) setTime(0);
    playBtn.textContent = on ? "\u23F8 pause" : "\u25B6 play";
    lastNow = null;
    if (!on) { writeHash(); dirty = true; }  // (a redraw: the canvas's spoken state is written when paused)
  }

  // ------------------------------------------------------------------ tooltip
  function showTip(ev, head, rows) {
    tip.replaceChildren(el("div", { class: "h" }, head));
    rows.forEach(function (r) { if (r) tip.appendChild(el("div", { class: "r" }, r)); });
    tip.style.display = "block";
    const w = tip.offsetWidth, h = tip.offsetHeight;
    let x = ev.clientX + 14, y = ev.clientY + 14;
    if (x + w > window.innerWidth - 4) x = ev.clientX - w - 10;
    if (y + h > window.innerHeight - 4) y = ev.clientY - h - 10;
    tip.style.left = Math.max(2, x) + "px";
    tip.style.top = Math.max(2, y) + "px";
  }
  function hideTip() { tip.style.display = "none"; }
  function span(a, b) { return num(a) + "\u2013" + num(b) + " s"; }
  function violationRows(v) {
    return [
      "arms: " + (v.arms.join(", ") || "\u2013") + (v.fruit ? "; fruit " + v.fruit : "") + (v.joint !== null && v.joint !== undefined ? "; joint " + (v.joint + 1) : ""),
      "at " + num(v.t, 3) + " s" + (v.t_start !== null && v.t_end !== null && v.t_end - v.t_start > 1e-9 ? " (from " + num(v.t_start, 3) + " to " + num(v.t_end, 3) + " s)" : ""),
      v.value !== null ? "value " + num(v.value, 4) + (v.limit !== null ? ", limit " + num(v.limit, 4) : "") : null,
      v.message || null,
      "click: go to this time",
    ];
  }

  // ------------------------------------------------------------------ the cell
  const manipImage = (function () {
    const m = P.manip, g = decode(m.grid), ny = m.grid.shape[0], nx = m.grid.shape[1];
    const c = document.createElement("canvas");
    c.width = nx; c.height = ny;
    const ctx = c.getContext("2d"), img = ctx.createImageData(nx, ny);
    for (let r = 0; r < ny; r++) {
      for (let col = 0; col < nx; col++) {
        const v = g[r * nx + col], o = ((ny - 1 - r) * nx + col) * 4; // row 0 is the lowest y
        if (v === 0) { img.data[o + 3] = 0; continue; }
        const s = (v - 1) / 254;
        const grey = Math.round(248 - 75 * s); // light: near singular, darker: dexterous (as plot_workspace)
        img.data[o] = grey; img.data[o + 1] = grey; img.data[o + 2] = grey;
        img.data[o + 3] = 255;
      }
    }
    ctx.putImageData(img, 0, 0);
    return c;
  })();

  function Cell(pl, box) {
    this.pl = pl;
    if (P.row) {  // a row: the whole row as a strip, and the carriage's position against time
      this.strip = el("canvas", { class: "rowstrip", "data-plan": String(pl.index) });
      box.appendChild(this.strip);
    }
    this.canvas = el("canvas", { class: "cell", "data-plan": String(pl.index), role: "img", "aria-label": (pl.label || pl.planner) + ", the arms at t = 0.00 s" });
    box.appendChild(this.canvas);
    this.ctx = this.canvas.getContext("2d");
    this.hits = [];
    const self = this;
    this.pointer = null;  // the last mouse event over the canvas: the tip follows the drawing
    this.canvas.addEventListener("mousemove", function (ev) { self.pointer = ev; self.hover(ev); });
    this.canvas.addEventListener("mouseleave", function () { self.pointer = null; hideTip(); });
  }
  Cell.prototype.layout = function () {
    const v = P.view, vx = v[2] - v[0], vy = v[3] - v[1];
    const W = Math.max(200, this.canvas.clientWidth);
    const H = Math.round(Math.min(W * vy / vx, Math.max(260, window.innerHeight * 0.55)));
    const dpr = window.devicePixelRatio || 1;
    this.canvas.style.height = H + "px";
    this.canvas.width = Math.round(W * dpr); this.canvas.height = Math.round(H * dpr);
    this.dpr = dpr; this.W = W; this.H = H;
    this.s = Math.min(W / vx, H / vy);
    this.ox = (W - vx * this.s) / 2; this.oy = (H - vy * this.s) / 2;
  };
  // the row strip: every fruit along the rail (ringed in the colour of the arm that takes it,
  // filled once placed), each stop (a tick), the carriage's reach now (a band) and, below, the
  // carriage's x against time (time downwards) with the clock as a line
  Cell.prototype.drawStrip = function (t) {
    const R = P.row, c = this.strip, pl = this.pl;
    const W = Math.max(200, c.clientWidth), H = 150, dpr = window.devicePixelRatio || 1;
    if (c.width !== Math.round(W * dpr)) { c.width = Math.round(W * dpr); c.height = Math.round(H * dpr); c.style.height = H + "px"; }
    const ctx = c.getContext("2d");
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    ctx.clearRect(0, 0, W, H);
    const x0 = R.start + R.reach[0], x1 = R.end + R.reach[1], pad = 8;
    const X = function (x) { return pad + (x - x0) / (x1 - x0) * (W - 2 * pad); };
    const ys = P.fruits.map(function (f) { return f.pos[1]; });
    const yl = Math.min.apply(null, ys.concat([0])), yh = Math.max.apply(null, ys.concat([1]));
    const Y = function (y) { return 8 + (yh - y) / Math.max(1e-9, yh - yl) * 44; };
    const sh = gxAt(pl, t);
    ctx.fillStyle = "rgba(60,120,200,0.12)";
    ctx.fillRect(X(sh + R.reach[0]), 2, X(sh + R.reach[1]) - X(sh + R.reach[0]), 54);
    ctx.strokeStyle = "#333"; ctx.lineWidth = 1;
    ctx.beginPath(); ctx.moveTo(X(R.start), 60); ctx.lineTo(X(R.end), 60); ctx.stroke();
    (R.stops[pl.index] || []).forEach(function (st, i) {
      ctx.strokeStyle = "#555"; ctx.beginPath(); ctx.moveTo(X(st.x), 56); ctx.lineTo(X(st.x), 64); ctx.stroke();
    });
    P.fruits.forEach(function (f) {
      const fact = pl.fruit[f.id], st = fruitState(pl, f, fact, t);
      const col = fact.arm !== null ? ARMS[ARM[fact.arm]].color : "#999999";
      ctx.beginPath(); ctx.arc(X(f.pos[0]), Y(f.pos[1]), 2.5, 0, 2 * Math.PI);
      ctx.fillStyle = st.state === "placed" ? col : "#fff"; ctx.fill();
      ctx.strokeStyle = st.state === "unreachable" ? "#999" : col; ctx.lineWidth = 1; ctx.stroke();
    });
    ctx.fillStyle = "#333"; ctx.beginPath();
    ctx.moveTo(X(sh), 60); ctx.lineTo(X(sh) - 5, 68); ctx.lineTo(X(sh) + 5, 68); ctx.fill();
    // the carriage's x against time
    const top = 74, h = H - top - 18, n = pl.gx ? pl.gx.length : 0;  // (the caption's line below it, clear of the curve)
    ctx.strokeStyle = "#2a6"; ctx.lineWidth = 1.5; ctx.beginPath();
    for (let i = 0; i < n; i += Math.max(1, Math.floor(n / 600))) {
      const tt = i / pl.display.rate, px = X(pl.gx[i]), py = top + tt / T_END * h;
      if (i === 0) ctx.moveTo(px, py); else ctx.lineTo(px, py);
    }
    ctx.stroke();
    ctx.strokeStyle = "rgba(0,0,0,0.35)"; ctx.beginPath(); ctx.moveTo(pad, top + t / T_END * h); ctx.lineTo(W - pad, top + t / T_END * h); ctx.stroke();
    ctx.fillStyle = "#333"; ctx.font = "11px system-ui, sans-serif"; ctx.textAlign = "left";
    const stops = (R.moving || [])[pl.index] ? "on the move, no stops; " + plural((R.stops[pl.index] || []).length, "rest") + " with picks (ticks)"
      : plural((R.stops[pl.index] || []).length, "stop") + " (ticks)";
    // the longest caption that fits the strip (it ran past a narrow one, over the carriage's curve)
    const caption = ["row " + num(R.start, 1) + "–" + num(R.end, 1) + " m; carriage at " + num(sh, 2) + " m; " + stops + "; above: carriage x against time",
                     "carriage at " + num(sh, 2) + " m; " + stops, "carriage at " + num(sh, 2) + " m"]
      .find(function (c) { return ctx.measureText(c).width <= W - 2 * pad; }) || "x " + num(sh, 2) + " m";
    ctx.fillText(caption, pad, H - 4);
  };
  Cell.prototype.px = function (x, y) {
    const v = P.view;  // a row's view box is the carriage's: it follows the carriage (this.shift)
    return [this.ox + (x - v[0] - (this.shift || 0)) * this.s, this.oy + (v[3] - y) * this.s];
  };
  Cell.prototype.draw = function (t) {
    const ctx = this.ctx, pl = this.pl, s = this.s, self = this;
    const sh = gxAt(pl, t);
    this.shift = sh;
    ctx.setTransform(this.dpr, 0, 0, this.dpr, 0, 0);
    ctx.clearRect(0, 0, this.W, this.H);
    this.hits = [];
    if (layers.manip) {
      const m = P.manip, a = this.px(m.x[0] + sh, m.y[1]), b = this.px(m.x[1] + sh, m.y[0]);
      ctx.imageSmoothingEnabled = true;
      ctx.drawImage(manipImage, a[0], a[1], b[0] - a[0], b[1] - a[1]);
    }
    if (layers.reach) {
      ARMS.forEach(function (a) {
        const c = self.px(a.base[0] + sh, a.base[1]);
        ctx.setLineDash([5, 4]); ctx.strokeStyle = rgba(a.color, 0.7); ctx.lineWidth = 1;
        [a.links[0] + a.links[1], Math.abs(a.links[0] - a.links[1])].forEach(function (r) {
          if (r <= 0) return;
          ctx.beginPath(); ctx.arc(c[0], c[1], r * s, 0, 2 * Math.PI); ctx.stroke();
        });
        ctx.setLineDash([]);
      });
    }
    // bins
    const bin = 0.22 * s;
    ARMS.forEach(function (a) {
      const c = self.px(a.bin[0] + sh, a.bin[1]);
      ctx.fillStyle = rgba(a.color, 0.12); ctx.strokeStyle = a.color; ctx.lineWidth = 1.5;
      ctx.fillRect(c[0] - bin / 2, c[1] - bin / 2, bin, bin); ctx.strokeRect(c[0] - bin / 2, c[1] - bin / 2, bin, bin);
      // how many it holds (its grid draws nine at most: a bin of 17 looked like one of 9)
      const held = (pl.binOrder[a.name] || []).filter(function (fid) { return pl.fruit[fid].place.t_end <= t; }).length;
      if (held > 0) {
        ctx.fillStyle = onWhite(a.color); ctx.font = "11px system-ui, sans-serif"; ctx.textAlign = "center";
        ctx.fillText(String(held), c[0], c[1] + bin / 2 + 12);
      }
    });
    // poses
    const poses = ARMS.map(function (a, i) { return fk(a, qTrack(pl, i, t), sh); });
    // trails
    if (layers.trails) {
      const r = pl.display.rate, i1 = Math.floor(clamp(t, 0, pl.duration) * r), i0 = Math.max(0, Math.floor((t - TRAIL) * r));
      ARMS.forEach(function (a, k) {
        for (let i = i0; i < i1; i++) {
          const p0 = self.px.apply(self, fk(a, qTrack(pl, k, i / r), gxAt(pl, i / r))[2]);
          const p1 = self.px.apply(self, fk(a, qTrack(pl, k, (i + 1) / r), gxAt(pl, (i + 1) / r))[2]);
          ctx.strokeStyle = rgba(a.color, 0.1 + 0.7 * (i - i0) / Math.max(1, i1 - i0)); ctx.lineWidth = 2;
          ctx.beginPath(); ctx.moveTo(p0[0], p0[1]); ctx.lineTo(p1[0], p1[1]); ctx.stroke();
        }
      });
    }
    // fruit
    const fr = Math.max(4, 0.035 * s);
    P.fruits.forEach(function (f) {
      const fact = pl.fruit[f.id], st = fruitState(pl, f, fact, t);
      const col = fact.arm !== null ? ARMS[ARM[fact.arm]].color : "#999999";
      let p = self.px(f.pos[0], f.pos[1]);
      if (st.state === "unreachable") {
        ctx.strokeStyle = "#888"; ctx.lineWidth = 2; const d = fr * 0.8;
        ctx.beginPath(); ctx.moveTo(p[0] - d, p[1] - d); ctx.lineTo(p[0] + d, p[1] + d); ctx.moveTo(p[0] - d, p[1] + d); ctx.lineTo(p[0] + d, p[1] - d); ctx.stroke();
      } else {
        let r = fr, fill = P.colors.fruit;
        if (st.state === "carried" || st.state === "placing") { p = self.px.apply(self, poses[ARM[fact.arm]][2]); r = fr * 0.8; }
        if (st.state === "placed") {
          const order = pl.binOrder[fact.place.arm] || [], k = order.indexOf(f.id), b = ARMS[ARM[fact.place.arm]].bin;
          const c = self.px(b[0] + sh, b[1]), per = 3, step = bin / (per + 1);
          p = [c[0] - bin / 2 + step * (1 + (k % per)), c[1] + bin / 2 - step * (1 + Math.floor(k / per) % per)];
          r = Math.min(fr * 0.6, step * 0.45);
        }
        ctx.fillStyle = fill; ctx.beginPath(); ctx.arc(p[0], p[1], r, 0, 2 * Math.PI); ctx.fill();
        ctx.lineWidth = st.state === "picking" ? 3.5 : 2;
        ctx.strokeStyle = col;
        if (st.state === "unharvested") { ctx.setLineDash([3, 2]); ctx.strokeStyle = "#777"; }
        ctx.stroke(); ctx.setLineDash([]);
      }
      self.hits.push({ kind: "fruit", id: f.id, x: p[0], y: p[1], r: fr + 3 });
    });
    // arms: capsules of their real radius
    const alarm = {};
    pl.contacts.forEach(function (v) { if (t >= v.t_start - 1e-9 && t <= v.t_end + 1e-9) v.arms.forEach(function (a) { alarm[a] = v.kind; }); });
    ARMS.forEach(function (a, k) {
      const pts = poses[k].map(function (q) { return self.px(q[0], q[1]); }), w = 2 * a.radius * s;
      ctx.lineCap = "round"; ctx.lineJoin = "round";
      if (alarm[a.name]) {
        ctx.strokeStyle = P.colors.alert; ctx.lineWidth = w + 5;
        ctx.beginPath(); ctx.moveTo(pts[0][0], pts[0][1]); ctx.lineTo(pts[1][0], pts[1][1]); ctx.lineTo(pts[2][0], pts[2][1]); ctx.stroke();
      }
      ctx.strokeStyle = rgba(a.color, 0.6); ctx.lineWidth = w;
      ctx.beginPath(); ctx.moveTo(pts[0][0], pts[0][1]); ctx.lineTo(pts[1][0], pts[1][1]); ctx.lineTo(pts[2][0], pts[2][1]); ctx.stroke();
      ctx.strokeStyle = a.color; ctx.lineWidth = 1.5; ctx.stroke();
      ctx.fillStyle = "#333"; ctx.fillRect(pts[0][0] - 7, pts[0][1] - 4, 14, 12);
      ctx.fillStyle = "#fff"; ctx.strokeStyle = "#333"; ctx.lineWidth = 1;
      [pts[0], pts[1]].forEach(function (p) { ctx.beginPath(); ctx.arc(p[0], p[1], 3, 0, 2 * Math.PI); ctx.fill(); ctx.stroke(); });
      ctx.fillStyle = onWhite(a.color); ctx.font = "12px system-ui, sans-serif"; ctx.textAlign = "center";
      ctx.fillText(a.locked ? a.name + " (locked)" : a.name, pts[0][0], pts[0][1] + 24);
      self.hits.push({ kind: "arm", arm: k, pts: pts, r: w / 2 + 3 });
    });
    const names = Object.keys(alarm);
    if (names.length) {
      ctx.fillStyle = P.colors.alert; ctx.font = "bold 13px system-ui, sans-serif"; ctx.textAlign = "left";
      ctx.fillText((Object.values(alarm).indexOf("collision") >= 0 ? "COLLISION: " : "CLEARANCE BREACH: ") + names.join(", "), 8, 18);
    }
    ctx.fillStyle = "#333"; ctx.font = "12px system-ui, sans-serif"; ctx.textAlign = "right";
    const placed = placedBy(pl, t);  // (the bins show nine at most: a row's count was nowhere)
    const clockText = "t = " + t.toFixed(2) + " s" + (pl.gx ? ", carriage at " + sh.toFixed(2) + " m" : "") + "; placed " + placed + "/" + pl.placedAt.length;
    ctx.fillText(clockText, this.W - 8, 16);
    if (!playing) {
      const said = (pl.label || pl.planner) + ", the arms at " + clockText + (names.length ? "; " + (Object.values(alarm).indexOf("collision") >= 0 ? "collision" : "clearance breach") + ": " + names.join(", ") : "");
      if (this.canvas.getAttribute("aria-label") !== said) this.canvas.setAttribute("aria-label", said);
    }
    if (this.strip) this.drawStrip(t);
  };
  Cell.prototype.hover = function (ev) {
    const r = this.canvas.getBoundingClientRect(), x = ev.clientX - r.left, y = ev.clientY - r.top, pl = this.pl;
    const fruit = this.hits.filter(function (h) { return h.kind === "fruit" && Math.hypot(h.x - x, h.y - y) <= h.r; })
      .sort(function (a, b) { return Math.hypot(a.x - x, a.y - y) - Math.hypot(b.x - x, b.y - y); })[0];
    if (fruit) {
      const f = P.fruits.find(function (g) { return g.id === fruit.id; }), fact = pl.fruit[f.id];
      showTip(ev, "fruit " + f.id, [
        "position (" + num(f.pos[0], 3) + ", " + num(f.pos[1], 3) + ") m",
        "now: " + fruitState(pl, f, fact, T).text,
        fact.arm ? "arm: " + fact.arm : null,
        fact.pick ? "pick " + span(fact.pick.t_start, fact.pick.t_end) : null,
        fact.place ? "place " + span(fact.place.t_start, fact.place.t_end) : null,
        f.unreachable ? null : "reachable by: " + (f.reach.join(", ") || "no arm"),
      ]);
      return;
    }
    const arm = this.hits.filter(function (h) {
      return h.kind === "arm" && Math.min(segDist(x, y, h.pts[0][0], h.pts[0][1], h.pts[1][0], h.pts[1][1]),
        segDist(x, y, h.pts[1][0], h.pts[1][1], h.pts[2][0], h.pts[2][1])) <= h.r;
    })[0];
    if (arm) {
      const a = ARMS[arm.arm], ex = qExact(pl, arm.arm, T), tipP = fk(a, ex.q, gxAt(pl, T))[2];
      const deg = function (r) { return num(r * 180 / Math.PI, 1) + "\u00B0"; };
      const pct = function (v, j) { return Math.round(100 * Math.abs(v) / a.max_velocity[j]) + " % of the limit"; };
      const done = (pl.binOrder[a.name] || []).filter(function (fid) { return pl.fruit[fid].place.t_end <= T; }).length;
      showTip(ev, "arm " + a.name, [
        "now: " + phaseText(pl, a.name, segmentAt(pl, a.name, T)),
        "q1 = " + num(ex.q[0], 4) + " rad (" + deg(ex.q[0]) + "), q2 = " + num(ex.q[1], 4) + " rad (" + deg(ex.q[1]) + ")",
        "q\u03071 = " + num(ex.qd[0], 3) + " rad/s (" + pct(ex.qd[0], 0) + "), q\u03072 = " + num(ex.qd[1], 3) + " rad/s (" + pct(ex.qd[1], 1) + ")",
        "tip (" + num(tipP[0], 3) + ", " + num(tipP[1], 3) + ") m; link radius " + num(a.radius, 3) + " m",
        "fruit: " + ((pl.allocation[a.name] || []).join(", ") || "none") + "; placed so far " + done,
        a.locked ? "locked: " + a.locked_reason : null,
      ]);
      return;
    }
    hideTip();
  };

  // ------------------------------------------------------------------ timeline and clearance
  function Panel(pl, root) {
    this.pl = pl;
    const box = el("section", { class: "panel", "data-plan": String(pl.index) });
    root.appendChild(box);
    const v = pl.verdict;
    // a row: its row time (a live row's runs to its last cycle's end, a probe's too: past the last place)
    const rw = pl.row, span = rw && rw.row_time != null ? rw.row_time : pl.makespan;
    const part = pl.harvested != null && pl.reachable != null && pl.harvested < pl.reachable;
    // (a partial plan's makespan read x0.814 of a bound for harvesting every fruit, unsaid)
    const ratio = pl.lower_bound ? " (lower bound " + num(pl.lower_bound, 3) + " s" + (part ? " to harvest all " + pl.reachable + " fruit; this plan harvests " + pl.harvested + ")" :
      ", \u00D7" + num(span / pl.lower_bound, 3) + ")") : "";
    // a row: what a grower judges it by first, as the summary says it
    const grower = rw ? " \u2014 " + num(rw.fruit_per_hour, 0) + " fruit/h, " + (rw.share_harvested == null ? "\u2013" : num(100 * rw.share_harvested, 1)) + " % of the harvestable fruit harvested, " +
      (rw.mode === "continuous" ? "on the move" : plural(rw.stops || 0, "stop")) : "";
    const h = el("h3", null, (pl.label || pl.planner) + " \u2014 " + pl.status + " \u2014 " + (rw ? "row time " : "makespan ") + num(span, 3) + " s" + ratio + grower + " \u2014 ");
    h.appendChild(el("span", { class: v.passed ? "verdict-ok" : "verdict-bad" },
      v.passed ? "verified: no violations" : "FAILED verification: " + plural(v.violation_count, "violation") + " (" + v.violation_kinds.join(", ") + ")"));
    box.appendChild(h);
    box.appendChild(el("div", { class: "facts" }, "fruit harvested " + (pl.harvested === null || pl.harvested === undefined ? "\u2013" : pl.harvested) + "/" +
      (pl.reachable === null || pl.reachable === undefined ? "\u2013" : pl.reachable) + (v.unharvested.length ? " (not harvested: " + v.unharvested.join(", ") + ")" : "") +
      "; least clearance " + num(v.min_clearance, 4) + " m (certified " + num(v.certified_clearance, 4) + " m, required " + num(v.required_clearance, 3) + " m; margin " + (v.margin == null ? "-" : num(1000 * v.margin, 1) + " mm") + ")" + (v.jerk ? "; RMS / peak jerk " + Object.keys(v.jerk).map(function (a) { return a + " " + (v.jerk[a].unbounded ? "unbounded (its acceleration steps)" : num(v.jerk[a].rms, 0) + " / " + num(v.jerk[a].peak, 0)); }).join(", ") + " rad/s\u00b3" : "")));
    // the plan file's own figures where they are not its motion's (the terminal said so; the page did not)
    (v.notes || []).forEach(function (n) { box.appendChild(el("div", { class: "facts file-note" }, "note: " + n + "; the measured figures are shown")); });
    this.tl = sv("svg", { class: "timeline", "data-plan": String(pl.index), role: "img",
      "aria-label": "Timeline of " + (pl.label || pl.planner) + ": each arm's moves, picks, places and waits against time (click to go to a time)" });
    this.cl = sv("svg", { class: "clearance", "data-plan": String(pl.index), role: "img",
      "aria-label": "Clearance between neighbouring arms against time, with the required " + num(v.required_clearance, 3) + " m" });
    box.appendChild(this.tl);
    box.appendChild(this.cl);
    this.legend = el("div", { class: "facts" });
    box.appendChild(this.legend);
    if (pl.violations.length) {
      const det = el("details", { class: "violations" });
      det.appendChild(el("summary", null, plural(pl.violations.length, "violation") + ": click one to go to its time"));
      const tab = el("table", { class: "vtable" }), head = el("tr");
      tab.appendChild(el("caption", { class: "sr-only" }, "Violations: Enter on a row goes to its time"));
      ["kind", "arms", "t (s)", "value", "limit", "unit", "detail"].forEach(function (c) { head.appendChild(el("th", null, c)); });
      tab.appendChild(head);
      pl.violations.slice(0, 500).forEach(function (vi, i) {
        // (focusable: Enter or Space goes to its time, as a click does -- a keyboard could not reach one)
        const tr = el("tr", { class: "violation-row", "data-t": String(clamp(vi.t, 0, T_END)), "data-index": String(i), tabindex: "0" });
        [vi.kind, vi.arms.join(", "), num(vi.t, 3), num(vi.value, 4), num(vi.limit, 4), (vi.step ? VIOLATION_UNITS.acceleration : VIOLATION_UNITS[vi.kind]) || "",
          (vi.fruit ? "fruit " + vi.fruit + " " : "") + (vi.message || "")].forEach(function (c) { tr.appendChild(el("td", null, c)); });
        tab.appendChild(tr);
      });
      det.appendChild(tab);
      if (pl.violations.length > 500) {  // (the table stopped at 500 of 1553 without a word)
        det.appendChild(el("div", { class: "facts" }, "the first 500 of " + pl.violations.length + " violations are listed (by time); every one is in verification.json (coplan verify)"));
      }
      box.appendChild(det);
      tab.addEventListener("click", function (ev) {
        const row = ev.target.closest(".violation-row");
        if (row) { setPlaying(false); setTime(parseFloat(row.getAttribute("data-t"))); }
      });
      tab.addEventListener("keydown", function (ev) {
        const row = ev.target.closest(".violation-row");
        if (row && (ev.key === "Enter" || ev.key === " ")) {
          ev.preventDefault(); ev.stopPropagation(); setPlaying(false); setTime(parseFloat(row.getAttribute("data-t")));
        }
      });
    }
    const self = this;
    [this.tl, this.cl].forEach(function (svg) {
      svg.addEventListener("mousemove", function (ev) { self.hover(ev, svg); });
      svg.addEventListener("mouseleave", hideTip);
      svg.addEventListener("click", function (ev) { self.click(ev, svg); });
    });
  }
  Panel.prototype.x = function (t) { return LABEL_W + clamp(t, 0, T_END) / T_END * this.plotW; };
  Panel.prototype.tOf = function (clientX, svg) { return clamp((clientX - svg.getBoundingClientRect().left - LABEL_W) / this.plotW * T_END, 0, T_END); };
  Panel.prototype.build = function () {
    const pl = this.pl, self = this, W = Math.max(300, this.tl.parentNode.clientWidth);
    this.plotW = W - LABEL_W - 12;
    // --- timeline
    const rowH = 18, gap = 5, top = 16, H = top + ARMS.length * (rowH + gap) + 2;
    const tl = this.tl;
    tl.replaceChildren();
    tl.setAttribute("width", W); tl.setAttribute("height", H); tl.setAttribute("viewBox", "0 0 " + W + " " + H);
    const defs = sv("defs"), pat = sv("pattern", { id: "hatch" + pl.index, width: 5, height: 5, patternUnits: "userSpaceOnUse", patternTransform: "rotate(45)" });
    pat.appendChild(sv("rect", { width: 2, height: 5, fill: "rgba(255,255,255,0.75)" }));
    defs.appendChild(pat); tl.appendChild(defs);
    tl.appendChild(sv("rect", { class: "bg", x: LABEL_W, y: 0, width: this.plotW, height: H }));
    this.axis(tl, 0, H, true);
    ARMS.forEach(function (a, k) {
      const y = top + k * (rowH + gap);
      tl.appendChild(sv("text", { x: 4, y: y + rowH - 5 }, a.name));
      (pl.segments[a.name] || []).forEach(function (s, i) {
        const x0 = self.x(s.t0), w = Math.max(0.5, self.x(s.t1) - x0);
        const idle = s.phase === "idle";
        const r = sv("rect", { class: "seg", x: x0, y: idle ? y + rowH * 0.3 : y, width: w, height: idle ? rowH * 0.4 : rowH,
          fill: idle ? "#dcdcdc" : s.phase === "moving" ? rgba(a.color, 0.35) : rgba(a.color, s.phase === "picking" ? 1 : 0.8),
          "data-arm": a.name, "data-index": String(i), "data-phase": s.phase });
        tl.appendChild(r);
        if (s.phase === "placing") tl.appendChild(sv("rect", { x: x0, y: y, width: w, height: rowH, fill: "url(#hatch" + pl.index + ")", "pointer-events": "none" }));
        if (s.phase === "picking" && w > 18 && s.fruit) tl.appendChild(sv("text", { x: x0 + w / 2, y: y + rowH - 5, "text-anchor": "middle", fill: ink(a.color), "pointer-events": "none", style: "fill:" + ink(a.color) }, s.fruit));
      });
    });
    pl.violations.forEach(function (v, i) {
      const rows = v.arms.filter(function (a) { return a in ARM; });
      rows.forEach(function (a) {
        const y = top + ARM[a] * (rowH + gap), g = sv("g", { class: "violation", "data-t": String(clamp(v.t, 0, T_END)), "data-index": String(i), "data-kind": v.kind });
        const t0 = v.t_start === null ? v.t : v.t_start, t1 = v.t_end === null ? v.t : v.t_end, xv = self.x(v.t);
        g.appendChild(sv("rect", { x: self.x(t0) - 1, y: y, width: Math.max(2, self.x(t1) - self.x(t0) + 2), height: rowH }));
        g.appendChild(sv("path", { d: "M" + (xv - 5) + "," + (y - 5) + " L" + (xv + 5) + "," + (y - 5) + " L" + xv + "," + (y + 4) + " Z" }));
        tl.appendChild(g);
      });
    });
    this.tlCursor = sv("line", { class: "cursor", y1: 0, y2: H });
    tl.appendChild(this.tlCursor);
    // --- clearance
    const cl = this.cl, CH = 120, req = P.task.clearance;
    cl.replaceChildren();
    if (!pl.clear.length) { cl.setAttribute("height", 0); this.clCursor = null; this.legend.textContent = "no two arms can touch: no clearance to show"; return; }
    let lo = 0, hi = 0;
    pl.clear.forEach(function (c) { for (let i = 0; i < c.d.length; i++) { lo = Math.min(lo, c.d[i]); hi = Math.max(hi, c.d[i]); } });
    hi = Math.min(hi, Math.max(0.5, 8 * req)); lo = Math.min(lo, 0) - 0.05 * (hi - Math.min(lo, 0));
    const y = function (d) { return 6 + (hi - clamp(d, lo, hi)) / (hi - lo) * (CH - 24); };
    this.cy = y;
    cl.setAttribute("width", W); cl.setAttribute("height", CH); cl.setAttribute("viewBox", "0 0 " + W + " " + CH);
    cl.appendChild(sv("rect", { class: "bg", x: LABEL_W, y: 0, width: this.plotW, height: CH }));
    cl.appendChild(sv("rect", { x: LABEL_W, y: y(req), width: this.plotW, height: y(lo) - y(req), fill: "rgba(224,0,0,0.07)", "pointer-events": "none" }));
    this.axis(cl, 0, CH - 14, false);
    cl.appendChild(sv("text", { x: 4, y: y(hi) + 30 }, "clearance"));
    cl.appendChild(sv("text", { x: 4, y: y(hi) + 43 }, "(m)"));
    cl.appendChild(sv("text", { x: LABEL_W + this.plotW - 4, y: y(req) - 6, "text-anchor": "end", style: "fill:" + P.colors.alert + ";stroke:#fff;stroke-width:3px;paint-order:stroke" }, "required " + num(req, 3) + " m"));
    const dstep = niceStep(hi / 4);
    for (let d = 0; d <= hi + 1e-9; d += dstep) {
      cl.appendChild(sv("line", { x1: LABEL_W, x2: LABEL_W + this.plotW, y1: y(d), y2: y(d), stroke: "#eee", "pointer-events": "none" }));
      cl.appendChild(sv("text", { x: LABEL_W - 4, y: y(d) + 4, "text-anchor": "end", class: "tick" }, d === 0 ? "0" : num(d, dstep < 0.1 ? 2 : 1)));
    }
    cl.appendChild(sv("line", { x1: LABEL_W, x2: LABEL_W + this.plotW, y1: y(0), y2: y(0), stroke: "#000", "stroke-width": 0.8 }));
    pl.clear.forEach(function (c) {
      const cols = Math.max(2, Math.round(self.plotW)), best = new Float64Array(cols).fill(Infinity), r = pl.display.rate;
      for (let i = 0; i < c.d.length; i++) { const k = clamp(Math.round((self.x(i / r) - LABEL_W)), 0, cols - 1); best[k] = Math.min(best[k], c.d[i]); }
      const pts = [];
      for (let k = 0; k < cols; k++) if (isFinite(best[k])) pts.push((LABEL_W + k).toFixed(1) + "," + y(best[k]).toFixed(1));
      cl.appendChild(sv("polyline", { points: pts.join(" "), fill: "none", stroke: c.color, "stroke-width": 1.5, "pointer-events": "none" }));
    });
    cl.appendChild(sv("line", { x1: LABEL_W, x2: LABEL_W + this.plotW, y1: y(req), y2: y(req), stroke: P.colors.alert, "stroke-dasharray": "5,3", "stroke-width": 1.2 }));
    this.clCursor = sv("line", { class: "cursor", y1: 0, y2: CH - 14 });
    cl.appendChild(this.clCursor);
    this.legend.replaceChildren();
    pl.verdict.pairs.forEach(function (p) {
      const c = pl.clear.find(function (q) { return q.arms[0] === p.arms[0] && q.arms[1] === p.arms[1]; });
      const sw = el("span", { class: "sw", style: "background:" + (c ? c.color : "#999") });
      const a = el("a", { href: "#", "data-t": String(p.t) }, p.arms.join("\u2013") + ": least " + num(p.min, 4) + " m at " + num(p.t, 2) + " s (certified " + num(p.certified, 4) + ", margin " + (p.margin == null ? "-" : num(1000 * p.margin, 1) + " mm") + ")");
      a.addEventListener("click", function (ev) { ev.preventDefault(); setPlaying(false); setTime(p.t); });
      const pair = el("span", { class: "pair" });  // (a swatch kept with its label: it wrapped away from it)
      pair.appendChild(sw); pair.appendChild(a);
      self.legend.appendChild(pair);
    });
    this.legend.appendChild(el("span", null, "  red dashed: required clearance " + num(req, 3) + " m"));
  };
  Panel.prototype.axis = function (svg, y0, y1, labels) {
    const g = sv("g", { class: "axis" }), step = niceStep(T_END / 10);
    for (let t = 0; t <= T_END + 1e-9; t += step) {
      const x = this.x(t);
      g.appendChild(sv("line", { x1: x, x2: x, y1: y0 + (labels ? 12 : 0), y2: y1 }));
      g.appendChild(sv("text", { x: x, y: labels ? 10 : y1 + 11, "text-anchor": "middle" }, num(t, step < 1 ? 1 : 0)));
    }
    svg.appendChild(g);
  };
  function niceStep(x) { const p = Math.pow(10, Math.floor(Math.log10(x))), m = x / p; return p * (m < 1.5 ? 1 : m < 3.5 ? 2 : m < 7.5 ? 5 : 10); }
  Panel.prototype.update = function (t) {
    const x = this.x(t);
    [this.tlCursor, this.clCursor].forEach(function (c) { if (c) { c.setAttribute("x1", x); c.setAttribute("x2", x); } });
  };
  Panel.prototype.hover = function (ev, svg) {
    const pl = this.pl, v = ev.target.closest ? ev.target.closest(".violation") : null;
    if (v) {
      const vi = pl.violations[+v.getAttribute("data-index")];
      showTip(ev, "violation: " + vi.kind, violationRows(vi));
      return;
    }
    const seg = ev.target.closest ? ev.target.closest(".seg") : null;
    if (seg) {
      const arm = seg.getAttribute("data-arm"), s = pl.segments[arm][+seg.getAttribute("data-index")];
      const note = s.phase === "idle" ? waitNote(pl, arm, s) : null;
      showTip(ev, arm + ": " + PHASE_TEXT[s.phase] + (s.fruit && s.phase !== "idle" ? " " + s.fruit : ""), [
        phaseText(pl, arm, s),
        span(s.t0, s.t1) + " (" + num(s.t1 - s.t0, 2) + " s)",
        note && !note.until && s.t0 > 0 ? "the plan does not record a neighbour this wait is for" : null,
        "click: go to " + num(s.t0, 2) + " s",
      ]);
      return;
    }
    if (svg === this.cl && pl.clear.length) {
      const t = this.tOf(ev.clientX, svg), i = clamp(Math.round(t * pl.display.rate), 0, pl.K - 1);
      showTip(ev, "clearance at " + num(t, 2) + " s", pl.clear.map(function (c) { return c.arms.join("\u2013") + ": " + num(c.d[i], 4) + " m"; })
        .concat(["required " + num(P.task.clearance, 3) + " m", "click: go to this time"]));
      return;
    }
    hideTip();
  };
  Panel.prototype.click = function (ev, svg) {
    const v = ev.target.closest ? ev.target.closest(".violation") : null;
    const seg = ev.target.closest ? ev.target.closest(".seg") : null;
    setPlaying(false);
    if (v) setTime(parseFloat(v.getAttribute("data-t")));
    else if (seg) setTime(this.pl.segments[seg.getAttribute("data-arm")][+seg.getAttribute("data-index")].t0);
    else setTime(this.tOf(ev.clientX, svg));
  };

  // ------------------------------------------------------------------ page
  const summary = document.getElementById("summary");
  summary.appendChild(el("span", null, (P.description ? P.description + " \u2014 " : "") + plural(ARMS.length, "arm") + ", " + P.fruits.length + " fruit, required clearance " + num(P.task.clearance, 3) + " m"));
  if (PLANS.length > 1 || D.lower_bound !== null) {
    summary.appendChild(el("br"));
    summary.appendChild(el("span", null, PLANS.map(function (p) { return (p.label || p.planner) + " " + num(p.makespan, 3) + " s" + (p.row ? ", " + num(p.row.fruit_per_hour, 0) + " fruit/h" : "") + " (" + p.status + ")"; }).join(" vs ") +
      (D.lower_bound !== null ? "; lower bound " + num(D.lower_bound, 3) + " s (no plan that harvests every harvestable fruit can be faster)" : "")));
  }
  const legend = document.getElementById("legend");
  [["moving", "rgba(90,90,90,0.35)"], ["picking", "#555"], ["placing (hatched)", "#777"], ["waiting", "#dcdcdc"], ["violation", "#e00000"]].forEach(function (l) {
    legend.appendChild(el("span", { class: "sw", style: "background:" + l[1] })); legend.appendChild(el("span", null, l[0]));
  });
  legend.appendChild(el("span", { style: "margin-left:14px" }, "fruit: red disc ringed in the colour of the arm that takes it; \u00D7 unreachable (hover for the reason); dashed ring: not harvested"));
  // the reasons in words too (a keyboard or screen reader had them only in the hover tip)
  const outOfReach = P.fruits.filter(function (f) { return f.unreachable; });
  if (outOfReach.length) {
    const det = el("details", { class: "facts unreachable-list" });
    det.appendChild(el("summary", null, outOfReach.length + " fruit unreachable: why"));
    const ul = el("ul");
    outOfReach.forEach(function (f) { ul.appendChild(el("li", null, f.id + ": " + f.unreachable)); });
    det.appendChild(ul);
    legend.after(det);
  }
  const cellsRoot = document.getElementById("cells"), panelsRoot = document.getElementById("panels");
  const cells = PLANS.map(function (pl) {
    const box = el("div", { class: "cellbox" });
    box.appendChild(el("h2", null, (pl.label || pl.planner) + " \u2014 " + pl.status + " \u2014 " + (pl.row ? "row time " + num(pl.row.row_time != null ? pl.row.row_time : pl.makespan, 3) : "makespan " + num(pl.makespan, 3)) + " s"));
    cellsRoot.appendChild(box);
    return new Cell(pl, box);
  });
  const panels = PLANS.map(function (pl) { return new Panel(pl, panelsRoot); });

  function layout() {
    cells.forEach(function (c) { c.layout(); });
    panels.forEach(function (p) { p.build(); });
    dirty = true;
  }
  function draw() {
    // a pointer resting on a cell gets its tip again from the new drawing (the hit areas move
    // with the arms: without this a tip showed what was under the pointer before the change)
    cells.forEach(function (c) { c.draw(T); if (c.pointer) c.hover(c.pointer); });
    panels.forEach(function (p) { p.update(T); });
  }
  function frame(now) {
    if (playing) {
      if (lastNow !== null) {
        const t = T + (now - lastNow) / 1000 * speed;
        if (t >= T_END) { setTime(T_END); setPlaying(false); } else setTime(t);
      }
      lastNow = now;
    }
    if (dirty) { dirty = false; draw(); }
    window.requestAnimationFrame(frame);
  }

  playBtn.addEventListener("click", function () { setPlaying(!playing); });
  slider.addEventListener("input", function () { setPlaying(false); setTime(parseFloat(slider.value)); });
  document.getElementById("speed").addEventListener("change", function (ev) { speed = parseFloat(ev.target.value) || 1; });
  ["trails", "reach", "manip"].forEach(function (k) {
    const box = document.getElementById("layer-" + k);
    layers[k] = box.checked;
    box.addEventListener("change", function () { layers[k] = box.checked; dirty = true; });
  });
  document.addEventListener("keydown", function (ev) {
    if (ev.target && (["SELECT", "TEXTAREA"].indexOf(ev.target.tagName) >= 0 || ev.target.tagName === "INPUT" && ev.target.type !== "range")) return;
    // (Space on a focused control is the control's: on the violations' summary it opened nothing and played; the arrows stay the page's)
    const control = ev.target && ["SUMMARY", "BUTTON", "TR"].indexOf(ev.target.tagName) >= 0;
    if (ev.key === " ") { if (control) return; ev.preventDefault(); setPlaying(!playing); }
    else if (ev.key === "ArrowRight" || ev.key === "ArrowLeft") {
      if (ev.target === slider) return;
      ev.preventDefault(); setPlaying(false); setTime(T + (ev.key === "ArrowRight" ? 1 : -1) * (ev.shiftKey ? 1 : 0.1));
    }
  });
  window.addEventListener("hashchange", readHash);
  let resizeTimer = null;
  window.addEventListener("resize", function () { clearTimeout(resizeTimer); resizeTimer = setTimeout(layout, 100); });

  layout();
  if (!readHash()) setTime(0);
  draw();
  window.requestAnimationFrame(frame);

  // a small handle for scripts and tests: the clock, and where a world point is drawn
  window.coplanViewer = {
    duration: T_END,
    time: function () { return T; },
    setTime: function (t) { setPlaying(false); setTime(t); },
    playing: function () { return playing; },
    placed: function (plan) { return placedBy(PLANS[plan], T); },
    carriage: function (plan) { return gxAt(PLANS[plan], T); },
    clientPoint: function (plan, x, y) {
      const c = cells[plan], r = c.canvas.getBoundingClientRect(), p = c.px(x, y);
      return [r.left + p[0], r.top + p[1]];
    },
  };
})();
