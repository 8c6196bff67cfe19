"""Read-ahead iteration: order kept, errors where they happened, bounded, stoppable."""

import threading
import time

import pytest

from labjoint.signal.prefetch import prefetch


def test_items_come_in_order_and_all_arrive():
    assert list(prefetch(iter(range(1000)), depth=3)) == list(range(1000))


def test_an_error_of_the_source_is_raised_after_the_items_before_it():
    def source():
        yield 1
        yield 2
        raise ValueError("block 3 is corrupt")

    got = []
    with pytest.raises(ValueError, match="block 3 is corrupt"):
        for item in prefetch(source()):
            got.append(item)
    assert got == [1, 2]


def test_the_reader_runs_at_most_depth_ahead():
    produced = []

    def source():
        for i in range(100):
            produced.append(i)
            yield i

    it = prefetch(source(), depth=2)
    assert next(it) == 0
    time.sleep(0.2)
    # one handed out, two queued, one held by the blocked reader
    assert len(produced) <= 4
    it.close()


def test_closing_early_stops_the_reader_thread():
    def endless():
        i = 0
        while True:
            yield i
            i += 1

    before = {t.name for t in threading.enumerate()}
    it = prefetch(endless())
    assert next(it) == 0
    it.close()
    assert "labjoint-prefetch" not in {t.name for t in threading.enumerate()} - before


def test_without_threads_the_items_are_read_in_the_callers_thread_when_asked_for():
    readers = []

    def source():
        for i in range(3):
            readers.append(threading.current_thread())
            yield i

    it = prefetch(source(), depth=2, threads=False)
    assert readers == []
    assert list(it) == [0, 1, 2]
    assert readers == [threading.main_thread()] * 3


def test_the_inline_pool_hands_an_error_to_whoever_takes_the_result():
    from labjoint.signal.prefetch import helper_pool

    with helper_pool(False, "x") as pool:
        fut = pool.submit(int, "not a number")
    with pytest.raises(ValueError):
        fut.result()
