// fs020n pendant page: the arm in 3D from the robot model, live joints and pose, the operator's
// controls (emulator) or the hub's view of a real controller. Written for this project; no
// libraries. The server sends the model (GET /model) and a live feed (GET /live, server-sent
// events read with fetch so that the token header can be sent).
"use strict";

(function () {
  // ------------------------------------------------------------------ token and requests
  const hashParams = new URLSearchParams(location.hash.slice(1));
  const token = hashParams.get("token") || "";

  function headers(json) {
    const h = {};
    if (token) h["Authorization"] = "Bearer " + token;
    if (json) h["Content-Type"] = "application/json";
    return h;
  }

  async function request(method, path, body) {
    const opts = { method: method, headers: headers(method === "POST"), credentials: "same-origin" };
    if (method === "POST") opts.body = JSON.stringify(body === undefined ? {} : body);
    const r = await fetch(path, opts);
    let data = null;
    try { data = await r.json(); } catch (e) { data = null; }
    if (!r.ok) {
      const msg = data && data.error ? data.error + (data.remedy ? " — " + data.remedy : "") : r.status + " " + r.statusText;
      throw new Error(msg);
    }
    return data;
  }

  function showResult(text, bad) {
    const el = document.getElementById("action-result");
    el.textContent = text;
    el.className = "small " + (bad ? "bad" : "good");
  }

  async function act(label, method, path, body) {
    try {
      await request(method, path, body);
      showResult(label + ": done", false);
    } catch (e) {
      showResult(label + ": " + e.message, true);
    }
  }

  // ------------------------------------------------------------------ small vector maths
  const V = {
    add: (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]],
    sub: (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]],
    scale: (a, s) => [a[0] * s, a[1] * s, a[2] * s],
    dot: (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2],
    cross: (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]],
    norm: (a) => { const l = Math.hypot(a[0], a[1], a[2]) || 1; return [a[0] / l, a[1] / l, a[2] / l]; },
  };
  // 3x3 matrices, row-major arrays of 9.
  function mul(a, b) {
    const r = new Array(9);
    for (let i = 0; i < 3; i++) for (let j = 0; j < 3; j++) {
      r[i * 3 + j] = a[i * 3] * b[j] + a[i * 3 + 1] * b[3 + j] + a[i * 3 + 2] * b[6 + j];
    }
    return r;
  }
  function apply(m, v) {
    return [m[0] * v[0] + m[1] * v[1] + m[2] * v[2], m[3] * v[0] + m[4] * v[1] + m[5] * v[2], m[6] * v[0] + m[7] * v[1] + m[8] * v[2]];
  }
  function rz(a) { const c = Math.cos(a), s = Math.sin(a); return [c, -s, 0, s, c, 0, 0, 0, 1]; }
  function ry(a) { const c = Math.cos(a), s = Math.sin(a); return [c, 0, s, 0, 1, 0, -s, 0, c]; }
  const I3 = [1, 0, 0, 0, 1, 0, 0, 0, 1];

  // ------------------------------------------------------------------ forward kinematics
  // The chain of docs/KINEMATICS.md: Rz(q1)·Tr(a1,0,d1)·Ry(q2)·Tr(0,0,a2)·Ry(−q3)·Tr(0,0,d4)
  //   ·Rz(q4)·Ry(−q5)·Rz(q6)·Tr(0,0,d6). Positions in metres.
  function fk(geometry, jointsDeg) {
    const q = jointsDeg.map((d) => d * Math.PI / 180);
    const g = geometry;
    const R1 = rz(q[0]);
    const shoulder = apply(R1, [g.shoulder_offset_m, 0, g.base_height_m]);
    const R2 = mul(R1, ry(q[1]));
    const elbow = V.add(shoulder, apply(R2, [0, 0, g.upper_arm_m]));
    const R3 = mul(R2, ry(-q[2]));
    const wrist = V.add(elbow, apply(R3, [0, 0, g.forearm_m]));
    const R4 = mul(R3, rz(q[3]));
    const R5 = mul(R4, ry(-q[4]));
    const R6 = mul(R5, rz(q[5]));
    const flange = V.add(wrist, apply(R6, [0, 0, g.flange_m]));
    const column = (m, i) => [m[i], m[3 + i], m[6 + i]];
    return {
      points: { base: [0, 0, 0], column: [0, 0, g.base_height_m], shoulder, elbow, wrist, flange },
      // Joint axes (world direction) at their places.
      axes: [
        { at: [0, 0, 0.05], dir: [0, 0, 1] },
        { at: shoulder, dir: column(R1, 1) },
        { at: elbow, dir: V.scale(column(R2, 1), -1) },
        { at: V.add(elbow, apply(R3, [0, 0, g.forearm_m * 0.4])), dir: column(R3, 2) },
        { at: wrist, dir: V.scale(column(R4, 1), -1) },
        { at: flange, dir: column(R6, 2) },
      ],
      tool: { origin: flange, x: column(R6, 0), y: column(R6, 1), z: column(R6, 2) },
    };
  }

  // ------------------------------------------------------------------ page state
  const S = {
    kind: null,
    model: null,
    last: null, // normalised view of the newest update
    history: [], // {t, j:[6]}
    lastFrameAt: 0,
    cam: { yaw: -0.9, pitch: 0.3, dist: 3.3, target: [0.45, 0, 0.75] },
  };
  const DEFAULT_CAM = { yaw: -0.9, pitch: 0.3, dist: 3.3, target: [0.45, 0, 0.75] };

  // Turns an emulator snapshot or a hub state into one shape.
  function normalise(msg) {
    if (msg.kind === "emulator") {
      const s = msg.snapshot;
      const moving = s.motion !== "idle" || s.motion_planned;
      return {
        kind: "emulator",
        t: s.time_s,
        model: s.model,
        joints: s.joints_deg,
        tool: s.tool,
        target: moving ? s.motion_target_deg : null,
        panel: s.panel,
        program: s.task,
        motion: s.motion,
        error: s.error,
        blockers: s.start_blockers,
        speed: s.monitor_speed_percent,
        abs: s.abs_speed,
        raw: s,
      };
    }
    const h = msg.hub;
    const st = h.status || {};
    return {
      kind: "hub",
      t: h.time_s,
      model: h.model,
      joints: st.joints_deg || [0, 0, 0, 0, 0, 0],
      tool: h.tool,
      target: h.target_deg,
      panel: { power: st.power, run: st.run, repeat: st.repeat, teach_lock: st.teach_lock, estop: null },
      program: st.task_running ? "running" : "not_running",
      motion: null,
      error: { code: st.error_code || 0, name: st.error_name || "none", message: st.error_message },
      blockers: st.blockers || [],
      raw: h,
    };
  }

  // ------------------------------------------------------------------ DOM helpers
  const $ = (id) => document.getElementById(id);
  function setText(el, text) { if (el && el.textContent !== text) el.textContent = text; }
  function fmt(v, d) { return typeof v === "number" && isFinite(v) ? v.toFixed(d) : "–"; }
  function lamp(id, on, text, danger) {
    const el = $(id);
    if (!el) return;
    el.classList.toggle("on", on === true);
    el.classList.toggle("danger", !!danger && on === true);
    el.classList.toggle("unknown", on === null || on === undefined);
    if (text) setText(el, text);
  }
  function kvs(el, pairs) {
    const html = pairs.map(([k, v]) => "<div class=\"kv\"><span>" + esc(k) + "</span><span>" + esc(String(v)) + "</span></div>").join("");
    if (el.dataset.html !== html) { el.innerHTML = html; el.dataset.html = html; }
  }
  function esc(s) {
    return String(s).replace(/[&<>"']/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", "\"": "&quot;", "'": "&#39;" }[c]));
  }

  // ------------------------------------------------------------------ updates
  function onUpdate(msg) {
    const v = normalise(msg);
    if (S.kind !== v.kind) {
      S.kind = v.kind;
      document.body.dataset.kind = v.kind;
      setText($("kind-badge"), v.kind === "hub" ? "HUB · real controller" : "EMULATOR");
    }
    S.last = v;
    setText($("model-name"), v.model || "");
    // History for the strip chart (10 s).
    if (v.joints && (S.history.length === 0 || v.t > S.history[S.history.length - 1].t)) {
      S.history.push({ t: v.t, j: v.joints.slice() });
      while (S.history.length && S.history[0].t < v.t - 10) S.history.shift();
    } else if (S.history.length && v.t < S.history[S.history.length - 1].t) {
      S.history = [{ t: v.t, j: v.joints.slice() }];
    }
    updateReadouts(v);
    updateController(v);
    if (v.kind === "emulator") updateEmulator(v.raw); else updateHub(v.raw);
    updateInterpreter(v.raw);
    draw();
    drawChart();
  }

  function updateReadouts(v) {
    const ranges = S.model ? S.model.joints : null;
    for (let i = 0; i < 6; i++) {
      const cell = document.querySelector("[data-joint=\"" + (i + 1) + "\"]");
      setText(cell, fmt(v.joints[i], 3));
      if (ranges && cell) {
        const r = ranges[i];
        const f = (v.joints[i] - r.min_deg) / (r.max_deg - r.min_deg);
        const bar = cell.parentElement.querySelector(".bar span");
        if (bar) bar.style.left = Math.max(0, Math.min(100, f * 100)).toFixed(1) + "%";
      }
    }
    const t = v.tool || {};
    setText(document.querySelector("[data-pose=x]"), fmt(t.x_mm, 1));
    setText(document.querySelector("[data-pose=y]"), fmt(t.y_mm, 1));
    setText(document.querySelector("[data-pose=z]"), fmt(t.z_mm, 1));
    setText(document.querySelector("[data-pose=o]"), fmt(t.o_deg, 2));
    setText(document.querySelector("[data-pose=a]"), fmt(t.a_deg, 2));
    setText(document.querySelector("[data-pose=t]"), fmt(t.t_deg, 2));
  }

  function updateController(v) {
    const p = v.panel || {};
    lamp("lamp-power", p.power, "MOTOR POWER " + (p.power ? "ON" : p.power === false ? "OFF" : "?"));
    lamp("lamp-run", p.run, p.run ? "RUN" : p.run === false ? "HOLD" : "RUN/HOLD ?");
    lamp("lamp-repeat", p.repeat, p.repeat ? "REPEAT" : p.repeat === false ? "TEACH" : "REPEAT ?");
    lamp("lamp-lock", p.teach_lock, "TEACH LOCK " + (p.teach_lock ? "ON" : p.teach_lock === false ? "OFF" : "?"), true);
    lamp("lamp-estop", p.estop, p.estop ? "E-STOP PRESSED" : p.estop === false ? "E-STOP released" : "E-STOP (not reported)", true);
    lamp("lamp-program", v.program === "running", "PROGRAM " + String(v.program || "?").replace("_", " "));
    const e = v.error || {};
    setText($("error-text"), e.code ? e.name + (e.message ? " — " + e.message : "") : "none");
    $("error-text").className = e.code ? "bad" : "";
    if (v.kind === "emulator") {
      // The emulator says why command 1 would be ignored.
      setText($("blockers-label"), "Command 1");
      setText($("blockers"), v.blockers && v.blockers.length ? "ignored: " + v.blockers.join("; ") : "would start the program");
    } else {
      setText($("blockers-label"), "Blocks motion");
      setText($("blockers"), v.blockers && v.blockers.length ? v.blockers.join("; ") : "nothing");
    }
    const banner = $("error-banner");
    banner.hidden = !e.code;
    if (e.code) setText(banner, e.name);
    // The emulator's switches.
    const run = $("sw-run");
    run.dataset.state = p.run ? "run" : "hold";
    setText(run, p.run ? "RUN → HOLD" : "HOLD → RUN");
    run.classList.toggle("on", !!p.run);
    setText($("sw-power"), p.power ? "MOTOR POWER OFF" : "MOTOR POWER ON");
    setText($("sw-repeat"), p.repeat ? "REPEAT → TEACH" : "TEACH → REPEAT");
    setText($("sw-lock"), p.teach_lock ? "TEACH LOCK OFF" : "TEACH LOCK ON");
    setText($("sw-estop"), p.estop ? "RELEASE E-STOP" : "E-STOP");
  }

  function updateEmulator(s) {
    setText($("speed-now"), fmt(s.monitor_speed_percent, 0));
    setText($("abs-now"), s.abs_speed ? "ON" : "OFF");
    // ABS.SPEED: command 3 switches it on; only the pendant switches it off.
    const abs = $("sw-abs");
    abs.dataset.state = s.abs_speed ? "on" : "off";
    setText(abs, s.abs_speed ? "ABS.SPEED OFF" : "ABS.SPEED ON");
    const ses = s.session || {};
    const nc = ses.newest_command;
    kvs($("session"), [
      ["client", ses.open ? "connected (session " + ses.id + ")" : ses.listening ? "none (listening)" : "none"],
      ["TIMER(1)", ses.timer1_s === null || ses.timer1_s === undefined ? "–" : fmt(ses.timer1_s, 3) + " s"],
      ["requests", s.counters.requests + " (" + s.counters.effective_requests + " acted on)"],
      ["newest command", nc ? commandName(nc) : "–"],
      ["program", String(s.task).replace("_", " ") + (s.step_s ? ", step " + fmt(s.step_s * 1000, 1) + " ms" : "")],
      ["motion", s.motion + (s.motion_planned ? " + one planned" : "")],
      ["monitor speed", fmt(s.monitor_speed_percent, 0) + " %" + (s.abs_speed ? " (ABS.SPEED ON)" : "")],
      ["pending faults", s.pending_faults + (ses.reading_paused ? ", not reading" : "")],
      ["last session end", ses.last_end ? "#" + ses.last_end.id + " " + ses.last_end.reason.replace(/_/g, " ") : "–"],
    ]);
  }

  function commandName(nc) {
    const names = { 0: "0 (none since accept)", 1: "1 start", 2: "2 stop", 3: "3 speed", 4: "4", 5: "5 cancel", 6: "6 joint move", 7: "7 stream", 255: "255 end" };
    const n = nc.number;
    return names[n] || String(n);
  }

  function updateHub(h) {
    const l = h.link;
    kvs($("session"), [
      ["controller", l.robot + (l.connected ? " — connected" : " — LOST: " + (l.error || "reconnecting"))],
      ["round trip", fmt(l.rtt_mean_ms, 2) + " ms mean, " + fmt(l.rtt_p99_ms, 2) + " ms p99"],
      ["requests to the controller", l.requests + " (" + l.keepalive_polls + " keep-alive polls)"],
      ["TIMER(1)", h.status && h.status.timer_s !== null ? fmt(h.status.timer_s, 3) + " s" : "–"],
      ["controlling client", h.controller === null ? "none" : "#" + h.controller],
      ["silence limit", fmt(h.silence_timeout_s, 1) + " s"],
    ]);
    const tbody = $("clients").querySelector("tbody");
    const rows = h.clients.map((c) => "<tr class=\"" + (c.controlling ? "controlling" : "") + "\"><td>" + c.id + "</td><td>" + esc(c.peer) + "</td><td>" + (c.controlling ? "controlling" : "watching") + "</td><td>" + c.requests + "</td><td>" + c.refused + "</td></tr>").join("");
    if (tbody.dataset.html !== rows) { tbody.innerHTML = rows || "<tr><td colspan=\"5\">no clients</td></tr>"; tbody.dataset.html = rows; }
    const k = h.counters;
    kvs($("hub-counters"), [
      ["forwarded", k.forwarded], ["answered from the latest status", k.answered_locally],
      ["refused: no control", k.refused_no_control], ["refused: fence", k.refused_fence],
      ["refused: checks", k.refused_checks], ["refused: incomplete", k.refused_incomplete],
      ["stops on client loss", k.stops_on_client_end], ["links lost", k.links_lost],
    ]);
    setText($("fence"), h.fence ? fenceText(h.fence) : "none (the controller's limits and the client's checks)");
    const ev = h.events.slice().reverse().map((e) => "<li class=\"ev-" + e.kind + "\"><span class=\"t\">" + fmt(e.t_s, 2) + "</span> " + esc(e.message) + (e.request ? " <code>" + esc(e.request) + "</code>" : "") + "</li>").join("");
    const ol = $("events");
    if (ol.dataset.html !== ev) { ol.innerHTML = ev; ol.dataset.html = ev; }
  }

  function fenceText(f) {
    const parts = [];
    if (f.speed_cap_percent !== null && f.speed_cap_percent !== undefined) parts.push("speed ≤ " + f.speed_cap_percent + " %");
    if (f.joints) parts.push("joints " + f.joints.min_deg.map((lo, i) => "JT" + (i + 1) + " [" + lo + ", " + f.joints.max_deg[i] + "]").join(" "));
    if (f.workspace) parts.push("flange in X [" + f.workspace.min_mm[0] + ", " + f.workspace.max_mm[0] + "] Y [" + f.workspace.min_mm[1] + ", " + f.workspace.max_mm[1] + "] Z [" + f.workspace.min_mm[2] + ", " + f.workspace.max_mm[2] + "] mm");
    return parts.join("; ") || "empty";
  }

  // The AS program's tasks and terminal, when the emulator runs one (fs020n sim --as-program):
  // snapshot.program = {name, served_port, tasks: [{task, state, program, line, text, waiting,
  // last_error, steps}], terminal: [{at, task, text}]}.
  function taskName(t) {
    if (typeof t === "string") return t;
    if (t && typeof t === "object") {
      const k = Object.keys(t)[0];
      return k === "Pc" ? "pc" + t[k] : String(k).toLowerCase();
    }
    return String(t);
  }
  function updateInterpreter(raw) {
    const it = raw && raw.program;
    $("as-panel").hidden = !it;
    if (!it) return;
    setText($("as-program"), it.name + (it.served_port != null ? " (serving port " + it.served_port + ")" : ""));
    const tasks = Array.isArray(it.tasks) ? it.tasks : [];
    const cell = (v) => "<td>" + esc(v == null ? "" : String(v)) + "</td>";
    const rows = tasks.map((t) =>
      "<tr data-task=\"" + esc(t.task) + "\" data-state=\"" + esc(t.state) + "\">" +
      cell(t.task) + cell(t.state) + cell(t.program) + cell(t.line) + cell(t.text) +
      cell(t.waiting || t.last_error || "") + "</tr>").join("");
    const tb = $("as-tasks").querySelector("tbody");
    if (tb.dataset.html !== rows) { tb.innerHTML = rows; tb.dataset.html = rows; }
    const lines = Array.isArray(it.terminal) ? it.terminal : [];
    const term = lines.map((l) =>
      (typeof l === "string") ? l : (Number(l.at).toFixed(3) + "  " + taskName(l.task) + "  " + l.text)).join("\n");
    setText($("as-terminal"), term);
  }

  // ------------------------------------------------------------------ 3D view (canvas 2D)
  const view = $("view");
  const vctx = view.getContext("2d");

  function fitCanvas(c) {
    const dpr = window.devicePixelRatio || 1;
    const w = Math.max(50, Math.round(c.clientWidth * dpr));
    const h = Math.max(50, Math.round(c.clientHeight * dpr));
    if (c.width !== w || c.height !== h) { c.width = w; c.height = h; }
    return dpr;
  }

  function camera() {
    const c = S.cam;
    const eye = V.add(c.target, V.scale([Math.cos(c.pitch) * Math.cos(c.yaw), Math.cos(c.pitch) * Math.sin(c.yaw), Math.sin(c.pitch)], c.dist));
    const fwd = V.norm(V.sub(c.target, eye));
    const right = V.norm(V.cross(fwd, [0, 0, 1]));
    const up = V.cross(right, fwd);
    const f = view.height / (2 * Math.tan(0.45));
    return {
      eye, fwd, right, up,
      project(p) {
        const d = V.sub(p, eye);
        const z = V.dot(d, fwd);
        if (z < 0.05) return null;
        return { x: view.width / 2 + f * V.dot(d, right) / z, y: view.height / 2 - f * V.dot(d, up) / z, z, s: f / z };
      },
    };
  }

  function segment(cam, a, b, widthM, colour, alpha, dashed) {
    const pa = cam.project(a), pb = cam.project(b);
    if (!pa || !pb) return;
    vctx.save();
    vctx.globalAlpha = alpha;
    vctx.strokeStyle = colour;
    vctx.lineCap = "round";
    vctx.lineWidth = Math.max(1, widthM * (pa.s + pb.s) / 2);
    if (dashed) vctx.setLineDash([8, 6]);
    vctx.beginPath();
    vctx.moveTo(pa.x, pa.y);
    vctx.lineTo(pb.x, pb.y);
    vctx.stroke();
    vctx.restore();
  }

  function dot(cam, p, radiusM, colour, alpha) {
    const pp = cam.project(p);
    if (!pp) return;
    vctx.save();
    vctx.globalAlpha = alpha;
    vctx.fillStyle = colour;
    vctx.beginPath();
    vctx.arc(pp.x, pp.y, Math.max(1.5, radiusM * pp.s), 0, 2 * Math.PI);
    vctx.fill();
    vctx.restore();
  }

  function drawArm(cam, joints, ghost) {
    const g = S.model.geometry;
    const k = fk(g, joints);
    const P = k.points;
    const r = Math.max(0.02, g.upper_arm_m / 10);
    const alpha = ghost ? 0.35 : 1;
    const arm = ghost ? "#6cf" : "#f39a1e";
    const dark = ghost ? "#6cf" : "#555b66";
    // Links, far ones first.
    const links = [
      [P.base, P.column, r * 3.2, dark],
      [P.column, P.shoulder, r * 2.4, arm],
      [P.shoulder, P.elbow, r * 2, arm],
      [P.elbow, P.wrist, r * 1.6, arm],
      [P.wrist, P.flange, r * 1.0, dark],
    ];
    links.sort((a, b) => {
      const za = cam.project(V.scale(V.add(a[0], a[1]), 0.5));
      const zb = cam.project(V.scale(V.add(b[0], b[1]), 0.5));
      return (zb ? zb.z : 0) - (za ? za.z : 0);
    });
    for (const l of links) segment(cam, l[0], l[1], l[2], l[3], alpha, ghost);
    for (const p of [P.shoulder, P.elbow, P.wrist]) dot(cam, p, r * 1.3, dark, alpha);
    if (ghost) return;
    // Joint axes.
    const axisColours = ["#e8e8e8", "#e8e8e8", "#e8e8e8", "#e8e8e8", "#e8e8e8", "#e8e8e8"];
    k.axes.forEach((ax, i) => {
      const half = V.scale(ax.dir, 0.12);
      segment(cam, V.sub(ax.at, half), V.add(ax.at, half), 0.006, axisColours[i], 0.9, false);
      const label = cam.project(V.add(ax.at, V.scale(ax.dir, 0.15)));
      if (label) {
        vctx.fillStyle = "#bbb";
        vctx.font = Math.round(11 * (window.devicePixelRatio || 1)) + "px sans-serif";
        vctx.fillText("J" + (i + 1), label.x + 3, label.y);
      }
    });
    // Tool frame: X red, Y green, Z blue.
    const t = k.tool;
    segment(cam, t.origin, V.add(t.origin, V.scale(t.x, 0.15)), 0.008, "#e33", 1, false);
    segment(cam, t.origin, V.add(t.origin, V.scale(t.y, 0.15)), 0.008, "#3c3", 1, false);
    segment(cam, t.origin, V.add(t.origin, V.scale(t.z, 0.15)), 0.008, "#39f", 1, false);
  }

  function drawGrid(cam) {
    const step = 0.25, n = 8;
    for (let i = -n; i <= n; i++) {
      const major = i % 4 === 0;
      segment(cam, [i * step, -n * step, 0], [i * step, n * step, 0], 0.002, major ? "#4a5060" : "#333844", 1, false);
      segment(cam, [-n * step, i * step, 0], [n * step, i * step, 0], 0.002, major ? "#4a5060" : "#333844", 1, false);
    }
    // Base frame axes on the floor.
    segment(cam, [0, 0, 0], [0.4, 0, 0], 0.006, "#a33", 1, false);
    segment(cam, [0, 0, 0], [0, 0.4, 0], 0.006, "#3a3", 1, false);
  }

  function draw() {
    fitCanvas(view);
    vctx.fillStyle = "#1b1e24";
    vctx.fillRect(0, 0, view.width, view.height);
    const cam = camera();
    drawGrid(cam);
    if (!S.model || !S.last) {
      vctx.fillStyle = "#aaa";
      vctx.font = "16px sans-serif";
      vctx.fillText("waiting for the robot…", 20, 30);
      return;
    }
    if (S.last.target) drawArm(cam, S.last.target, true);
    drawArm(cam, S.last.joints, false);
    S.lastFrameAt = performance.now();
  }

  // Orbit, pan, zoom.
  let drag = null;
  view.addEventListener("contextmenu", (e) => e.preventDefault());
  view.addEventListener("pointerdown", (e) => {
    drag = { x: e.clientX, y: e.clientY, pan: e.shiftKey || e.button !== 0 };
    view.setPointerCapture(e.pointerId);
  });
  view.addEventListener("pointermove", (e) => {
    if (!drag) return;
    const dx = e.clientX - drag.x, dy = e.clientY - drag.y;
    drag.x = e.clientX; drag.y = e.clientY;
    const c = S.cam;
    if (drag.pan) {
      const cam = camera();
      const s = c.dist * 0.0015;
      c.target = V.add(c.target, V.add(V.scale(cam.right, -dx * s), V.scale(cam.up, dy * s)));
    } else {
      c.yaw -= dx * 0.008;
      c.pitch = Math.max(-1.4, Math.min(1.4, c.pitch + dy * 0.008));
    }
    draw();
  });
  view.addEventListener("pointerup", () => { drag = null; });
  view.addEventListener("wheel", (e) => {
    e.preventDefault();
    S.cam.dist = Math.max(0.5, Math.min(15, S.cam.dist * Math.exp(e.deltaY * 0.001)));
    draw();
  }, { passive: false });
  view.addEventListener("dblclick", () => { S.cam = JSON.parse(JSON.stringify(DEFAULT_CAM)); draw(); });

  // ------------------------------------------------------------------ strip chart
  const chart = $("chart");
  const cctx = chart.getContext("2d");
  const COLOURS = ["#f39a1e", "#4fc3f7", "#aed581", "#f06292", "#ba68c8", "#fff176"];

  function drawChart() {
    const dpr = fitCanvas(chart);
    const w = chart.width, h = chart.height;
    cctx.fillStyle = "#1b1e24";
    cctx.fillRect(0, 0, w, h);
    const hist = S.history;
    if (hist.length < 1) return;
    const tEnd = hist[hist.length - 1].t, tStart = tEnd - 10;
    let lo = Infinity, hi = -Infinity;
    for (const s of hist) for (const v of s.j) { if (v < lo) lo = v; if (v > hi) hi = v; }
    if (hi - lo < 10) { const m = (hi + lo) / 2; lo = m - 5; hi = m + 5; }
    const pad = (hi - lo) * 0.08; lo -= pad; hi += pad;
    const left = 44 * dpr, right = w - 6 * dpr, top = 6 * dpr, bottom = h - 16 * dpr;
    const X = (t) => left + (t - tStart) / 10 * (right - left);
    const Y = (v) => bottom - (v - lo) / (hi - lo) * (bottom - top);
    cctx.strokeStyle = "#333844";
    cctx.fillStyle = "#8a8f99";
    cctx.font = Math.round(10 * dpr) + "px sans-serif";
    cctx.lineWidth = 1;
    for (let k = 0; k <= 4; k++) {
      const v = lo + (hi - lo) * k / 4;
      cctx.beginPath(); cctx.moveTo(left, Y(v)); cctx.lineTo(right, Y(v)); cctx.stroke();
      cctx.fillText(v.toFixed(0) + "°", 2, Y(v) + 3 * dpr);
    }
    for (let s = 0; s <= 10; s += 2) cctx.fillText("-" + (10 - s) + " s", X(tStart + s) - 10 * dpr, h - 3 * dpr);
    for (let j = 0; j < 6; j++) {
      cctx.strokeStyle = COLOURS[j];
      cctx.lineWidth = 1.5 * dpr;
      cctx.beginPath();
      hist.forEach((s, i) => { const x = X(s.t), y = Y(s.j[j]); if (i === 0) cctx.moveTo(x, y); else cctx.lineTo(x, y); });
      cctx.stroke();
    }
    const last = hist[hist.length - 1].j;
    const legend = last.map((v, j) => "<span style=\"color:" + COLOURS[j] + "\">JT" + (j + 1) + " " + v.toFixed(1) + "</span>").join(" ");
    const lg = $("chart-legend");
    if (lg.dataset.html !== legend) { lg.innerHTML = legend; lg.dataset.html = legend; }
  }

  // ------------------------------------------------------------------ controls
  function on(id, f) { const el = $(id); if (el) el.addEventListener("click", f); }
  on("sw-power", () => act("motor power", "POST", "/panel", { power: !(S.last && S.last.panel.power) }));
  on("sw-run", () => act("RUN/HOLD", "POST", "/panel", { run: !(S.last && S.last.panel.run) }));
  on("sw-repeat", () => act("TEACH/REPEAT", "POST", "/panel", { repeat: !(S.last && S.last.panel.repeat) }));
  on("sw-lock", () => act("TEACH LOCK", "POST", "/panel", { teach_lock: !(S.last && S.last.panel.teach_lock) }));
  on("sw-abs", () => act("ABS.SPEED", "POST", "/abs_speed", { on: !(S.last && S.last.raw.abs_speed) }));
  on("sw-estop", () => {
    const pressed = S.last && S.last.panel.estop;
    act(pressed ? "E-stop release" : "E-stop", "POST", pressed ? "/estop/release" : "/estop/press", {});
  });
  on("btn-reset", () => act("error reset", "POST", "/reset", {}));
  on("btn-speed", () => act("monitor speed", "POST", "/speed", { percent: Number($("speed-input").value) }));
  on("btn-raise", () => act("raise error", "POST", "/faults", { kind: "raise_error", code: $("error-input").value.trim() }));
  on("btn-fault-clear", () => act("clear faults", "DELETE", "/faults"));
  on("btn-fault", () => {
    const kind = $("fault-kind").value;
    const n = (id) => Number($(id).value);
    const body = { kind };
    if (kind === "delay_replies") { body.count = n("fault-count"); body.delay_ms = n("fault-delay"); }
    if (kind === "withhold_replies") body.count = n("fault-count");
    if (kind === "split_reply") { body.parts = n("fault-parts"); body.gap_ms = n("fault-gap"); }
    if (kind === "stop_reading") body.duration_ms = n("fault-duration");
    if (kind === "garbage_reply") body.text = $("fault-text").value;
    act("fault " + kind, "POST", "/faults", body);
  });
  function showFaultParams() {
    const kind = $("fault-kind").value;
    document.querySelectorAll(".fp").forEach((el) => { el.hidden = !el.dataset.for.split(" ").includes(kind); });
  }
  $("fault-kind").addEventListener("change", showFaultParams);
  showFaultParams();

  // Guarded buttons: the first click arms for 3 s, the second sends.
  function guarded(id, label, path) {
    const el = $(id);
    const text = el.textContent;
    let armed = null;
    el.addEventListener("click", () => {
      if (!armed) {
        el.classList.add("armed");
        el.textContent = "Click again: " + label;
        armed = setTimeout(() => { armed = null; el.classList.remove("armed"); el.textContent = text; }, 3000);
        return;
      }
      clearTimeout(armed); armed = null;
      el.classList.remove("armed"); el.textContent = text;
      act(label, "POST", path, { confirm: true });
    });
  }
  guarded("btn-cancel", "cancel motion (5)", "/cancel");
  guarded("btn-stop", "stop program (2)", "/stop");

  // ------------------------------------------------------------------ live feed
  function setLive(on, text) {
    const el = $("live-status");
    el.classList.toggle("off", !on);
    setText(el, text);
  }

  async function loadModel() {
    for (;;) {
      try {
        S.model = await request("GET", "/model");
        draw();
        return;
      } catch (e) {
        setLive(false, "model: " + e.message);
        await new Promise((r) => setTimeout(r, 2000));
      }
    }
  }

  async function live() {
    let delay = 500;
    for (;;) {
      try {
        const r = await fetch("/live", { headers: headers(false), credentials: "same-origin" });
        if (!r.ok || !r.body) throw new Error("live feed: " + r.status);
        setLive(true, "live");
        delay = 500;
        const reader = r.body.getReader();
        const dec = new TextDecoder();
        let buf = "";
        for (;;) {
          const { value, done } = await reader.read();
          if (done) break;
          buf += dec.decode(value, { stream: true });
          let cut;
          while ((cut = buf.indexOf("\n\n")) >= 0) {
            const block = buf.slice(0, cut);
            buf = buf.slice(cut + 2);
            const data = block.split("\n").filter((l) => l.startsWith("data:")).map((l) => l.slice(5).replace(/^ /, "")).join("\n");
            if (data) {
              try { onUpdate(JSON.parse(data)); } catch (e) { showResult("bad update: " + e.message, true); }
            }
          }
        }
        throw new Error("live feed ended");
      } catch (e) {
        setLive(false, "offline (" + e.message + ")");
        await new Promise((r) => setTimeout(r, delay));
        delay = Math.min(5000, delay * 2);
      }
    }
  }

  window.addEventListener("resize", () => { draw(); drawChart(); });

  // For automation and for checking the drawing against the server's kinematics.
  window.fs020n = {
    fk: (joints) => S.model ? fk(S.model.geometry, joints) : null,
    state: () => S.last,
    frames: () => S.history.length,
  };

  loadModel();
  live();
  draw();
})();
