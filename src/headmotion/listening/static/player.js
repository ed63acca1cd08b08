// Stimulus players for the listening test: an mp4 <video>, or motion + audio rendered by the
// project's head viewer component (src/headmotion/web/static, served under /viewer/).
// createPlayer(info, {onplay}) -> {element, play(), stop()}; play() always restarts from the
// beginning so a stimulus can be replayed as often as the participant wants.

const players = new Set();
let viewerModule = null;   // Promise of the viewer ES module (or null when not installed)

export function stopAll(except = null) {
  for (const p of players) if (p !== except) p.stop();
}

// Free every player of the previous trial (WebGL contexts, decoders) before drawing the next.
export function destroyAll() {
  for (const p of players) p.destroy();
  players.clear();
}

function loadViewer() {
  if (viewerModule === null) {
    viewerModule = fetch("/api/test").then((r) => r.json()).then((info) =>
      info.viewer ? import(info.viewer) : null).catch((e) => { console.warn("viewer unavailable", e); return null; });
  }
  return viewerModule;
}

export function createPlayer(info, { onplay = () => {} } = {}) {
  return info.kind === "video" ? videoPlayer(info, onplay) : motionPlayer(info, onplay);
}

function videoPlayer(info, onplay) {
  const box = document.createElement("div");
  box.className = "player";
  const v = document.createElement("video");
  v.src = info.video; v.preload = "auto"; v.playsInline = true; v.controls = false;
  box.append(v);
  const p = {
    element: box,
    play() { stopAll(p); v.currentTime = 0; v.play().catch(() => {}); onplay(); },
    stop() { v.pause(); },
    destroy() { v.pause(); v.removeAttribute("src"); v.load(); },
  };
  players.add(p);
  return p;
}

function motionPlayer(info, onplay) {
  const box = document.createElement("div");
  box.className = "player";
  const audio = new Audio(info.audio);
  audio.preload = "auto";
  let viewer = null;
  const note = (text) => box.append(Object.assign(document.createElement("div"), { className: "note", textContent: text }));
  const ready = Promise.all([loadViewer(), fetch(info.motion).then((r) => r.json())]).then(async ([mod, motion]) => {
    if (!mod) { note("3D head viewer not installed: audio only"); return; }
    try {
      viewer = await mountViewer(mod, box, motion, audio);
      box.dataset.viewer = "ready";
    } catch (e) {
      console.error("viewer failed", e);
      note(`3D head viewer failed (${e && e.message ? e.message : e}): audio only`);
      box.dataset.viewer = "error";
    }
  });
  const p = {
    element: box,
    ready,
    get viewer() { return viewer; },
    async play() {
      stopAll(p);
      onplay();
      await ready.catch(() => {});
      if (viewer) { viewer.seek(0); viewer.play(); return; }
      audio.currentTime = 0;
      audio.play().catch(() => {});
    },
    stop() { if (viewer) viewer.pause(); else audio.pause(); },
    destroy() {
      audio.pause();
      ready.then(() => { if (viewer && viewer.destroy) viewer.destroy(); viewer = null; }).catch(() => {});
    },
  };
  players.add(p);
  return p;
}

// The viewer component's API (comment at the top of src/headmotion/web/js/src/viewer.js):
// mountViewer(element, {motion: {fps, rotvec}, audio: HTMLAudioElement, style, mask, controls}).
let testInfo = null;
async function mountViewer(mod, container, motion, audio) {
  const make = mod.mountViewer || mod.createViewer;
  if (!make) throw new Error("the viewer module exports no mountViewer()");
  if (testInfo === null) testInfo = await fetch("/api/test").then((r) => r.json());
  return await make(container, {
    motion, audio, style: testInfo.viewer_style || "textured", mask: true, controls: false,
    cellAspect: 4 / 3,
  });
}
