"""The browser viewer: a three.js head that plays speech and head motion in sync.

* ``static/viewer.js`` — the viewer component, an ES module exporting ``mountViewer(element,
  {motions, audioUrl, ...})`` (API documented at the top of ``js/src/viewer.js``; its shaders in
  ``js/src/head.vert`` and ``head.frag``); three.js from the npm registry is bundled at build time
  into ``static/vendor/`` (one copy for the viewer and the avatar), so nothing is fetched from a
  CDN at run time.
* ``static/head_mesh.bin`` — the project's head model (:mod:`headmotion.render.mesh`, detail 0);
  ``static/avatar.vrm`` and ``static/talkinghead.glb`` — the avatars of ``/v1/avatar`` and
  ``/v1/talkinghead`` (:mod:`headmotion.web.build_assets`).
* ``static/vendor/talkinghead.js`` — TalkingHead (``@met4citizen/talkinghead``) bundled the same way,
  with ``playback-worklet.js`` and ``lipsync-en.mjs``, which it loads beside itself.
* ``static/index.body.html``, ``static/live.body.html``, ``static/avatar.body.html``,
  ``static/talkinghead.body.html`` and ``page.css`` — the bodies and the shared style of the pages
  ``headmotion view``, ``view --live``, ``/v1/avatar`` and ``/v1/talkinghead`` serve
  (:mod:`headmotion.serve.pages` writes their one head).

The listening-test app mounts ``static/`` under ``/viewer`` and imports ``/viewer/viewer.js``.

Rebuilding the static files (only needed after editing ``js/src/viewer.js`` or the mesh)::

    cd src/headmotion/web/js && npm ci && npm run build      # → static/viewer.js, avatar.js, vendor/ (minified)
    python -m headmotion.web.build_assets                     # → static/head_mesh.bin, avatar.vrm, talkinghead.glb
"""

from __future__ import annotations

from pathlib import Path

STATIC_DIR = Path(__file__).resolve().parent / "static"

__all__ = ["STATIC_DIR"]
