// Bundle src/viewer.js with three.js into ../static/viewer.js (minified ES module) and keep the
// API comment from the top of the source as the bundle's first lines.  Run: npm ci && npm run build
import { readFileSync } from "node:fs";
import { build } from "esbuild";

const src = readFileSync(new URL("./src/viewer.js", import.meta.url), "utf8");
const header = src.slice(0, src.indexOf("*/") + 2);
await build({
  entryPoints: [new URL("./src/viewer.js", import.meta.url).pathname],
  outfile: new URL("../static/viewer.js", import.meta.url).pathname,
  bundle: true,
  format: "esm",
  minify: true,
  target: "es2020",
  legalComments: "eof",
  banner: { js: `${header}\n// three.js (MIT licence, https://threejs.org) is bundled below; built by web/js/build.mjs.` },
});
console.log("wrote ../static/viewer.js");
