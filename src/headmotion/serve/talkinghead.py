"""The TalkingHead page, ``GET /v1/talkinghead``: a TalkingHead avatar (``@met4citizen/talkinghead``)
whose neck and head follow ``/v1/stream``.

:func:`mount_talkinghead` adds the page and its files to a FastAPI app — ``headmotion serve``'s, or
any app that also answers ``/v1/stream``:

* ``/v1/talkinghead``          — the page (:mod:`.pages`: body ``web/static/talkinghead.body.html``,
  script ``talkinghead-page.js``, styles ``page.css`` and ``talkinghead.css``);
* ``/v1/talkinghead/static/``  — ``web/static``: ``vendor/talkinghead.js`` (TalkingHead and the parts
  of three.js it uses, bundled by ``web/js/build.mjs``, with the worklet and the lip-sync module it
  loads beside it), ``talkinghead.glb`` (the project's full-body avatar with the Ready Player Me
  skeleton and blendshapes, written by ``python -m headmotion.web.build_assets``), the page's
  script and style;
* ``/v1/talkinghead/client/``  — ``@headmotion/client`` (``serve/static/client``), whose
  ``talkinghead.js`` drives the avatar.

Everything is a file of the package: nothing is fetched from a CDN, and the page runs under
``headmotion serve``'s Content-Security-Policy (no inline script or style).
"""

from __future__ import annotations

from .pages import mount_page

#: where ``web/static`` is mounted
STATIC_URL = "/v1/talkinghead/static"


def mount_talkinghead(app) -> None:
    """Add ``/v1/talkinghead`` and its static files to the FastAPI ``app`` (module docstring)."""
    mount_page(app, "talkinghead", "TalkingHead", stylesheets=("talkinghead.css",))


__all__ = ["mount_talkinghead", "STATIC_URL"]
