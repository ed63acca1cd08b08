"""``headmotion listen serve CONFIG`` and ``headmotion listen analyze RESULTS -o REPORT_DIR``
(thesis §4.2, §5.5.1, §5.9; paper §4.4).  Thin: parses, calls :mod:`headmotion.listening`."""

from __future__ import annotations

import os
from pathlib import Path
from typing import List, Optional

import typer

from .app import console, listen_app, print_warning


@listen_app.command("serve")
def serve(
    config: Path = typer.Argument(..., help="The test's YAML configuration."),
    host: str = typer.Option("127.0.0.1", help="Interface to listen on (0.0.0.0 for all)."),
    port: int = typer.Option(8000, help="TCP port."),
    database: Optional[str] = typer.Option(
        None, help="sqlite:///FILE (default: results/<name>.sqlite beside the config) or "
                   "postgresql://user:pw@host/db."),
    admin_token: Optional[str] = typer.Option(
        None, help="Token for the admin page/API (default: config, $HEADMOTION_ADMIN_TOKEN, "
                   "else random and printed)."),
    allowed_host: Optional[List[str]] = typer.Option(
        None, "--allowed-host",
        help="A host name participants use to reach the server (repeatable); requests naming any "
             "other host are refused (DNS-rebinding protection). localhost and --host are always "
             "allowed."),
    workers: int = typer.Option(1, min=1, max=64, help="Server processes (SQLite: WAL + busy "
                                                        "timeout; PostgreSQL: row locks); more than "
                                                        "one per CPU core does not help."),
    sync: str = typer.Option("full", help="SQLite commits: 'full' (each commit fsynced before its answers "
                                          "are acknowledged, answers arriving together sharing one; survives "
                                          "a power cut) or 'normal' (not fsynced; survives a killed server, "
                                          "not a power cut)."),
) -> None:
    """Run a listening test (MOS with reference, MUSHRA or A/B) in the browser."""
    import secrets

    import uvicorn
    from rich.markup import escape

    from ..listening.app import create_app
    from ..listening.config import load_config

    from ..errors import ParameterError

    if sync not in ("full", "normal"):
        raise ParameterError(f"--sync must be 'full' or 'normal'; got {sync!r}")
    cfg = load_config(config)
    token = admin_token or cfg.admin_token or os.environ.get("HEADMOTION_ADMIN_TOKEN") or secrets.token_urlsafe(16)
    # one app in this process: checks the configuration, creates the database and its secret
    # before any worker starts (so that workers never race to create them)
    app = create_app(cfg, database_url=database, admin_token=token, allowed_hosts=allowed_host,
                     served_host=host, durable=sync == "full")
    shown = "localhost" if host in ("0.0.0.0", "::") else host
    console.print(f"[bold]{escape(cfg.title)}[/] ({cfg.type}, {cfg.n_trials} trials per participant)")
    console.print(f"participants: http://{escape(shown)}:{port}/", highlight=False)
    console.print(f"admin:        http://{escape(shown)}:{port}/admin?token={escape(token)}  (opens once; the "
                  f"browser then keeps a session cookie)", highlight=False)
    console.print(f"database:     {escape(app.state.database_url)}", highlight=False)
    console.print(f"hosts:        {escape(', '.join(sorted(app.state.allowed_hosts)))}", highlight=False)
    # participants sit on a trial for a while: keep idle connections open longer than the
    # default 5 s so that a browser's reused connection is not closed under it
    common = dict(host=host, port=port, log_level="warning", timeout_keep_alive=75)
    if workers == 1:
        uvicorn.run(app, **common)
        return
    app.state.db.close()
    os.environ.update({
        "HEADMOTION_LISTEN_CONFIG": str(Path(config).resolve()),
        "HEADMOTION_LISTEN_DATABASE": app.state.database_url,
        "HEADMOTION_ADMIN_TOKEN": token,
        "HEADMOTION_LISTEN_ALLOWED_HOSTS": ",".join(allowed_host or ()),
        "HEADMOTION_LISTEN_HOST": host,
        "HEADMOTION_LISTEN_SYNC": sync,
    })
    uvicorn.run("headmotion.listening.app:app_from_env", factory=True, workers=workers, **common)


@listen_app.command("analyze")
def analyze(
    results: Path = typer.Argument(..., help="results.json / results.csv from the admin page, or "
                                             "the test's .sqlite file."),
    output: Path = typer.Option(..., "-o", "--output", help="Report folder (created)."),
    window: int = typer.Option(10, help="Window (trials) for score differences (thesis Fig 4.5)."),
    reference: Optional[str] = typer.Option(
        None, help="Condition compared in the windowed difference (default: best-rated)."),
    compare: Optional[str] = typer.Option(
        None, help="Condition it is compared with (default: second best-rated)."),
    include_training: bool = typer.Option(False, help="Also analyse training answers."),
) -> None:
    """Analyse a listening test: MOS tables, t-tests, MUSHRA box plots, A/B matrix."""
    from ..listening.analysis import analyze as run

    report = run(results, output, window=window, reference=reference, compare=compare,
                 include_training=include_training)
    console.print(f"report: {report}")
    for w in getattr(run, "last_warnings", []):
        print_warning(w)
