"""One BLAS thread in live processes (headmotion.live.blas)."""

from threadpoolctl import ThreadpoolController, threadpool_info

from headmotion.live.blas import one_blas_thread


def _blas_threads():
    return [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]


def test_one_blas_thread_limits_blas_and_keeps_a_users_choice():
    ctl = ThreadpoolController()
    with ctl.limit(limits=2, user_api="blas"):  # restored on exit, whatever the call sets
        assert one_blas_thread(environ={"OPENBLAS_NUM_THREADS": "2"}) is False
        assert set(_blas_threads()) <= {2}
        assert one_blas_thread(environ={}) is True
        assert set(_blas_threads()) <= {1}
