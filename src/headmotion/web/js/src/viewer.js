/**
 * headmotion head viewer — an ES module (three.js bundled in; no CDN, no npm at run time).
 *
 * Plays speech and animates one or several heads in sync with it (side by side, one label each),
 * with play / pause / seek controls.  The head is the project's own model
 * (headmotion.render.mesh, exported to head_mesh.bin beside this file) drawn with the same shading
 * as the offscreen renderer (thesis §4.2.3 styles; black boxes over the eyes and mouth by default).
 * Axis convention (headmotion.rotations): +x speaker's left, +y up, +z forward; the camera faces
 * the speaker, so positive yaw turns the nose to the image's right.
 *
 * API
 * ---
 *   import { mountViewer } from "/viewer/viewer.js";
 *   const v = await mountViewer(element, {
 *     motions: [{ label: "truth", url: "/motion/0.json" },        // or { label, data: {...} }
 *               { label: "TWS",   data: { fps: 100, rotvec: [[x, y, z], ...] } }],
 *     audioUrl: "/audio.wav",          // or audio: an HTMLAudioElement or a URL; optional
 *     style: "textured",               // "textured" | "smooth" | "silhouette"
 *     mask: true,                      // black boxes over the eyes and mouth
 *     controls: true,                  // play/pause button, seek slider, time
 *     cellAspect: 4 / 3,               // width / height of one head's cell
 *     meshUrl: undefined,              // default: head_mesh.bin next to this module
 *   });
 *   // a single motion also works: mountViewer(el, { motion: {fps, rotvec}, audio: audioElement })
 *   v.play(); v.pause(); v.seek(seconds); v.toggle();
 *   v.duration                          // seconds (longest of the motions and the audio)
 *   v.currentTime()                     // the timeline: audio.currentTime when there is audio
 *   v.getState() -> { time, playing, duration, frames: [frame per motion],
 *                     rotvec: [[x, y, z] per motion], quaternion: [[x, y, z, w] per motion],
 *                     rendered: { time, frames, count } }   // what the last drawn image showed
 *   v.renderNow()                       // draw immediately (tests)
 *   v.destroy()
 *   createViewer is an alias of mountViewer.  element.headmotionViewer is set to the viewer, and
 *   every viewer is pushed onto window.headmotionViewers (for tests and the console).
 *
 * Motion JSON: { fps, rotvec: [[x, y, z], ...] radians (T, 3), translation?: [[x, y, z], ...] m }.
 * Frame i is shown from i / fps to (i + 1) / fps, as in the rendered videos.
 */
import {
  BufferAttribute, BufferGeometry, Color, FrontSide, Mesh, PerspectiveCamera, Quaternion, Scene,
  ShaderMaterial, Vector2, Vector3, WebGLRenderer,
} from "three";
import VERTEX from "./head.vert";
import FRAGMENT from "./head.frag";

const STYLES = ["textured", "smooth", "silhouette"];
const BACKGROUND = { textured: 0xccd1d9, smooth: 0xdbdbdb, silhouette: 0xffffff };

/** Parse head_mesh.bin (headmotion.render.mesh.mesh_to_bytes). */
function parseMesh(buf) {
  const dv = new DataView(buf);
  const magic = String.fromCharCode(dv.getUint8(0), dv.getUint8(1), dv.getUint8(2), dv.getUint8(3));
  if (magic !== "HMSH") throw new Error("head_mesh.bin: not a headmotion mesh file");
  const nParts = dv.getUint32(8, true);
  let off = 12;
  const parts = {};
  for (let p = 0; p < nParts; p++) {
    const ln = dv.getUint32(off, true); off += 4;
    const name = new TextDecoder().decode(new Uint8Array(buf, off, ln));
    off += ln + ((4 - (ln % 4)) % 4);
    const nv = dv.getUint32(off, true); const nt = dv.getUint32(off + 4, true); off += 8;
    const v = new Float32Array(buf.slice(off, off + nv * 44)); off += nv * 44;
    const idx = new Uint32Array(buf.slice(off, off + nt * 12)); off += nt * 12;
    parts[name] = { v, idx, nv };
  }
  return parts;
}

function partGeometry(part) {
  const { v, idx, nv } = part;
  const pick = (start, width) => {
    const a = new Float32Array(nv * width);
    for (let i = 0; i < nv; i++) for (let k = 0; k < width; k++) a[i * width + k] = v[i * 11 + start + k];
    return a;
  };
  const g = new BufferGeometry();
  g.setAttribute("position", new BufferAttribute(pick(0, 3), 3));
  g.setAttribute("normal", new BufferAttribute(pick(3, 3), 3));
  g.setAttribute("hmColor", new BufferAttribute(pick(6, 3), 3));
  g.setAttribute("hmMat", new BufferAttribute(pick(9, 1), 1));
  g.setAttribute("hmWeight", new BufferAttribute(pick(10, 1), 1));
  g.setIndex(new BufferAttribute(idx, 1));
  return g;
}

/** Normalise a motion object: {fps, n, rotvec: Float64Array(3n), translation?: Float64Array(3n)}. */
function normaliseMotion(d, label) {
  if (!d || !(d.fps > 0)) throw new Error(`motion ${label}: needs a positive fps`);
  const flat = (a) => {
    if (!a) return null;
    if (a.length && Array.isArray(a[0])) return Float64Array.from(a.flat());
    return Float64Array.from(a);
  };
  const rotvec = flat(d.rotvec);
  if (!rotvec || rotvec.length % 3 !== 0 || rotvec.length === 0) throw new Error(`motion ${label}: rotvec must be (T, 3)`);
  const translation = flat(d.translation);
  return { fps: Number(d.fps), n: rotvec.length / 3, rotvec, translation, label };
}

async function fetchJSON(url) {
  const r = await fetch(url);
  if (!r.ok) throw new Error(`${url}: HTTP ${r.status}`);
  return r.json();
}

function fmt(t) {
  const m = Math.floor(t / 60);
  const s = t - 60 * m;
  return `${m}:${s.toFixed(2).padStart(5, "0")}`;
}

export async function mountViewer(element, options = {}) {
  const opts = { style: "textured", mask: true, controls: true, cellAspect: 4 / 3, ...options };
  if (!STYLES.includes(opts.style)) throw new Error(`style must be one of ${STYLES.join(", ")}`);
  // -- motions -------------------------------------------------------------------------------
  let specs = opts.motions;
  if (!specs && opts.motion) specs = [typeof opts.motion === "string" ? { url: opts.motion } : { data: opts.motion }];
  if (!specs || !specs.length) throw new Error("mountViewer needs motions: [{label, url | data}]");
  const motions = await Promise.all(specs.map(async (s, i) => {
    const label = s.label ?? (specs.length > 1 ? `motion ${i + 1}` : "");
    const data = s.data ?? await fetchJSON(s.url);
    return normaliseMotion(data, label);
  }));
  // -- audio ---------------------------------------------------------------------------------
  let audio = null;
  const src = opts.audio ?? opts.audioUrl;
  if (src instanceof HTMLMediaElement) audio = src;
  else if (src) { audio = new Audio(src); audio.preload = "auto"; }
  // -- DOM -----------------------------------------------------------------------------------
  const root = document.createElement("div");
  root.className = "hm-viewer";
  root.style.cssText = "position:relative;display:inline-block;max-width:100%;font:13px system-ui,sans-serif";
  const stage = document.createElement("div");
  stage.style.cssText = "position:relative;line-height:0";
  const canvas = document.createElement("canvas");
  canvas.style.cssText = "display:block;width:100%;height:auto";
  stage.append(canvas);
  root.append(stage);
  const n = motions.length;
  const labels = motions.map((m, i) => {
    if (!m.label) return null;
    const d = document.createElement("div");
    d.textContent = m.label;
    d.className = "hm-label";
    const dark = opts.style !== "silhouette";
    d.style.cssText = `position:absolute;top:6px;left:calc(${(100 * i) / n}% + 6px);padding:2px 6px;line-height:1.3;` +
      `border-radius:3px;background:${dark ? "rgba(20,20,20,.65)" : "rgba(255,255,255,.8)"};color:${dark ? "#fff" : "#000"}`;
    stage.append(d);
    return d;
  });
  let playBtn = null; let slider = null; let timeText = null;
  if (opts.controls) {
    const bar = document.createElement("div");
    bar.className = "hm-controls";
    bar.style.cssText = "display:flex;gap:8px;align-items:center;padding:6px 0";
    playBtn = document.createElement("button");
    playBtn.type = "button"; playBtn.textContent = "▶ play"; playBtn.className = "hm-play";
    slider = document.createElement("input");
    slider.type = "range"; slider.min = "0"; slider.step = "0.001"; slider.value = "0"; slider.className = "hm-seek";
    slider.style.flex = "1";
    timeText = document.createElement("span");
    timeText.className = "hm-time"; timeText.style.fontVariantNumeric = "tabular-nums";
    bar.append(playBtn, slider, timeText);
    root.append(bar);
  }
  element.append(root);
  // -- three.js ------------------------------------------------------------------------------
  const meshUrl = opts.meshUrl ?? new URL("./head_mesh.bin", import.meta.url).href;
  const parts = parseMesh(await (await fetch(meshUrl)).arrayBuffer());
  const renderer = new WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
  renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));
  renderer.setScissorTest(true);
  const scene = new Scene();
  const material = new ShaderMaterial({
    vertexShader: VERTEX, fragmentShader: FRAGMENT, side: FrontSide,
    uniforms: { uRotvec: { value: new Vector3() }, uTrans: { value: new Vector3() }, uStyle: { value: STYLES.indexOf(opts.style) } },
  });
  for (const name of ["head", "ears", "neck", "torso", ...(opts.mask ? ["mask"] : [])]) {
    if (parts[name]) scene.add(new Mesh(partGeometry(parts[name]), material));
  }
  const bg = new Color(BACKGROUND[opts.style]);
  const camera = new PerspectiveCamera(26, opts.cellAspect, 0.1, 5);
  camera.position.set(0, 0.08, 0.86);
  camera.lookAt(0, 0.045, 0);
  let cssWidth = 0;
  function resize() {
    const w = Math.max(160, Math.floor(opts.width ?? Math.min(element.clientWidth || 640 * n, 480 * n)));
    if (w === cssWidth) return;
    cssWidth = w;
    const h = Math.round(w / n / opts.cellAspect);
    renderer.setSize(w, h, false);
    canvas.style.width = `${w}px`;
    canvas.style.height = `${h}px`;
  }
  resize();
  const duration = Math.max(...motions.map((m) => m.n / m.fps), audio && isFinite(audio.duration) ? audio.duration : 0);
  const state = { playing: false, clockStart: 0, clockOffset: 0, raf: 0, destroyed: false, dirty: true,
    rendered: { time: 0, frames: motions.map(() => 0), count: 0 } };

  const frameAt = (m, t) => Math.max(0, Math.min(m.n - 1, Math.floor(t * m.fps + 1e-6)));
  function currentTime() {
    if (audio) return audio.currentTime;
    if (!state.playing) return state.clockOffset;
    return Math.min(duration, state.clockOffset + (performance.now() - state.clockStart) / 1000);
  }
  function totalDuration() {
    return Math.max(duration, audio && isFinite(audio.duration) ? audio.duration : 0);
  }
  function draw() {
    resize();
    const t = currentTime();
    const size = renderer.getDrawingBufferSize(new Vector2()).divideScalar(renderer.getPixelRatio());
    const cw = size.x / n; const ch = size.y;
    const frames = [];
    renderer.setScissor(0, 0, size.x, ch); renderer.setViewport(0, 0, size.x, ch);
    renderer.setClearColor(bg, 1); renderer.clear();
    motions.forEach((m, i) => {
      const f = frameAt(m, t);
      frames.push(f);
      material.uniforms.uRotvec.value.set(m.rotvec[3 * f], m.rotvec[3 * f + 1], m.rotvec[3 * f + 2]);
      if (m.translation) material.uniforms.uTrans.value.set(m.translation[3 * f], m.translation[3 * f + 1], m.translation[3 * f + 2]);
      else material.uniforms.uTrans.value.set(0, 0, 0);
      renderer.setViewport(i * cw, 0, cw, ch); renderer.setScissor(i * cw, 0, cw, ch);
      renderer.render(scene, camera);
    });
    state.rendered = { time: t, frames, count: state.rendered.count + 1 };
    const dur = totalDuration();
    if (slider && document.activeElement !== slider) { slider.max = String(dur); slider.value = String(t); }
    if (timeText) timeText.textContent = `${fmt(t)} / ${fmt(dur)}`;
    if (!audio && state.playing && t >= duration) pause();
  }
  // Redraw only while playing or after something changed (seek, pause, resize): a paused
  // viewer costs nothing, which matters with several software-WebGL viewers on one page.
  let lastWidth = -1;
  function loop() {
    if (state.destroyed) return;
    const width = element.clientWidth;
    if (state.playing || state.dirty || width !== lastWidth) {
      state.dirty = false;
      lastWidth = width;
      draw();
    }
    state.raf = requestAnimationFrame(loop);
  }
  function setPlaying(p) {
    state.playing = p;
    state.dirty = true;
    if (playBtn) playBtn.textContent = p ? "❚❚ pause" : "▶ play";
  }
  function play() {
    if (audio) {
      if (audio.ended || audio.currentTime >= totalDuration() - 1e-3) audio.currentTime = 0;
      const pr = audio.play();
      if (pr && pr.catch) pr.catch((e) => { console.warn("audio could not play:", e); setPlaying(false); });
    } else {
      if (state.clockOffset >= duration) state.clockOffset = 0;
      state.clockStart = performance.now();
    }
    setPlaying(true);
  }
  function pause() {
    if (audio) audio.pause();
    else state.clockOffset = currentTime();
    setPlaying(false);
  }
  function seek(t) {
    const x = Math.max(0, Math.min(Number(t) || 0, totalDuration()));
    if (audio) audio.currentTime = x;
    else { state.clockOffset = x; state.clockStart = performance.now(); }
    draw();
  }
  if (audio) {
    audio.addEventListener("play", () => setPlaying(true));
    audio.addEventListener("pause", () => setPlaying(false));
    audio.addEventListener("ended", () => setPlaying(false));
    audio.addEventListener("seeked", () => draw());
  }
  if (playBtn) playBtn.addEventListener("click", () => (state.playing ? pause() : play()));
  if (slider) slider.addEventListener("input", () => seek(parseFloat(slider.value)));
  const viewer = {
    element: root, audio, motions, duration,
    play, pause, seek, currentTime,
    toggle: () => (state.playing ? pause() : play()),
    renderNow: draw,
    getState() {
      const t = currentTime();
      const frames = motions.map((m) => frameAt(m, t));
      const q = new Quaternion(); const ax = new Vector3();
      const rotvec = motions.map((m, i) => [m.rotvec[3 * frames[i]], m.rotvec[3 * frames[i] + 1], m.rotvec[3 * frames[i] + 2]]);
      const quaternion = rotvec.map((r) => {
        ax.set(r[0], r[1], r[2]);
        const a = ax.length();
        if (a < 1e-12) return [0, 0, 0, 1];
        q.setFromAxisAngle(ax.normalize(), a);
        return [q.x, q.y, q.z, q.w];
      });
      return { time: t, playing: state.playing, duration: totalDuration(), frames, rotvec, quaternion,
        fps: motions.map((m) => m.fps), rendered: { ...state.rendered } };
    },
    destroy() {
      state.destroyed = true;
      cancelAnimationFrame(state.raf);
      const list = window.headmotionViewers || [];
      const k = list.indexOf(viewer);
      if (k >= 0) list.splice(k, 1);
      if (audio) audio.pause();
      renderer.dispose();
      root.remove();
    },
  };
  element.headmotionViewer = viewer;
  (window.headmotionViewers ||= []).push(viewer);
  loop();
  return viewer;
}

export const createViewer = mountViewer;
export default { mountViewer, createViewer };
