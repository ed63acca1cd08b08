"""run_map (headmotion.parallel): results in order on every backend; on a cluster, the large
arrays several items hold travel once and are shared."""

from __future__ import annotations

import numpy as np
import pytest

from headmotion import parallel as P


def _total(item):
    arrays, scale = item
    return float(sum(a.sum() for a in arrays)) * scale


def _apply(item):
    f, a = item
    return f(a)


def test_items_are_pickled_without_their_large_arrays_and_each_array_is_kept_once():
    big = np.arange(200_000, dtype=np.float64)  # 1.6 MB
    other = np.ones(50_000)  # 400 kB
    small = np.arange(10.0)  # under SHARED_BYTES: stays inside the item
    items = [([big, small], 1.0), ([big, other], 2.0), ([other], 3.0)]
    blobs, keys, arrays = P._by_reference(items)
    assert len(arrays) == 2  # big and other, each once
    assert [len(k) for k in keys] == [1, 2, 1]
    assert keys[0][0] in keys[1] and keys[2][0] in keys[1]
    assert max(len(b) for b in blobs) < 2_000  # the 2 MB are not in any item
    for blob, ks, item in zip(blobs, keys, items):
        mine = {k: arrays[k] for k in ks}
        assert P._call_by_reference(blob, fn=_total, arrays=mine) == _total(item)


def test_an_item_read_back_without_its_array_is_refused():
    import pickle

    big = np.zeros(100_000)
    blobs, keys, arrays = P._by_reference([([big], 1.0)])
    with pytest.raises(pickle.UnpicklingError, match="unknown array reference"):
        P._call_by_reference(blobs[0], fn=_total, arrays={})


def test_items_holding_lambdas_travel_by_reference_too():
    big = np.full(100_000, 2.0)
    blobs, keys, arrays = P._by_reference([(lambda a: float(a.mean()) + 1, big)])
    assert len(arrays) == 1
    assert P._call_by_reference(blobs[0], fn=_apply, arrays=arrays) == 3.0


@pytest.mark.parametrize("backend", ["serial", "joblib", "dask"])
def test_run_map_gives_every_result_in_order_on_every_backend(backend):
    big = np.arange(300_000, dtype=np.float64)
    items = [([big, np.full(20_000, float(k))], float(k)) for k in range(5)]
    expected = [_total(it) for it in items]
    if backend == "dask":
        distributed = pytest.importorskip("distributed")
        with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                      dashboard_address=None) as cluster:
            seen = []
            out = P.run_map(_total, items, scheduler=cluster.scheduler_address,
                            progress=lambda d, t, _desc: seen.append((d, t)))
        assert sorted(seen) == [(d, 5) for d in range(1, 6)]
    else:
        out = P.run_map(_total, items, n_jobs=2 if backend == "joblib" else 1)
    assert out == expected
