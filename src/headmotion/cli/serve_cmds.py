"""``headmotion serve``: head motion as a service (:mod:`headmotion.serve`; docs/serve.md).

* ``serve [--models DIR] [--host H] [--port P] [--workers N] [--api-keys FILE] [--allowed-host NAME]
  [--allowed-origin URL] [--max-streams N]`` — the HTTP/WebSocket server; without ``--api-keys`` on
  localhost only;
* ``serve hash-key [--name NAME] [--streams N] [--rate N] [--key-file FILE]`` — a new API key
  (shown once) and its line for the key file (the key itself is never stored).
"""

from __future__ import annotations

from pathlib import Path
from typing import List, Optional

import typer

from .app import app, console

serve_app = typer.Typer(help="Head motion as a service: HTTP and WebSocket API (docs/serve.md).",
                        invoke_without_command=True)
app.add_typer(serve_app, name="serve")


@serve_app.callback()
def serve(
    ctx: typer.Context,
    models: Optional[Path] = typer.Option(None, "--models", help="Folder of NAME.hmz models to offer besides "
                                          "the shipped 'default' and 'stream'."),
    host: str = typer.Option("127.0.0.1", "--host", help="Interface to listen on; anything but localhost "
                             "needs --api-keys."),
    port: int = typer.Option(8000, "--port", min=0, max=65535, help="TCP port."),
    workers: int = typer.Option(1, "--workers", min=1, max=64, help="Worker processes (each loads the models once)."),
    api_keys: Optional[Path] = typer.Option(None, "--api-keys", help="Key file: lines from "
                                            "`headmotion serve hash-key`."),
    allowed_host: Optional[List[str]] = typer.Option(None, "--allowed-host", help="Another Host name to "
                                                     "answer (the name clients use; repeatable)."),
    allowed_origin: Optional[List[str]] = typer.Option(None, "--allowed-origin", help="A web page origin "
                                                       "allowed to call the API, e.g. https://app.example.com."),
    max_streams: int = typer.Option(64, "--max-streams", min=1, max=100_000, help="Open streams per worker; "
                                    "more are refused with 'busy'. Set it to what the machine holds in real "
                                    "time (benchmarks/run.py --only serve measures it)."),
):
    """Serve head motion over HTTP (POST /v1/motion) and WebSocket (/v1/stream)."""
    if ctx.invoked_subcommand is not None:
        return
    from ..serve.config import Limits, ServeConfig
    from ..serve.runner import run

    config = ServeConfig(host=host, port=port, models_dir=None if models is None else str(models),
                         api_keys=None if api_keys is None else str(api_keys),
                         allowed_hosts=tuple(allowed_host or ()), allowed_origins=tuple(allowed_origin or ()),
                         limits=Limits(max_streams=max_streams))
    run(config, workers=workers, announce=lambda s: console.print(s, markup=False, highlight=False, soft_wrap=True))


@serve_app.command("hash-key")
def hash_key(
    name: str = typer.Option("client", "--name", help="The key's name in logs and metrics (one word)."),
    streams: int = typer.Option(8, "--streams", min=1, help="Concurrent streams allowed to the key."),
    rate: int = typer.Option(120, "--rate", min=1, help="Requests per minute (offline calls and stream openings)."),
    key_file: Optional[Path] = typer.Option(None, "--key-file", help="Append the line to this key file."),
):
    """Make a new API key: prints the key (shown once; give it to the client) and its key-file line."""
    from ..serve.auth import key_line, new_key

    key = new_key()
    line = key_line(key, name=name, streams=streams, rate=rate)
    console.print(f"key:  {key}", markup=False, highlight=False, soft_wrap=True)
    if key_file is None:
        console.print(f"line: {line}", markup=False, highlight=False, soft_wrap=True)
        return
    with open(key_file, "a", encoding="utf-8") as fh:
        fh.write(line + "\n")
    console.print(f"added to {key_file}: {line}", markup=False, highlight=False, soft_wrap=True)
