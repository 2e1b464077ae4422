"""`flexmb._warnings.recording`: each thread records its own warnings, also while others record
(a dask worker runs designs in threads: `warnings.catch_warnings` swapped two designs' warnings,
seen once in two 40-design studies), and the process's warning state comes back afterwards."""

import threading
import warnings

from flexmb import _warnings


def test_two_threads_recording_at_once_keep_their_own_warnings():
    barrier = threading.Barrier(2)
    caught = {}

    def design(name):
        with _warnings.recording() as records:
            for k in range(20):
                barrier.wait()  # interleave the two threads' warnings
                warnings.warn(f"{name} {k}", UserWarning)
        caught[name] = [str(w.message) for w in records]

    threads = [threading.Thread(target=design, args=(n,)) for n in ("a", "b")]
    before = (warnings.showwarning, list(warnings.filters))
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert caught == {n: [f"{n} {k}" for k in range(20)] for n in ("a", "b")}
    assert (warnings.showwarning, list(warnings.filters)) == before


def test_nested_recordings_hand_their_warnings_out_when_raised_again():
    with _warnings.recording() as outer:
        with _warnings.recording() as inner:
            warnings.warn("inner", RuntimeWarning)
        _warnings.raise_again(inner)
    assert [str(w.message) for w in inner] == ["inner"] and [str(w.message) for w in outer] == ["inner"]
    assert _warnings.as_text(outer + inner) == "RuntimeWarning: inner"
