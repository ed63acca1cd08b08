/**
 * headmotion avatar — an ES module (three.js, its GLTFLoader and @pixiv/three-vrm bundled in; no CDN,
 * no npm at run time) that loads a VRM avatar and turns its neck and head bones.
 *
 * The default avatar is the project's own (avatar.vrm next to this module: the head model of
 * headmotion.render.mesh as a VRM 1.0 bust, written by headmotion.web.build_assets); any VRM 1.0
 * or 0.x file with neck and head bones works.  A rotation vector r (headmotion's axes: +x the
 * avatar's left, +y up, +z forward; radians; the head against the torso) is split as the BVH and
 * glTF writers split it: the neck turns by s·r and the head by (1 − s)·r, s the file's
 * asset.extras.neck_share (0.93 when the file has none).
 *
 * API
 * ---
 *   import { mountAvatar } from "/v1/avatar/static/avatar.js";
 *   const a = await mountAvatar(element, { vrmUrl: undefined,    // default: avatar.vrm beside this module
 *                                          width, height,       // default: the element's width, 4:3
 *                                          antialias,           // default: unless WebGL is drawn by the CPU
 *                                          pixelRatio });       // default: the screen's; 0.5 when WebGL is
 *                                                               // drawn by the CPU (a quarter of the pixels:
 *                                                               // drawing them competed with the stream for
 *                                                               // the cores: a median of 240 against 87 ms
 *                                                               // from the audio to the bone on 2 cores)
 *   a.setRotvec([rx, ry, rz]);     // pose the neck and head bones now (radians)
 *   a.headRotation()               // [pitch, yaw, roll] degrees: the head bone against its rest pose,
 *                                  // relative to the chest, read back from the bones (intrinsic YXZ)
 *   a.renderNow(); a.destroy();
 *   a.vrm, a.neckShare             // the loaded @pixiv/three-vrm VRM; the split in use
 */
// three.js (MIT licence, https://threejs.org) and @pixiv/three-vrm (MIT licence, https://github.com/pixiv/three-vrm) are bundled in ./vendor/; built by web/js/build.mjs.
import{a as H,b as p}from"./vendor/chunk-3RZZO67R.js";import{a as Q}from"./vendor/chunk-YWD7VCKZ.js";import{C as d,D as E,Da as z,Ea as U,Ia as y,J as k,Ja as q,M as D,N as P,Va as F,x as V}from"./vendor/chunk-NTRQNTM4.js";var X=.93,N=180/Math.PI;function $(t,r,a){let s=Math.hypot(t[0],t[1],t[2])*r;if(s<1e-12)return a.identity();let l=new E(t[0],t[1],t[2]).normalize();return a.setFromAxisAngle(l,s)}function Y(){try{let t=document.createElement("canvas").getContext("webgl2")||document.createElement("canvas").getContext("webgl");if(!t)return!0;let r=t.getExtension("WEBGL_debug_renderer_info"),a=String(t.getParameter(r?r.UNMASKED_RENDERER_WEBGL:t.RENDERER)),s=t.getExtension("WEBGL_lose_context");return s&&s.loseContext(),/swiftshader|llvmpipe|software/i.test(a)}catch{return!0}}async function oe(t,r={}){let a=r.vrmUrl||new URL("./avatar.vrm",import.meta.url).href,s=new Q;s.register(e=>new H(e));let l=await s.loadAsync(a),o=l.userData.vrm;if(!o)throw new Error(`${a} is not a VRM file (no VRMC_vrm or VRM extension)`);(o.meta&&o.meta.metaVersion)==="0"&&p.rotateVRM0(o),p.removeUnnecessaryVertices(l.scene);let C=l.parser.json.asset&&l.parser.json.asset.extras||{},g=Number.isFinite(C.neck_share)?C.neck_share:X,c=o.humanoid,R=c.getNormalizedBoneNode("neck"),L=c.getNormalizedBoneNode("head"),f=c.getRawBoneNode("upperChest")||c.getRawBoneNode("chest")||c.getRawBoneNode("spine"),u=c.getRawBoneNode("head");if(!L||!u)throw new Error(`${a} has no head bone`);let i=new P;i.background=new D(14672872),i.add(new z(16777215,8028298,1.1)),i.add(new q(16777215,.2));let M=new y(16777215,2.6);M.position.set(-1,2.2,1.8),i.add(M);let _=new y(14542591,.6);_.position.set(1.2,1.4,1),i.add(_),i.add(o.scene),o.scene.updateMatrixWorld(!0);let j=new d,m=e=>e.getWorldQuaternion(new d).premultiply(o.scene.getWorldQuaternion(j).invert()),I=m(u),K=f?m(f):new d,w=u.getWorldPosition(new E),x=r.width||t.clientWidth||640,W=r.height||Math.round(x*.75),h=new U(22,x/W,.05,20);h.position.set(0,w.y+.06,w.z+1.3),h.lookAt(0,w.y-.03,w.z);let n=null;try{let e=Y();n=new F({antialias:r.antialias??!e}),n.outputColorSpace=V,n.setPixelRatio(r.pixelRatio||(e?.5:window.devicePixelRatio||1)),n.setSize(x,W),t.appendChild(n.domElement)}catch(e){n=null,t.textContent=`no WebGL: ${e&&e.message||e}`}let A=new d,B=new d;function b(e){$(e,g,A),$(e,R?1-g:1,B),R&&R.quaternion.copy(A),L.quaternion.copy(B),c.update(),o.scene.updateMatrixWorld(!0)}function T(){let e=m(u).multiply(I.clone().invert()),O=(f?m(f).multiply(K.clone().invert()):new d).invert().multiply(e),v=new k().setFromQuaternion(O,"YXZ");return[v.x*N,v.y*N,v.z*N]}let G=performance.now();function S(){let e=performance.now();o.update((e-G)/1e3),G=e,n&&n.render(i,h)}return b([0,0,0]),S(),{vrm:o,neckShare:g,scene:i,camera:h,setRotvec:b,headRotation:T,renderNow:S,canvas:n&&n.domElement,destroy(){n&&(n.dispose(),n.domElement.remove()),p.deepDispose(o.scene)}}}export{oe as createAvatar,oe as mountAvatar};
