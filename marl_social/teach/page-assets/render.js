// marl-social teach: the drawing code, shared by the live app (app.js) and the docs' static
// player (player.js). A Pane draws one episode: the map with every agent, each agent's field
// of view in its colour, what the robot sees (dashed outlines), where each hidden hypothesis
// would be (discs, opacity = belief); the belief bars; the robot's planned speed profile per
// branch; a strip chart of speeds and belief over time. Frames come from
// marl_social/teach/scene_json.py (metres, radians, m/s). No dependencies, no build step.
"use strict";

(function (global) {
  const TAU = 2 * Math.PI;

  function el(tag, attrs, parent) {
    const node = document.createElement(tag);
    for (const [k, v] of Object.entries(attrs || {})) {
      if (k === "text") node.textContent = v;
      else if (k === "class") node.className = v;
      else node.setAttribute(k, v);
    }
    if (parent) parent.appendChild(node);
    return node;
  }

  function fitCanvas(canvas) {
    const ratio = global.devicePixelRatio || 1;
    const w = Math.max(50, Math.round(canvas.clientWidth * ratio));
    const h = Math.max(30, Math.round(canvas.clientHeight * ratio));
    if (canvas.width !== w || canvas.height !== h) { canvas.width = w; canvas.height = h; }
    return ratio;
  }

  function lerpAngle(a, b, s) {
    let d = (b - a) % TAU;
    if (d > Math.PI) d -= TAU;
    if (d < -Math.PI) d += TAU;
    return a + s * d;
  }

  function hexAlpha(hex, alpha) {
    const n = parseInt(hex.slice(1), 16);
    return `rgba(${(n >> 16) & 255},${(n >> 8) & 255},${n & 255},${alpha})`;
  }

  class Pane {
    // container: the element the pane fills; header: scene_json's episode header; ids: the
    // data-testid suffix ("" for the first pane, "-2" for the second).
    constructor(container, header, suffix) {
      this.header = header;
      this.root = el("section", { class: "pane" }, container);
      el("h2", { text: `${header.scenario} · robot planner: ${header.planner} · seed ${header.seed}` },
        this.root);
      const top = el("div", { class: "pane-top" }, this.root);
      this.scene = el("canvas", { class: "scene", "data-testid": "scene" + suffix }, top);
      const side = el("div", { class: "side" }, top);
      el("h3", { text: "robot's belief" }, side);
      this.beliefBox = el("div", { class: "belief", "data-testid": "belief" + suffix }, side);
      el("h3", { text: "robot's planned speed per branch [m/s]" }, side);
      this.plan = el("canvas", { class: "plan", "data-testid": "plan" + suffix }, side);
      el("h3", { text: "speeds [m/s] and belief over time" }, this.root);
      this.strip = el("canvas", { class: "strip", "data-testid": "strip" + suffix }, this.root);
      this.history = [];
      this.prev = null;
      this.frame = null;
      this.beliefKey = "";
    }

    remove() { this.root.remove(); }

    // a new step: remembered for the strip chart; drawing eases from the previous one
    push(frame) {
      if (this.history.length && frame.step <= this.history[this.history.length - 1].step) {
        this.history = this.history.filter((f) => f.step < frame.step);
      }
      this.history.push({ step: frame.step, t: frame.t, speeds: frame.agents.map((a) => a[3]),
                          active: frame.agents.map((a) => a[4]),
                          belief: frame.belief ? frame.belief.headline : null });
      this.prev = this.frame && this.frame.step === frame.step - 1 ? this.frame : frame;
      this.frame = frame;
      this.drawBelief();
      this.drawPlan();
      this.drawStrip();
    }

    // the world: s in [0, 1] eases the agents from the previous step to this one
    draw(s) {
      if (!this.frame) return;
      const canvas = this.scene, ctx = canvas.getContext("2d");
      const ratio = fitCanvas(canvas);
      const h = this.header, pal = h.palette, map = h.map, f = this.frame, p = this.prev;
      const [x0, x1, y0, y1] = map.extent;
      let scale = Math.min(canvas.width / (x1 - x0), canvas.height / (y1 - y0));
      let left = x0, bottom = y0 + 0.5 * (y1 - y0) - 0.5 * canvas.height / scale;
      const minScale = 3 * ratio; // px per m below which the view follows the robot
      if (scale < minScale) {
        scale = minScale;
        const r = h.robot !== null ? f.agents[h.robot] : f.agents[0];
        left = Math.min(Math.max(r[0] - 0.5 * canvas.width / scale, x0), x1 - canvas.width / scale);
        bottom = r[1] - 0.5 * canvas.height / scale;
      } else {
        left = x0 + 0.5 * (x1 - x0) - 0.5 * canvas.width / scale;
      }
      const X = (x) => (x - left) * scale, Y = (y) => canvas.height - (y - bottom) * scale;
      const poly = (pts, close) => {
        ctx.beginPath();
        pts.forEach((q, i) => (i ? ctx.lineTo(X(q[0]), Y(q[1])) : ctx.moveTo(X(q[0]), Y(q[1]))));
        if (close) ctx.closePath();
      };
      ctx.fillStyle = pal.background;
      ctx.fillRect(0, 0, canvas.width, canvas.height);
      ctx.fillStyle = pal.road;
      map.lanes.forEach((q) => { poly(q, true); ctx.fill(); });
      ctx.strokeStyle = pal.marking;
      ctx.lineWidth = 1.5 * ratio;
      map.solid.forEach((q) => { poly(q, false); ctx.stroke(); });
      ctx.lineWidth = 1 * ratio;
      map.dashed.forEach((q) => { poly(q, false); ctx.stroke(); });
      ctx.fillStyle = pal.marking;
      map.stripes.forEach((q) => { poly(q, true); ctx.fill(); });
      ctx.lineWidth = 2.5 * ratio;
      map.stop_lines.forEach((q) => { poly(q, false); ctx.stroke(); });
      ctx.fillStyle = pal.house;
      ctx.strokeStyle = pal.house_edge;
      ctx.lineWidth = 1 * ratio;
      map.houses.forEach((q) => { poly(q, true); ctx.fill(); ctx.stroke(); });
      map.signal_heads.forEach((q, i) => {
        ctx.fillStyle = pal.signals[f.signals[i]] || "#333";
        ctx.fillRect(X(q[0]) - 4 * ratio, Y(q[1]) - 4 * ratio, 8 * ratio, 8 * ratio);
      });
      if (map.robot_route) {
        ctx.setLineDash([6 * ratio, 6 * ratio]);
        ctx.strokeStyle = hexAlpha(pal.roles.robot, 0.5);
        poly(map.robot_route, false); ctx.stroke();
        ctx.setLineDash([]);
      }
      // fields of view (this step's), each in its agent's colour
      for (const [i, outline] of f.fov) {
        const role = h.agents[i].role, colour = pal.roles[role] || "#888";
        poly(outline, true);
        ctx.fillStyle = hexAlpha(colour, pal.fan_alpha[role] || 0.1);
        ctx.fill();
        ctx.strokeStyle = hexAlpha(colour, 0.45);
        ctx.lineWidth = 0.8 * ratio;
        ctx.stroke();
      }
      // where each hidden hypothesis puts its agent, opacity = belief
      if (f.belief) {
        for (const [x, y, prob, ped] of f.belief.spots) {
          ctx.beginPath();
          ctx.arc(X(x), Y(y), (ped ? 0.9 : 2.0) * scale, 0, TAU);
          ctx.fillStyle = hexAlpha(pal.beliefs[0], Math.min(0.9, 0.15 + 3 * prob));
          ctx.fill();
        }
      }
      // agents, eased between the two steps
      const names = [];
      f.agents.forEach((a, i) => {
        if (!a[4]) return;
        const b = p.agents[i] || a, spec = h.agents[i];
        const x = b[0] + s * (a[0] - b[0]), y = b[1] + s * (a[1] - b[1]);
        const yaw = lerpAngle(b[2], a[2], s);
        const colour = pal.roles[spec.role] || "#888", edge = pal.role_edges[spec.role] || "#333";
        ctx.save();
        ctx.translate(X(x), Y(y));
        ctx.rotate(-yaw);
        ctx.fillStyle = colour;
        ctx.strokeStyle = edge;
        ctx.lineWidth = 1 * ratio;
        const seen = f.seen.includes(i) && i !== h.robot;
        if (spec.pedestrian) {
          const r = Math.max(0.5 * spec.width * scale, 3 * ratio);
          ctx.beginPath(); ctx.arc(0, 0, r, 0, TAU); ctx.fill(); ctx.stroke();
          if (seen) { this.seenOutline(ctx, () => { ctx.arc(0, 0, r + 3 * ratio, 0, TAU); }, ratio, pal); }
        } else {
          const L = spec.length * scale, W = spec.width * scale;
          ctx.fillRect(-L / 2, -W / 2, L, W); ctx.strokeRect(-L / 2, -W / 2, L, W);
          ctx.fillStyle = "rgba(0,0,0,0.35)";
          ctx.beginPath(); ctx.moveTo(0.45 * L, 0); ctx.lineTo(0.15 * L, -0.3 * W);
          ctx.lineTo(0.15 * L, 0.3 * W); ctx.closePath(); ctx.fill();
          if (seen) { this.seenOutline(ctx, () => { ctx.rect(-L / 2 - 3 * ratio, -W / 2 - 3 * ratio, L + 6 * ratio, W + 6 * ratio); }, ratio, pal); }
        }
        ctx.restore();
        names.push([spec.name, X(x), Y(y) - (spec.pedestrian ? 8 : 10) * ratio]);
      });
      ctx.fillStyle = "#1a1a1a";
      ctx.font = `${11 * ratio}px sans-serif`;
      ctx.textAlign = "center";
      names.forEach(([n, x, y]) => ctx.fillText(n, x, y));
      ctx.textAlign = "left";
      ctx.font = `${13 * ratio}px monospace`;
      const t = p.t + s * (f.t - p.t);
      ctx.fillText(`t = ${t.toFixed(1)} s`, 8 * ratio, 18 * ratio);
      // scale bar: 10 m
      ctx.fillRect(8 * ratio, canvas.height - 10 * ratio, 10 * scale, 3 * ratio);
      ctx.fillText("10 m", 12 * ratio + 10 * scale, canvas.height - 6 * ratio);
    }

    seenOutline(ctx, path, ratio, pal) {
      ctx.beginPath(); path();
      ctx.setLineDash([3 * ratio, 3 * ratio]);
      ctx.strokeStyle = pal.roles.robot; ctx.lineWidth = 1.5 * ratio; ctx.stroke();
      ctx.setLineDash([]);
    }

    drawBelief() {
      const b = this.frame.belief, box = this.beliefBox;
      if (!b) {
        box.dataset.value = "";
        if (this.beliefKey !== "none") {
          box.textContent = "this planner keeps no belief over hidden agents";
          this.beliefKey = "none";
        }
        return;
      }
      box.dataset.value = String(b.headline);
      const key = JSON.stringify([b.paths, b.perceived]);
      if (key === this.beliefKey) return;
      this.beliefKey = key;
      box.textContent = "";
      const head = el("div", { class: "headline" }, box);
      head.textContent = `P(hidden agent) = ${b.headline.toFixed(2)}` +
        (b.perceived ? "  (seen by the robot itself)" : "  (inferred)");
      const pal = this.header.palette.beliefs;
      b.paths.forEach(([name, prob], k) => {
        const row = el("div", { class: "bar-row" }, box);
        el("span", { class: "bar-name", text: name }, row);
        const track = el("span", { class: "bar-track" }, row);
        const bar = el("span", { class: "bar" }, track);
        bar.style.width = `${(100 * prob).toFixed(1)}%`;
        bar.style.background = name === "none" ? "#999" : pal[k % pal.length];
        el("span", { class: "bar-value", text: prob.toFixed(3) }, row);
      });
    }

    drawPlan() {
      const canvas = this.plan, ctx = canvas.getContext("2d"), ratio = fitCanvas(canvas);
      ctx.clearRect(0, 0, canvas.width, canvas.height);
      const plan = this.frame.plan, W = canvas.width, H = canvas.height, pad = 22 * ratio;
      ctx.font = `${10 * ratio}px sans-serif`;
      ctx.fillStyle = "#444";
      if (!plan || !plan.speeds.length) { ctx.fillText("no MPC plan (this planner)", pad, H / 2); return; }
      const n = plan.speeds[0].length, horizon = n * plan.dt;
      const vmax = Math.max(14, ...plan.speeds.flat());
      const X = (t) => pad + (W - 1.5 * pad) * t / horizon, Y = (v) => H - pad - (H - 1.6 * pad) * v / vmax;
      this.axes(ctx, X, Y, horizon, vmax, ratio, "s ahead");
      const pal = this.header.palette.beliefs;
      plan.speeds.forEach((row, k) => {
        ctx.beginPath();
        ctx.moveTo(X(0), Y(this.frame.agents[this.header.robot][3]));
        row.forEach((v, j) => ctx.lineTo(X((j + 1) * plan.dt), Y(v)));
        ctx.strokeStyle = plan.labels[k] === "none" ? "#666" : pal[k % pal.length];
        ctx.lineWidth = (1 + 4 * (plan.weights[k] || 0)) * ratio;
        ctx.stroke();
      });
      ctx.fillStyle = "#222";
      const shown = plan.labels.map((l, k) => `${l} ${(plan.weights[k] || 0).toFixed(2)}`);
      ctx.fillText(`${plan.speeds.length} branch(es)${plan.feasible ? "" : " — infeasible: brakes"}`, pad + 4, 12 * ratio);
      ctx.fillText(shown.slice(0, 3).join(" · "), pad + 4, 24 * ratio);
    }

    axes(ctx, X, Y, tmax, vmax, ratio, xlabel) {
      ctx.strokeStyle = "#999"; ctx.lineWidth = 1;
      ctx.beginPath(); ctx.moveTo(X(0), Y(vmax)); ctx.lineTo(X(0), Y(0)); ctx.lineTo(X(tmax), Y(0)); ctx.stroke();
      ctx.fillStyle = "#444";
      ctx.fillText(vmax.toFixed(0), 2, Y(vmax) + 8 * ratio);
      ctx.fillText("0", 2, Y(0));
      ctx.fillText(`${tmax.toFixed(0)} ${xlabel}`, X(tmax) - 40 * ratio, Y(0) + 14 * ratio);
    }

    drawStrip() {
      const canvas = this.strip, ctx = canvas.getContext("2d"), ratio = fitCanvas(canvas);
      ctx.clearRect(0, 0, canvas.width, canvas.height);
      const h = this.header, W = canvas.width, H = canvas.height, pad = 22 * ratio;
      const tmax = h.max_steps * h.dt, vmax = 14;
      ctx.font = `${10 * ratio}px sans-serif`;
      const X = (t) => pad + (W - 2 * pad) * t / tmax, Y = (v) => H - pad - (H - 1.5 * pad) * v / vmax;
      const B = (p) => H - pad - (H - 1.5 * pad) * p;
      this.axes(ctx, X, Y, tmax, vmax, ratio, "s");
      const hist = this.history;
      h.agents.forEach((spec, i) => {
        if (spec.pedestrian) return;
        ctx.beginPath();
        let on = false;
        hist.forEach((r) => {
          if (!r.active[i]) { on = false; return; }
          if (on) ctx.lineTo(X(r.t), Y(r.speeds[i])); else ctx.moveTo(X(r.t), Y(r.speeds[i]));
          on = true;
        });
        ctx.strokeStyle = h.palette.roles[spec.role] || "#888";
        ctx.lineWidth = (spec.role === "robot" ? 2 : 1.2) * ratio;
        ctx.stroke();
      });
      if (hist.some((r) => r.belief !== null)) {
        ctx.beginPath();
        hist.forEach((r, k) => (k ? ctx.lineTo(X(r.t), B(r.belief)) : ctx.moveTo(X(r.t), B(r.belief))));
        ctx.strokeStyle = h.palette.beliefs[0]; ctx.lineWidth = 1.5 * ratio;
        ctx.setLineDash([4 * ratio, 2 * ratio]); ctx.stroke(); ctx.setLineDash([]);
        ctx.fillStyle = h.palette.beliefs[0];
        ctx.fillText("belief (0-1, dashed)", W - 120 * ratio, 12 * ratio);
      }
      ctx.fillStyle = h.palette.roles.robot;
      ctx.fillText("robot speed", W - 220 * ratio, 12 * ratio);
    }
  }

  // Playback clock and the stats hook shared by the app and the player: call `drawn()` once
  // per drawn frame; `stats()` is window.marlSocial.stats().
  class Meter {
    constructor() { this.frames = 0; this.stamps = []; }
    drawn() {
      const now = performance.now();
      this.frames += 1;
      this.stamps.push(now);
      while (this.stamps.length && now - this.stamps[0] > 1000) this.stamps.shift();
    }
    fps() {
      if (this.stamps.length < 2) return 0;
      const span = this.stamps[this.stamps.length - 1] - this.stamps[0];
      return span > 0 ? (1000 * (this.stamps.length - 1)) / span : 0;
    }
  }

  const SPEEDS = [0.25, 0.5, 1, 2, 4];  // the playback speeds offered

  // the element with data-testid=id (the page's stable hooks)
  const byTestId = (id) => document.querySelector(`[data-testid="${id}"]`);

  // fill the "speed" select with SPEEDS (1x chosen) and call onChange(speed) on a change
  function speedSelect(onChange) {
    const speed = byTestId("speed");
    SPEEDS.forEach((v) => el("option", { value: v, text: `${v}×` }, speed));
    speed.value = "1";
    speed.addEventListener("change", () => onChange(Number(speed.value)));
  }

  global.MarlRender = { Pane, Meter, el, byTestId, speedSelect };
})(window);
