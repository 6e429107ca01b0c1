// marl-social teach, the live page: controls bound to settings-tree leaves, one websocket to
// the server (marl_social/teach/server.py), the panes drawn by render.js. Test hooks:
// data-testid attributes and window.marlSocial.stats() -> {t, frames, fps, belief, ...}.
"use strict";

(function () {
  const { Pane, Meter, el, byTestId: $, speedSelect } = window.MarlRender;
  const STATUS_TEXT = {
    compiling: "compiling the numba kernels (first start only: about 20-60 s; cached afterwards)…",
    building: "building the episode…",
    ready: "ready", playing: "playing", paused: "paused", done: "episode over (restart or change a control)",
    disconnected: "disconnected from the server (reload the page)", busy: "busy",
  };
  const app = {
    ws: null, controls: [], values: {}, compare: null, panes: [], episodeId: 0,
    speed: 1, playing: false, state: "connecting", lastFrameAt: 0, meter: new Meter(),
    changeAt: null, changeEpisode: 0, latencyMs: null, error: "", planners: [],
  };

  function send(command) {
    if (app.ws && app.ws.readyState === WebSocket.OPEN) app.ws.send(JSON.stringify(command));
  }

  function setStatus(state) {
    app.state = state;
    $("status").textContent = STATUS_TEXT[state] || state;
    $("status").dataset.state = state;
    $("play").textContent = app.playing ? "❚❚ pause" : "▶ play";
  }

  function showError(text) {
    app.error = text;
    const box = $("error");
    box.textContent = text;  // one line of fixed height: no layout shift under the pointer
    box.title = text;
  }

  function configure() {
    app.changeAt = performance.now();
    app.changeEpisode = app.episodeId;
    app.latencyMs = null;  // until the new episode is drawn
    showError("");
    send({ type: "configure", settings: { ...app.values }, compare: app.compare });
  }

  function buildControls(controls) {
    app.controls = controls;
    const box = $("controls");
    box.textContent = "";
    const keep = app.values;
    app.values = {};
    for (const c of controls) {
      const wrap = el("label", { class: "control" }, box);
      el("span", { class: "control-label", text: c.label }, wrap);
      let input;
      const value = c.name in keep && c.name !== "scenario" && keepable(c, keep[c.name]) ? keep[c.name] : c.default;
      if (c.name === "scenario") app.values.scenario = c.default;
      else app.values[c.name] = value;
      if (c.kind === "choice") {
        input = el("select", {}, wrap);
        c.options.forEach((o) => el("option", { value: o, text: o }, input));
        input.value = c.name === "scenario" ? c.default : value;
      } else if (c.kind === "bool") {
        input = el("input", { type: "checkbox" }, wrap);
        input.checked = !!value;
      } else if (c.kind === "float") {
        input = el("input", { type: "range", min: c.low, max: c.high, step: c.step }, wrap);
        input.value = value;
        const out = el("output", { text: Number(value).toFixed(2) }, wrap);
        input.addEventListener("input", () => { out.textContent = Number(input.value).toFixed(2); });
      } else {
        input = el("input", { type: "number", min: c.low, max: c.high, step: c.step }, wrap);
        input.value = value;
      }
      input.dataset.testid = `control-${c.name}`;
      input.addEventListener("change", () => onControl(c, input));
    }
    const wrap = el("label", { class: "control" }, box);
    el("span", { class: "control-label", text: "compare with planner" }, wrap);
    const compare = el("select", { "data-testid": "control-compare" }, wrap);
    el("option", { value: "", text: "off" }, compare);
    const planners = (controls.find((c) => c.name === "robot.planner") || { options: [] }).options;
    planners.forEach((p) => el("option", { value: p, text: p }, compare));
    compare.value = app.compare || "";
    compare.addEventListener("change", () => { app.compare = compare.value || null; configure(); });
  }

  function keepable(c, v) {
    return c.kind !== "choice" || c.options.includes(v);
  }

  function onControl(c, input) {
    let value;
    if (c.kind === "bool") value = input.checked;
    else if (c.kind === "choice") value = input.value;
    else value = input.value === "" ? input.value : Number(input.value);
    if (c.name === "scenario") {
      app.values = { seed: app.values.seed };
      app.pendingScene = value;
      send({ type: "controls", scenario: value });
      return;
    }
    app.values[c.name] = value;
    configure();
  }

  function onEpisode(msg) {
    app.panes.forEach((p) => p.remove());
    app.episodeId = msg.id;
    const box = $("panes");
    app.panes = msg.panes.map((header, k) => new Pane(box, header, k ? `-${k + 1}` : ""));
  }

  function onFrame(msg) {
    if (msg.id !== app.episodeId) return;
    msg.panes.forEach((frame, k) => app.panes[k] && app.panes[k].push(frame));
    app.lastFrameAt = performance.now();
  }

  function onMessage(event) {
    const msg = JSON.parse(event.data);
    if (msg.type === "status") {
      if (msg.state === "done") app.playing = false;
      setStatus(msg.state === "ready" && app.panes.length ? (app.playing ? "playing" : "paused") : msg.state);
    } else if (msg.type === "controls") {
      buildControls(msg.controls);
      if (app.pendingScene) { app.values.scenario = app.pendingScene; app.pendingScene = null; }
      configure();
    } else if (msg.type === "episode") onEpisode(msg);
    else if (msg.type === "frame") onFrame(msg);
    else if (msg.type === "error") { showError(msg.message); if (!app.panes.length) setStatus("ready"); }
    else if (msg.type === "busy") { showError(msg.message); setStatus("busy"); }
  }

  function connect() {
    const scheme = location.protocol === "https:" ? "wss" : "ws";
    app.ws = new WebSocket(`${scheme}://${location.host}/ws`);
    app.ws.onopen = () => send({ type: "controls", scenario: "occluded_crosswalk" });
    app.ws.onmessage = onMessage;
    app.ws.onclose = () => { if (app.state !== "busy") setStatus("disconnected"); };
  }

  function draw() {
    const interval = (100 / app.speed);
    const s = Math.min(1, (performance.now() - app.lastFrameAt) / interval);
    let drew = false;
    for (const pane of app.panes) { pane.draw(app.playing ? s : 1); drew = drew || !!pane.frame; }
    if (drew) {
      app.meter.drawn();
      if (app.changeAt !== null && app.episodeId > app.changeEpisode && app.panes[0].frame) {
        app.latencyMs = performance.now() - app.changeAt;
        app.changeAt = null;
      }
    }
    requestAnimationFrame(draw);
  }

  function wireButtons() {
    $("play").addEventListener("click", () => {
      if (app.state === "done") { send({ type: "restart" }); }
      app.playing = !app.playing;
      send({ type: app.playing ? "play" : "pause" });
      setStatus(app.playing ? "playing" : "paused");
    });
    $("step").addEventListener("click", () => { app.playing = false; send({ type: "step" }); setStatus("paused"); });
    $("restart").addEventListener("click", () => send({ type: "restart" }));
    speedSelect((value) => { app.speed = value; send({ type: "speed", value }); });
  }

  window.marlSocial = {
    stats() {
      const pane = app.panes[0], frame = pane && pane.frame;
      return {
        t: frame ? frame.t : null, frames: app.meter.frames, fps: app.meter.fps(),
        belief: frame && frame.belief ? frame.belief.headline : null,
        step: frame ? frame.step : null, episode: app.episodeId, state: app.state,
        panes: app.panes.length, latency_ms: app.latencyMs, error: app.error,
        beliefs: app.panes.map((p) => (p.frame && p.frame.belief ? p.frame.belief.headline : null)),
      };
    },
    send,
  };

  wireButtons();
  connect();
  requestAnimationFrame(draw);
})();
