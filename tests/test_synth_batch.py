"""``headmotion synth IN... -o DIR`` and :func:`headmotion.batch.synthesize_batch`: the outputs are
the files single runs write (byte for byte), names mirror the inputs, a second run skips what is up
to date, a damaged input is reported while the others are written."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest

from headmotion.batch import synthesize_batch
from headmotion.batch.manifest import MANIFEST_NAME
from headmotion.cli import main
from headmotion.errors import ParameterError

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "speech"


@pytest.fixture
def voices(tmp_path) -> Path:
    """A library of real speech in sub-folders: en/a.wav, en/b.wav, fr/deep/c.wav, plus a note."""
    lib = tmp_path / "voices"
    for rel, src in (("en/a.wav", "short.wav"), ("en/b.wav", "speech_female.wav"), ("fr/deep/c.wav", "speech_male.wav")):
        (lib / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(EXAMPLES / src, lib / rel)
    (lib / "en" / "notes.txt").write_text("not speech")
    return lib


def _bytes(path: Path) -> bytes:
    return path.read_bytes()


def _files(folder: Path) -> list[str]:
    return sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file())


@pytest.mark.parametrize("fmt", ["npz", "bvh"])
def test_outputs_equal_single_runs_and_names_mirror_the_folders(voices, tmp_path, fmt):
    out = tmp_path / "out"
    assert main(["synth", str(voices), "-o", str(out), "--format", fmt, "--seed", "3", "--amount", "1.5"]) == 0
    assert _files(out) == sorted([MANIFEST_NAME, f"en/a.{fmt}", f"en/b.{fmt}", f"fr/deep/c.{fmt}"])
    for rel in ("en/a", "en/b", "fr/deep/c"):
        single = tmp_path / f"single.{fmt}"
        assert main(["synth", str(voices / f"{rel}.wav"), "-o", str(single), "--seed", "3", "--amount", "1.5"]) == 0
        assert _bytes(out / f"{rel}.{fmt}") == _bytes(single), rel


def test_samples_and_neck_share_as_single_runs(voices, tmp_path):
    out = tmp_path / "out"
    a = voices / "en" / "a.wav"
    assert main(["synth", str(a), "-o", str(out), "--format", "bvh", "--samples", "2", "--neck-share", "0.5"]) == 0
    assert main(["synth", str(a), "-o", str(tmp_path / "s.bvh"), "--samples", "2", "--neck-share", "0.5"]) == 0
    for k in (1, 2):
        assert _bytes(out / f"a_{k}.bvh") == _bytes(tmp_path / f"s_{k}.bvh")
    assert _bytes(out / "a_1.bvh") != _bytes(out / "a_2.bvh")


def test_two_jobs_write_the_same_files(voices, tmp_path):
    one = synthesize_batch([voices], tmp_path / "one", format="npz", jobs=1)
    two = synthesize_batch([voices], tmp_path / "two", format="npz", jobs=2)
    assert len(one.written) == len(two.written) == 3 and one.exit_code == two.exit_code == 0
    for rel in ("en/a.npz", "en/b.npz", "fr/deep/c.npz"):
        assert _bytes(tmp_path / "one" / rel) == _bytes(tmp_path / "two" / rel)


@pytest.mark.slow
def test_dask_cluster_writes_the_same_files(voices, tmp_path):
    distributed = pytest.importorskip("distributed", reason="dask.distributed is not installed (headmotion[dask])")
    local = synthesize_batch([voices], tmp_path / "local", format="json", seed=2)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=None) as cluster:
        remote = synthesize_batch([voices], tmp_path / "dask", format="json", seed=2, scheduler=cluster.scheduler_address)
    assert len(local.written) == len(remote.written) == 3 and remote.exit_code == 0
    for rel in ("en/a.json", "en/b.json", "fr/deep/c.json"):
        assert _bytes(tmp_path / "local" / rel) == _bytes(tmp_path / "dask" / rel)


def test_second_run_skips_what_is_up_to_date(voices, tmp_path):
    out = tmp_path / "out"
    first = synthesize_batch([voices], out, format="npz")
    assert len(first.written) == 3
    stamps = {p: p.stat().st_mtime_ns for p in out.rglob("*.npz")}
    again = synthesize_batch([voices], out, format="npz")
    assert again.written == [] and len(again.skipped) == 3
    assert {p: p.stat().st_mtime_ns for p in out.rglob("*.npz")} == stamps
    # touched but the same bytes: still up to date; new bytes: made again
    a, b = voices / "en" / "a.wav", voices / "en" / "b.wav"
    os.utime(a, ns=(a.stat().st_atime_ns, a.stat().st_mtime_ns + 5_000_000_000))
    shutil.copy(EXAMPLES / "speech_male.wav", b)
    res = synthesize_batch([voices], out, format="npz")
    assert res.written == [b] and sorted(res.skipped) == sorted([a, voices / "fr" / "deep" / "c.wav"])
    # an output removed, another option, or --force: made again
    (out / "en" / "a.npz").unlink()
    assert synthesize_batch([voices], out, format="npz").written == [a]
    assert len(synthesize_batch([voices], out, format="npz", seed=5).written) == 3
    assert len(synthesize_batch([voices], out, format="npz", seed=5, force=True).written) == 3
    lines = (out / MANIFEST_NAME).read_text().splitlines()
    synthesize_batch([voices], out, format="npz", seed=5)  # the superseded lines are dropped on start
    assert len((out / MANIFEST_NAME).read_text().splitlines()) == 3 < len(lines)


def test_damaged_input_is_one_line_and_the_others_are_written(voices, tmp_path, capsys):
    bad = voices / "en" / "broken.wav"
    bad.write_bytes(b"RIFF....WAVEfmt garbage")
    out = tmp_path / "out"
    assert main(["synth", str(voices), str(tmp_path / "missing.wav"), "-o", str(out), "--jobs", "2"]) == 1
    err = capsys.readouterr()
    errors = [line for line in err.err.splitlines() if line.startswith("error:")]
    assert len(errors) == 2 and any(str(bad) in e for e in errors) and any("missing.wav" in e for e in errors)
    assert "wrote 3, up to date 0, failed 2 of 5 inputs" in err.out.replace("\n", " ")
    assert _files(out) == sorted([MANIFEST_NAME, "en/a.bvh", "en/b.bvh", "fr/deep/c.bvh"])
    assert not list(out.rglob("*.part*"))
    # the failed ones are tried again, the written ones skipped
    res = synthesize_batch([voices], out)
    assert len(res.skipped) == 3 and [s for s, _ in res.failed] == [bad] and res.exit_code == 1


def test_list_file_entries_are_read_from_its_folder(voices, tmp_path):
    lst = voices / "lines.txt"
    lst.write_text("# the English lines\nen/a.wav\n\nfr\n" + str(EXAMPLES / "short.wav") + "\n")
    out = tmp_path / "out"
    assert main(["synth", f"@{lst}", "-o", str(out), "--format", "json"]) == 0
    assert _files(out) == sorted([MANIFEST_NAME, "en/a.json", "deep/c.json", "short.json"])


def test_refusals_before_anything_is_written(voices, tmp_path, capsys):
    out = tmp_path / "out"
    # two inputs, one output name
    assert main(["synth", str(voices / "en" / "a.wav"), str(EXAMPLES / "short.wav"), str(voices / "en"),
                 "-o", str(out)]) == 2
    assert "would both be written to" in capsys.readouterr().err
    assert main(["synth", str(voices), "-o", str(out), "--format", "mp4"]) == 2
    assert main(["synth", str(voices), "-o", str(out), "--format", "csv", "--neck-share", "0.5"]) == 2
    assert main(["synth", str(voices), "-o", str(out), "--jobs", "0"]) == 2
    assert main(["synth", f"@{tmp_path / 'nolist.txt'}", "-o", str(out)]) == 2
    assert main(["synth", str(tmp_path / "missing.wav"), "-o", str(out)]) == 1  # one input, reported, exit 1
    empty = tmp_path / "empty"
    empty.mkdir()
    assert main(["synth", str(empty), "-o", str(out)]) == 2
    assert not out.exists()
    from headmotion import Controls

    with pytest.raises(ParameterError, match="give the controls"):
        synthesize_batch([voices], out, controls=Controls(), gain=1.0)
