// Bundle src.js (three.js + GLTFLoader) into three_gltf.js, a minified ES module.
// Run from src/headmotion/web/js (whose package.json pins three and esbuild) after `npm ci`:
//   node ../../../../tests/web_gltf/build.mjs
import { createRequire } from "node:module";

const { build } = createRequire(process.cwd() + "/")("esbuild");  // esbuild from the cwd's node_modules

await build({
  entryPoints: [new URL("./src.js", import.meta.url).pathname],
  outfile: new URL("./three_gltf.js", import.meta.url).pathname,
  bundle: true,
  format: "esm",
  minify: true,
  target: "es2020",
  legalComments: "eof",
  nodePaths: [process.cwd() + "/node_modules"],
  banner: { js: "// three.js (MIT licence, https://threejs.org) and its GLTFLoader, bundled by tests/web_gltf/build.mjs." },
});
console.log("wrote tests/web_gltf/three_gltf.js");
