// The head's fragment shader: the textured, smooth and silhouette styles of headmotion.render.offscreen.
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
}