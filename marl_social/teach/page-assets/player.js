// marl-social teach, the static player of the docs site: precomputed episodes (JSON written by
// marl_social/teach/export.py) drawn by the live app's render.js, with the same hooks
// (data-testid attributes, window.marlSocial.stats()). No server.
"use strict";

(function () {
  const { Pane, Meter, el, byTestId: $, speedSelect } = window.MarlRender;
  const base = document.currentScript.dataset.episodes || "episodes/";
  const player = { episode: null, panes: [], k: 0, playing: false, speed: 1, lastStepAt: 0,
                   meter: new Meter(), id: 0 };

  function show(k) {
    player.k = k;
    player.panes.forEach((pane, j) => pane.push(player.episode.panes[j].frames[k]));
    player.lastStepAt = performance.now();
  }

  function last() { return Math.min(...player.episode.panes.map((p) => p.frames.length)) - 1; }

  function setPlaying(on) {
    player.playing = on;
    $("play").textContent = on ? "❚❚ pause" : "▶ play";
    $("status").textContent = on ? "playing" : (player.k >= last() ? "episode over" : "paused");
  }

  async function load(file) {
    $("status").textContent = "loading…";
    const response = await fetch(base + file);
    if (!response.ok) { $("error").textContent = `could not load ${file}: HTTP ${response.status}`; return; }
    player.episode = await response.json();
    player.panes.forEach((p) => p.remove());
    player.id += 1;
    const box = $("panes");
    player.panes = player.episode.panes.map((p, j) => new Pane(box, p.header, j ? `-${j + 1}` : ""));
    show(0);
    setPlaying(false);
  }

  function tick() {
    if (player.episode) {
      const interval = 100 / player.speed, now = performance.now();
      if (player.playing && now - player.lastStepAt >= interval) {
        if (player.k < last()) show(player.k + 1); else setPlaying(false);
      }
      const s = player.playing ? Math.min(1, (performance.now() - player.lastStepAt) / interval) : 1;
      player.panes.forEach((p) => p.draw(s));
      player.meter.drawn();
    }
    requestAnimationFrame(tick);
  }

  async function start() {
    const index = await (await fetch(base + "index.json")).json();
    const select = $("control-episode");
    index.forEach((e) => el("option", { value: e.file, text: e.title }, select));
    select.addEventListener("change", () => load(select.value));
    $("play").addEventListener("click", () => {
      if (player.k >= last()) show(0);
      setPlaying(!player.playing);
    });
    $("step").addEventListener("click", () => { setPlaying(false); if (player.k < last()) show(player.k + 1); });
    $("restart").addEventListener("click", () => show(0));
    speedSelect((value) => { player.speed = value; });
    await load(index[0].file);
    requestAnimationFrame(tick);
  }

  window.marlSocial = {
    stats() {
      const pane = player.panes[0], frame = pane && pane.frame;
      return {
        t: frame ? frame.t : null, frames: player.meter.frames, fps: player.meter.fps(),
        belief: frame && frame.belief ? frame.belief.headline : null,
        step: frame ? frame.step : null, episode: player.id, panes: player.panes.length,
        state: player.playing ? "playing" : "paused",
      };
    },
  };
  start();
})();
