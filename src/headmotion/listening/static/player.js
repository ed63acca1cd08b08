// Stimulus players for the listening test: an mp4 <video>, or motion + audio rendered by the
// project's head viewer component (src/headmotion/web/static, served under /viewer/).
// createPlayer(info, {onplay}) -> {element, play(), stop()}; play() always restarts from the
// beginning so a stimulus can be replayed as often as the participant wants.

const players = new Set();
let viewerModule = null;   // Promise of the viewer ES module (or null when not installed)

export function stopAll(except = null) {
  for (const p of players) if (p !== except) p.stop();
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
  const ready = Promise.all([loadViewer(), fetch(info.motion).then((r) => r.json())]).then(async ([mod, motion]) => {
    if (!mod) {
      box.append(Object.assign(document.createElement("div"), { className: "note", textContent: "3D head viewer not installed: audio only" }));
      return;
    }
    viewer = await mountViewer(mod, box, motion, audio);
  });
  const p = {
    element: box,
    async play() {
      stopAll(p);
      onplay();
      await ready.catch(() => {});
      audio.currentTime = 0;
      if (viewer && viewer.seek) viewer.seek(0);
      audio.play().catch(() => {});
      if (viewer && viewer.play) viewer.play();
    },
    stop() { audio.pause(); if (viewer && viewer.pause) viewer.pause(); },
  };
  players.add(p);
  return p;
}

// Adapter to the viewer component's API (see the comment at the top of its module).
async function mountViewer(mod, container, motion, audio) {
  const make = mod.createViewer || mod.mountViewer || (mod.default && mod.default.createViewer);
  if (!make) { console.warn("viewer module has no createViewer()"); return null; }
  return await make(container, { motion, audio });
}
