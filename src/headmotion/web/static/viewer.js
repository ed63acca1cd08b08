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
// three.js (MIT licence, https://threejs.org) is bundled in ./vendor/; built by web/js/build.mjs.
import{B as I,C as J,D as U,Ea as te,M as Q,N as X,P as k,T as Y,Va as ne,_ as Z,c as q,pa as ee}from"./vendor/chunk-NTRQNTM4.js";var re=`// The head's vertex shader (three.js ShaderMaterial): the neck skinned by scaling the rotation.
attribute vec3 hmColor;
attribute float hmMat;
attribute float hmWeight;
uniform vec3 uRotvec;
uniform vec3 uTrans;
varying vec3 vWorld;
varying vec3 vNrm;
varying vec3 vCol;
varying vec3 vObj;
varying float vMat;
mat3 axisAngle(vec3 r) {
  float a = length(r);
  if (a < 1e-8) return mat3(1.0);
  vec3 k = r / a;
  mat3 K = mat3(0.0, k.z, -k.y, -k.z, 0.0, k.x, k.y, -k.x, 0.0);
  return mat3(1.0) + sin(a) * K + (1.0 - cos(a)) * K * K;
}
void main() {
  mat3 R = axisAngle(uRotvec * hmWeight);
  vec3 p = R * position + uTrans * hmWeight;
  vNrm = normalize(R * normal);
  vWorld = p;
  vObj = position;
  vCol = hmColor;
  vMat = hmMat;
  gl_Position = projectionMatrix * viewMatrix * vec4(p, 1.0);
}`;var ae=`// The head's fragment shader: the textured, smooth and silhouette styles of headmotion.render.offscreen.
varying vec3 vWorld;
varying vec3 vNrm;
varying vec3 vCol;
varying vec3 vObj;
varying float vMat;
uniform int uStyle;
float hash(vec3 p) { return fract(sin(dot(p, vec3(127.1, 311.7, 74.7))) * 43758.5453); }
void main() {
  int mat = int(vMat + 0.5);
  if (uStyle == 2 || mat == 3) { gl_FragColor = vec4(0.0, 0.0, 0.0, 1.0); return; }
  vec3 n = normalize(vNrm);
  vec3 v = normalize(cameraPosition - vWorld);
  if (dot(n, v) < 0.0) n = -n;
  vec3 l1 = normalize(vec3(-0.55, 0.60, 0.75));
  vec3 l2 = normalize(vec3(0.80, 0.10, 0.55));
  vec3 l3 = normalize(vec3(0.20, 0.70, -0.80));
  vec3 base; float specK; float shin; float wrap;
  if (uStyle == 1) {
    base = (mat == 2) ? vec3(0.42, 0.43, 0.45) : vec3(0.74, 0.73, 0.72);
    specK = 0.18; shin = 30.0; wrap = 0.0;
  } else {
    base = pow(vCol, vec3(2.2));
    specK = 0.10; shin = 18.0; wrap = 0.35;
    if (mat == 1) {
      float az = atan(vObj.x, vObj.z - 0.01);
      float s = 0.5 + 0.5 * sin(az * 220.0 + 9.0 * sin(vObj.y * 90.0) + 40.0 * hash(floor(vec3(az * 60.0, 0.0, 0.0))));
      base *= 0.78 + 0.40 * s;
      specK = 0.22; shin = 40.0; wrap = 0.0;
    } else if (mat == 2) { specK = 0.03; shin = 8.0; wrap = 0.1; }
  }
  float d1 = max((dot(n, l1) + wrap) / (1.0 + wrap), 0.0);
  float d2 = max((dot(n, l2) + wrap) / (1.0 + wrap), 0.0);
  float rim = pow(1.0 - max(dot(n, v), 0.0), 3.0) * max(dot(n, l3) + 0.3, 0.0);
  float hemi = 0.5 + 0.5 * n.y;
  vec3 amb = mix(vec3(0.10, 0.09, 0.09), vec3(0.20, 0.21, 0.24), hemi);
  vec3 c = base * (amb + 0.95 * d1 * vec3(1.0, 0.97, 0.93) + 0.35 * d2 * vec3(0.85, 0.90, 1.0));
  if (uStyle == 0 && (mat == 0 || mat == 4)) {
    float sss = max(dot(n, l1) + 0.45, 0.0) * max(0.45 - dot(n, l1), 0.0);
    c += base * vec3(0.35, 0.08, 0.04) * sss;
  }
  vec3 h1 = normalize(l1 + v);
  c += specK * pow(max(dot(n, h1), 0.0), shin) * vec3(1.0);
  c += 0.35 * rim * vec3(1.0);
  gl_FragColor = vec4(pow(clamp(c, 0.0, 1.0), vec3(1.0 / 2.2)), 1.0);
}`;var W=["textured","smooth","silhouette"],fe={textured:13423065,smooth:14408667,silhouette:16777215};function ue(i){let s=new DataView(i);if(String.fromCharCode(s.getUint8(0),s.getUint8(1),s.getUint8(2),s.getUint8(3))!=="HMSH")throw new Error("head_mesh.bin: not a headmotion mesh file");let m=s.getUint32(8,!0),n=12,t={};for(let y=0;y<m;y++){let f=s.getUint32(n,!0);n+=4;let g=new TextDecoder().decode(new Uint8Array(i,n,f));n+=f+(4-f%4)%4;let d=s.getUint32(n,!0),p=s.getUint32(n+4,!0);n+=8;let K=new Float32Array(i.slice(n,n+d*44));n+=d*44;let w=new Uint32Array(i.slice(n,n+p*12));n+=p*12,t[g]={v:K,idx:w,nv:d}}return t}function de(i){let{v:s,idx:o,nv:m}=i,n=(y,f)=>{let g=new Float32Array(m*f);for(let d=0;d<m;d++)for(let p=0;p<f;p++)g[d*f+p]=s[d*11+y+p];return g},t=new Y;return t.setAttribute("position",new k(n(0,3),3)),t.setAttribute("normal",new k(n(3,3),3)),t.setAttribute("hmColor",new k(n(6,3),3)),t.setAttribute("hmMat",new k(n(9,1),1)),t.setAttribute("hmWeight",new k(n(10,1),1)),t.setIndex(new k(o,1)),t}function pe(i,s){if(!i||!(i.fps>0))throw new Error(`motion ${s}: needs a positive fps`);let o=t=>t?t.length&&Array.isArray(t[0])?Float64Array.from(t.flat()):Float64Array.from(t):null,m=o(i.rotvec);if(!m||m.length%3!==0||m.length===0)throw new Error(`motion ${s}: rotvec must be (T, 3)`);let n=o(i.translation);return{fps:Number(i.fps),n:m.length/3,rotvec:m,translation:n,label:s}}async function ve(i){let s=await fetch(i);if(!s.ok)throw new Error(`${i}: HTTP ${s.status}`);return s.json()}function oe(i){let s=Math.floor(i/60),o=i-60*s;return`${s}:${o.toFixed(2).padStart(5,"0")}`}async function ie(i,s={}){let o={style:"textured",mask:!0,controls:!0,cellAspect:1.3333333333333333,...s};if(!W.includes(o.style))throw new Error(`style must be one of ${W.join(", ")}`);let m=o.motions;if(!m&&o.motion&&(m=[typeof o.motion=="string"?{url:o.motion}:{data:o.motion}]),!m||!m.length)throw new Error("mountViewer needs motions: [{label, url | data}]");let n=await Promise.all(m.map(async(e,a)=>{let l=e.label??(m.length>1?`motion ${a+1}`:""),h=e.data??await ve(e.url);return pe(h,l)})),t=null,y=o.audio??o.audioUrl;y instanceof HTMLMediaElement?t=y:y&&(t=new Audio(y),t.preload="auto");let f=document.createElement("div");f.className="hm-viewer",f.style.cssText="position:relative;display:inline-block;max-width:100%;font:13px system-ui,sans-serif";let g=document.createElement("div");g.style.cssText="position:relative;line-height:0";let d=document.createElement("canvas");d.style.cssText="display:block;width:100%;height:auto",g.append(d),f.append(g);let p=n.length,K=n.map((e,a)=>{if(!e.label)return null;let l=document.createElement("div");l.textContent=e.label,l.className="hm-label";let h=o.style!=="silhouette";return l.style.cssText=`position:absolute;top:6px;left:calc(${100*a/p}% + 6px);padding:2px 6px;line-height:1.3;border-radius:3px;background:${h?"rgba(20,20,20,.65)":"rgba(255,255,255,.8)"};color:${h?"#fff":"#000"}`,g.append(l),l}),w=null,u=null,M=null;if(o.controls){let e=document.createElement("div");e.className="hm-controls",e.style.cssText="display:flex;gap:8px;align-items:center;padding:6px 0",w=document.createElement("button"),w.type="button",w.textContent="\u25B6 play",w.className="hm-play",u=document.createElement("input"),u.type="range",u.min="0",u.step="0.001",u.value="0",u.className="hm-seek",u.style.flex="1",M=document.createElement("span"),M.className="hm-time",M.style.fontVariantNumeric="tabular-nums",e.append(w,u,M),f.append(e)}i.append(f);let se=o.meshUrl??new URL("./head_mesh.bin",import.meta.url).href,j=ue(await(await fetch(se)).arrayBuffer()),v=new ne({canvas:d,antialias:!0,preserveDrawingBuffer:!0});v.setPixelRatio(Math.min(window.devicePixelRatio||1,2)),v.setScissorTest(!0);let L=new X,T=new ee({vertexShader:re,fragmentShader:ae,side:q,uniforms:{uRotvec:{value:new U},uTrans:{value:new U},uStyle:{value:W.indexOf(o.style)}}});for(let e of["head","ears","neck","torso",...o.mask?["mask"]:[]])j[e]&&L.add(new Z(de(j[e]),T));let ce=new Q(fe[o.style]),$=new te(26,o.cellAspect,.1,5);$.position.set(0,.08,.86),$.lookAt(0,.045,0);let P=0;function B(){let e=Math.max(160,Math.floor(o.width??Math.min(i.clientWidth||640*p,480*p)));if(e===P)return;P=e;let a=Math.round(e/p/o.cellAspect);v.setSize(e,a,!1),d.style.width=`${e}px`,d.style.height=`${a}px`}B();let A=Math.max(...n.map(e=>e.n/e.fps),t&&isFinite(t.duration)?t.duration:0),r={playing:!1,clockStart:0,clockOffset:0,raf:0,destroyed:!1,dirty:!0,rendered:{time:0,frames:n.map(()=>0),count:0}},D=(e,a)=>Math.max(0,Math.min(e.n-1,Math.floor(a*e.fps+1e-6)));function C(){return t?t.currentTime:r.playing?Math.min(A,r.clockOffset+(performance.now()-r.clockStart)/1e3):r.clockOffset}function z(){return Math.max(A,t&&isFinite(t.duration)?t.duration:0)}function N(){B();let e=C(),a=v.getDrawingBufferSize(new I).divideScalar(v.getPixelRatio()),l=a.x/p,h=a.y,E=[];v.setScissor(0,0,a.x,h),v.setViewport(0,0,a.x,h),v.setClearColor(ce,1),v.clear(),n.forEach((c,x)=>{let b=D(c,e);E.push(b),T.uniforms.uRotvec.value.set(c.rotvec[3*b],c.rotvec[3*b+1],c.rotvec[3*b+2]),c.translation?T.uniforms.uTrans.value.set(c.translation[3*b],c.translation[3*b+1],c.translation[3*b+2]):T.uniforms.uTrans.value.set(0,0,0),v.setViewport(x*l,0,l,h),v.setScissor(x*l,0,l,h),v.render(L,$)}),r.rendered={time:e,frames:E,count:r.rendered.count+1};let R=z();u&&document.activeElement!==u&&(u.max=String(R),u.value=String(e)),M&&(M.textContent=`${oe(e)} / ${oe(R)}`),!t&&r.playing&&e>=A&&O()}let G=-1;function _(){if(r.destroyed)return;let e=i.clientWidth;(r.playing||r.dirty||e!==G)&&(r.dirty=!1,G=e,N()),r.raf=requestAnimationFrame(_)}function S(e){r.playing=e,r.dirty=!0,w&&(w.textContent=e?"\u275A\u275A pause":"\u25B6 play")}function V(){if(t){(t.ended||t.currentTime>=z()-.001)&&(t.currentTime=0);let e=t.play();e&&e.catch&&e.catch(a=>{console.warn("audio could not play:",a),S(!1)})}else r.clockOffset>=A&&(r.clockOffset=0),r.clockStart=performance.now();S(!0)}function O(){t?t.pause():r.clockOffset=C(),S(!1)}function H(e){let a=Math.max(0,Math.min(Number(e)||0,z()));t?t.currentTime=a:(r.clockOffset=a,r.clockStart=performance.now()),N()}t&&(t.addEventListener("play",()=>S(!0)),t.addEventListener("pause",()=>S(!1)),t.addEventListener("ended",()=>S(!1)),t.addEventListener("seeked",()=>N())),w&&w.addEventListener("click",()=>r.playing?O():V()),u&&u.addEventListener("input",()=>H(parseFloat(u.value)));let F={element:f,audio:t,motions:n,duration:A,play:V,pause:O,seek:H,currentTime:C,toggle:()=>r.playing?O():V(),renderNow:N,getState(){let e=C(),a=n.map(c=>D(c,e)),l=new J,h=new U,E=n.map((c,x)=>[c.rotvec[3*a[x]],c.rotvec[3*a[x]+1],c.rotvec[3*a[x]+2]]),R=E.map(c=>{h.set(c[0],c[1],c[2]);let x=h.length();return x<1e-12?[0,0,0,1]:(l.setFromAxisAngle(h.normalize(),x),[l.x,l.y,l.z,l.w])});return{time:e,playing:r.playing,duration:z(),frames:a,rotvec:E,quaternion:R,fps:n.map(c=>c.fps),rendered:{...r.rendered}}},destroy(){r.destroyed=!0,cancelAnimationFrame(r.raf);let e=window.headmotionViewers||[],a=e.indexOf(F);a>=0&&e.splice(a,1),t&&t.pause(),v.dispose(),f.remove()}};return i.headmotionViewer=F,(window.headmotionViewers||(window.headmotionViewers=[])).push(F),_(),F}var he=ie,ke={mountViewer:ie,createViewer:he};export{he as createViewer,ke as default,ie as mountViewer};
