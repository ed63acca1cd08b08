"""``headmotion listen serve CONFIG`` and ``headmotion listen analyze RESULTS -o REPORT_DIR``
(thesis §4.2, §5.5.1, §5.9; paper §4.4).  Thin: parses, calls :mod:`headmotion.listening`."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from .app import console, err_console, listen_app


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
) -> None:
    """Run a listening test (MOS with reference, MUSHRA or A/B) in the browser."""
    import uvicorn

    from ..listening.app import create_app
    from ..listening.config import load_config

    cfg = load_config(config)
    app = create_app(cfg, database_url=database, admin_token=admin_token)
    shown = "localhost" if host in ("0.0.0.0", "::") else host
    console.print(f"[bold]{cfg.title}[/] ({cfg.type}, {cfg.n_trials} trials per participant)")
    console.print(f"participants: http://{shown}:{port}/")
    console.print(f"admin:        http://{shown}:{port}/admin?token={app.state.admin_token}")
    console.print(f"database:     {app.state.database_url}", highlight=False)
    # participants sit on a trial for a while: keep idle connections open longer than the
    # default 5 s so that a browser's reused connection is not closed under it
    uvicorn.run(app, host=host, port=port, log_level="warning", timeout_keep_alive=75)


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
        err_console.print(f"[yellow]warning:[/] {w}")
