// Bundle the browser components with their npm dependencies into ../static/ (minified ES modules),
// keeping the API comment from the top of each source as the bundle's first lines:
//   src/viewer.js → ../static/viewer.js   (three.js)
//   src/avatar.js → ../static/avatar.js   (three.js, its GLTFLoader, @pixiv/three-vrm)
// Run: npm ci && npm run build
import { readFileSync } from "node:fs";
import { build } from "esbuild";

const BUNDLES = [
  ["viewer.js", "three.js (MIT licence, https://threejs.org) is"],
  ["avatar.js", "three.js (MIT licence, https://threejs.org) and @pixiv/three-vrm (MIT licence, https://github.com/pixiv/three-vrm) are"],
];
for (const [name, what] of BUNDLES) {
  const src = readFileSync(new URL(`./src/${name}`, import.meta.url), "utf8");
  const header = src.slice(0, src.indexOf("*/") + 2);
  await build({
    entryPoints: [new URL(`./src/${name}`, import.meta.url).pathname],
    outfile: new URL(`../static/${name}`, import.meta.url).pathname,
    bundle: true,
    format: "esm",
    minify: true,
    target: "es2020",
    legalComments: "eof",
    banner: { js: `${header}\n// ${what} bundled below; built by web/js/build.mjs.` },
  });
  console.log(`wrote ../static/${name}`);
}
