"""Small dense work on one BLAS thread (issue 19 item 3): inside a solve and in study workers."""

import flexmb
from flexmb.linear import single_threaded
from threadpoolctl import threadpool_info


def _blas_threads() -> dict:
    return {"threads": max([p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"] or [1])}


def test_a_solve_runs_its_linear_algebra_on_one_thread(monkeypatch):
    seen = []
    import flexmb.solvers.conventional as conventional

    real = conventional.is_stable

    def spy(K):  # called inside the solve, after the last Newton iteration
        seen.append(_blas_threads()["threads"])
        return real(K)

    monkeypatch.setattr(conventional, "is_stable", spy)
    assert flexmb.solve(flexmb.models.cross_flexure_pivot(1, dim=2, rotation=0.2)).converged
    assert seen == [1, 1]  # the solve and its companion mesh's (flexmb.accuracy's estimate)
    with single_threaded():
        assert _blas_threads()["threads"] == 1


def test_study_workers_have_one_blas_thread():
    table = flexmb.parameter_study(lambda_free_threads, [{"x": 1.0}, {"x": 2.0}], max_workers=2, progress=False)
    assert list(table["threads"]) == [1, 1]


def lambda_free_threads(x):  # module level: picklable for the process pool
    return _blas_threads()
