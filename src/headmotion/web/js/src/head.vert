// The head's vertex shader (three.js ShaderMaterial): the neck skinned by scaling the rotation.
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
}