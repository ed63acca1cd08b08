// Bundle the browser components with their npm dependencies into ../static/ (minified ES modules),
// keeping the API comment from the top of each source as the bundle's first lines:
//   src/viewer.js → ../static/viewer.js   (the head viewer; its shaders src/head.vert, src/head.frag)
//   src/avatar.js → ../static/avatar.js   (the VRM avatar)
// The third-party code goes into ../static/vendor/ as chunks they import: three.js's core once for all
// (a page that shows the viewer and the avatar loads it once), @pixiv/three-vrm and the GLTFLoader apart,
// and TalkingHead (@met4citizen/talkinghead) as vendor/talkinghead.js, which the TalkingHead page
// imports, with the two files it loads beside itself at run time: vendor/playback-worklet.js and
// vendor/lipsync-en.mjs (TalkingHead's source has no licence comment that esbuild keeps: its MIT
// licence is written at the top of the three).
// Run: npm ci && npm run build
import { readFileSync, rmSync, writeFileSync, mkdirSync } from "node:fs";
import { basename, dirname, join } from "node:path";
import { build } from "esbuild";

const here = (p) => new URL(p, import.meta.url).pathname;
const NOTICE = {
  "viewer.js": "three.js (MIT licence, https://threejs.org) is",
  "avatar.js": "three.js (MIT licence, https://threejs.org) and @pixiv/three-vrm (MIT licence, https://github.com/pixiv/three-vrm) are",
};
const TALKINGHEAD = here("./node_modules/@met4citizen/talkinghead/");
const TH_LICENCE = `/*! TalkingHead (@met4citizen/talkinghead ${JSON.parse(readFileSync(TALKINGHEAD + "package.json", "utf8")).version}), ` +
  `https://github.com/met4citizen/TalkingHead\n${readFileSync(TALKINGHEAD + "LICENSE", "utf8").trim()}\n*/\n`;
const TH_FILES = { "talkinghead.js": true, "playback-worklet.js": true, "lipsync-en.js": true };
const outdir = here("../static");
rmSync(join(outdir, "vendor"), { recursive: true, force: true });
const result = await build({
  entryPoints: {
    viewer: here("./src/viewer.js"),
    avatar: here("./src/avatar.js"),
    "vendor/vrm": here("./src/vrm-vendor.js"),   // puts the VRM loader's code in vendor/ too
    "vendor/talkinghead": here("./src/talkinghead-vendor.js"),
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
const alone = await build({  // loaded by TalkingHead at run time, each a file of its own (no chunk)
  entryPoints: {
    "vendor/playback-worklet": TALKINGHEAD + "modules/playback-worklet.js",
    "vendor/lipsync-en": TALKINGHEAD + "modules/lipsync-en.mjs",
  },
  outdir, bundle: true, format: "esm", minify: true, target: "es2022", legalComments: "eof", write: false,
});
for (const file of [...result.outputFiles, ...alone.outputFiles]) {
  const name = basename(file.path);
  let text = file.text, path = file.path;
  if (TH_FILES[name]) {
    text = `${TH_LICENCE}// built by web/js/build.mjs.\n${text}`;
    if (name === "lipsync-en.js") path = path.replace(/\.js$/, ".mjs");  // the name TalkingHead imports
  } else if (NOTICE[name]) {
    const src = readFileSync(here(`./src/${name}`), "utf8");
    const header = src.slice(0, src.indexOf("*/") + 2);
    text = `${header}\n// ${NOTICE[name]} bundled in ./vendor/; built by web/js/build.mjs.\n${text}`;
  } else {
    text = `// Third-party code (licences at the end), imported by the pages' modules; built by web/js/build.mjs.\n${text}`;
  }
  mkdirSync(dirname(path), { recursive: true });
  writeFileSync(path, text);
  console.log(`wrote ${path.slice(outdir.length - "static".length)} (${(text.length / 1024).toFixed(0)} KiB)`);
}
