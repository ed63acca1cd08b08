"""The HTML pages of the apps: the viewer's (``headmotion view``), the live view's (``view --live``)
and the avatar's (``/v1/avatar``).

Every page has the same head — its title, the shared stylesheet ``page.css`` and the page's own —
written here once; a page's body is a file of ``web/static``, ``NAME.body.html``.  The pages link
their styles and scripts as files, so they run under ``headmotion serve``'s Content-Security-Policy
(no inline style).  Here rather than in :mod:`headmotion.web`, because the service serves the
avatar page and the live view imports the service's routes.
"""

from __future__ import annotations

from functools import lru_cache
from html import escape
from pathlib import Path

#: the web components' files (the viewer's and the avatar's bundles, the VRM, the pages' bodies and styles)
WEB_STATIC = Path(__file__).resolve().parents[1] / "web" / "static"

_HEAD = """<!doctype html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{title}</title>
<link rel="icon" href="data:,">
{links}</head>
"""


@lru_cache(maxsize=None)
def page_html(name: str, title: str, *, static: str, stylesheets: tuple[str, ...] = ()) -> str:
    """The page whose body is ``web/static/NAME.body.html``, titled ``headmotion TITLE``, linking
    ``page.css`` and ``stylesheets`` under the URL prefix ``static`` (where ``web/static`` is mounted);
    made once per page and process (its body is a file of the package), not on every request."""
    links = "".join(f'<link rel="stylesheet" href="{escape(static)}/{escape(s)}">\n'
                    for s in ("page.css", *stylesheets))
    body = (WEB_STATIC / f"{name}.body.html").read_text(encoding="utf-8")
    return _HEAD.format(title=escape(f"headmotion {title}"), links=links) + body + "</html>\n"


def page_response(name: str, title: str, *, static: str, stylesheets: tuple[str, ...] = ()):
    """:func:`page_html` as a FastAPI response."""
    from fastapi.responses import HTMLResponse

    return HTMLResponse(page_html(name, title, static=static, stylesheets=stylesheets))


#: @headmotion/client, which the avatar pages stream with
CLIENT = Path(__file__).resolve().parent / "static" / "client"


def mount_page(app, name: str, title: str, *, stylesheets: tuple[str, ...] = ()) -> str:
    """Add the page ``/v1/NAME`` (:func:`page_response`) to the FastAPI ``app``, with ``web/static`` at
    ``/v1/NAME/static`` and @headmotion/client at ``/v1/NAME/client``; returns the static files' URL."""
    from fastapi.staticfiles import StaticFiles

    static = f"/v1/{name}/static"

    def page():
        return page_response(name, title, static=static, stylesheets=stylesheets)

    app.add_api_route(f"/v1/{name}", page, methods=["GET"], include_in_schema=False, name=f"{name}_page")
    app.mount(static, StaticFiles(directory=WEB_STATIC), name=f"{name}-static")
    app.mount(f"/v1/{name}/client", StaticFiles(directory=CLIENT), name=f"{name}-client")
    return static


__all__ = ["WEB_STATIC", "CLIENT", "page_html", "page_response", "mount_page"]
