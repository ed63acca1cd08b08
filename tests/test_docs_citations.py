"""The documents cite only what the tree holds: every report folder, figure and script path named
in the README, ``docs/`` and the model cards exists, and ``docs/`` stays under 20 MB."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md")),
        *sorted((ROOT / "src" / "headmotion" / "data").glob("*.md"))]
DOCS = [p for p in DOCS if "eval" not in p.relative_to(ROOT).parts[:2]]  # reports cite their own figures
# a path in the tree; not ``git show COMMIT:scripts/x.py`` (history) or a placeholder (``docs/decisions/TOPIC.md``)
PATH = re.compile(r"(?<![\w/.:])((?:docs/(?:eval|figures|decisions)|scripts)/[\w./-]*\w)")
PLACEHOLDER = re.compile(r"/[A-Z]+\.\w+$")


def cited_paths() -> list[tuple[Path, str]]:
    out = []
    for doc in DOCS:
        for m in PATH.finditer(doc.read_text(encoding="utf-8")):
            if not PLACEHOLDER.search(m.group(1)):
                out.append((doc, m.group(1)))
    return out


def test_documents_cite_existing_paths():
    cites = cited_paths()
    assert len(cites) > 20  # the results page, the decisions and the cards cite reports and figures
    missing = sorted({f"{doc.relative_to(ROOT)}: {p}" for doc, p in cites if not (ROOT / p).exists()})
    assert not missing, "cited but not in the tree:\n" + "\n".join(missing)


def test_kept_reports_are_cited():
    text = "\n".join(d.read_text(encoding="utf-8") for d in DOCS)
    reports = sorted(p.name for p in (ROOT / "docs" / "eval").iterdir() if p.is_dir())
    assert reports, "docs/eval holds the reports docs/results.md cites"
    assert [r for r in reports if f"docs/eval/{r}" not in text and f"eval/{r}" not in text] == []


def test_docs_under_20_mb():
    size = sum(p.stat().st_size for p in (ROOT / "docs").rglob("*") if p.is_file())
    assert size < 20 * 1024 * 1024, f"docs/ holds {size / 2**20:.1f} MB"


def test_relative_links_resolve():
    link = re.compile(r"\]\(([^)#\s]+)(?:#[^)]*)?\)")
    bad = []
    for doc in DOCS:
        for m in link.finditer(doc.read_text(encoding="utf-8")):
            target = m.group(1)
            if "://" not in target and not (doc.parent / target).exists():
                bad.append(f"{doc.relative_to(ROOT)}: {target}")
    assert not bad, "broken links:\n" + "\n".join(bad)
