// Bundle the browser components with their npm dependencies into ../static/ (minified ES modules),
// keeping the API comment from the top of each source as the bundle's first lines:
//   src/viewer.js → ../static/viewer.js   (the head viewer; its shaders src/head.vert, src/head.frag)
//   src/avatar.js → ../static/avatar.js   (the VRM avatar)
// The third-party code goes into ../static/vendor/ as chunks they import: three.js's core once for both
// (a page that shows the viewer and the avatar loads it once), @pixiv/three-vrm and the GLTFLoader apart.
// Run: npm ci && npm run build
import { readFileSync, rmSync, writeFileSync, mkdirSync } from "node:fs";
import { basename, dirname, join } from "node:path";
import { build } from "esbuild";

const here = (p) => new URL(p, import.meta.url).pathname;
const NOTICE = {
  "viewer.js": "three.js (MIT licence, https://threejs.org) is",
  "avatar.js": "three.js (MIT licence, https://threejs.org) and @pixiv/three-vrm (MIT licence, https://github.com/pixiv/three-vrm) are",
};
const outdir = here("../static");
rmSync(join(outdir, "vendor"), { recursive: true, force: true });
const result = await build({
  entryPoints: {
    viewer: here("./src/viewer.js"),
    avatar: here("./src/avatar.js"),
    "vendor/vrm": here("./src/vrm-vendor.js"),   // puts the VRM loader's code in vendor/ too
  },
  outdir,
  bundle: true,
  splitting: true,
  chunkNames: "vendor/[name]-[hash]",
  format: "esm",
  minify: true,
  target: "es2020",
  legalComments: "eof",
  loader: { ".vert": "text", ".frag": "text" },
  metafile: true,
  write: false,
});
for (const file of result.outputFiles) {
  const name = basename(file.path);
  let text = file.text;
  if (NOTICE[name]) {
    const src = readFileSync(here(`./src/${name}`), "utf8");
    const header = src.slice(0, src.indexOf("*/") + 2);
    text = `${header}\n// ${NOTICE[name]} bundled in ./vendor/; built by web/js/build.mjs.\n${text}`;
  } else {
    text = `// Third-party code (licences at the end), imported by viewer.js and avatar.js; built by web/js/build.mjs.\n${text}`;
  }
  mkdirSync(dirname(file.path), { recursive: true });
  writeFileSync(file.path, text);
  console.log(`wrote ${file.path.slice(outdir.length - "static".length)} (${(text.length / 1024).toFixed(0)} KiB)`);
}
