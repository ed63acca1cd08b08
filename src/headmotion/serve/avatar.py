"""The avatar page, ``GET /v1/avatar``: a VRM avatar whose neck and head bones follow ``/v1/stream``.

:func:`mount_avatar` adds the page and its files to a FastAPI app — ``headmotion serve``'s, and any
app that also answers ``/v1/stream`` (``view --live``, or an agent's own server):

* ``/v1/avatar``          — the page (:mod:`.pages`: body ``web/static/avatar.body.html``, script
  ``avatar-page.js``, styles ``page.css`` and ``avatar.css``);
* ``/v1/avatar/static/``  — ``web/static``: ``avatar.js`` (three.js, its GLTFLoader and
  @pixiv/three-vrm bundled into ``vendor/`` by ``web/js/build.mjs``), ``avatar.vrm`` (the project's VRM 1.0 bust,
  written by ``python -m headmotion.web.build_assets``), the page's script and style;
* ``/v1/avatar/client/``  — ``@headmotion/client`` (``serve/static/client``), which the page
  streams with.

Everything is a file of the package: nothing is fetched from a CDN, and the page runs under
``headmotion serve``'s Content-Security-Policy (no inline script or style).
"""

from __future__ import annotations

from .pages import CLIENT, WEB_STATIC, mount_page

#: where ``web/static`` is mounted
STATIC_URL = "/v1/avatar/static"


def mount_avatar(app) -> None:
    """Add ``/v1/avatar`` and its static files to the FastAPI ``app`` (module docstring)."""
    mount_page(app, "avatar", "avatar", stylesheets=("avatar.css",))


__all__ = ["mount_avatar", "WEB_STATIC", "CLIENT", "STATIC_URL"]
