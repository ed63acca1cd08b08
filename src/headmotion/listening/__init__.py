"""Subjective evaluation of head motion: listening tests in the browser and their analysis
(thesis §4.2, §5.5.1, §5.9; paper §4.4).

* :mod:`.config` — the YAML test configuration (MOS with reference, MUSHRA, A/B), validated with
  line numbers;
* :mod:`.plan` — per-participant seeded trial order, balanced A/B sides;
* :mod:`.db` — participants and answers (SQLite with WAL by default, PostgreSQL optional);
* :mod:`.app` — the FastAPI app (participant pages in ``static/``, admin API);
* :mod:`.analysis` — rescaling, exclusion, windowed differences, MOS tables, t-tests, MUSHRA box
  plots, A/B preference matrix.

Nothing heavy is imported here; import the submodules you need.
"""
