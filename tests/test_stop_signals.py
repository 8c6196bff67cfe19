"""Signals that end a plan or a command: SIGTERM as the engine's emergency stop (a flag read
at the next block) and as Ctrl-C for commands writing run files, including a signal that
lands inside a weakref callback or ``__del__``, where an exception raised by the handler is
lost (the stop test of issue 31 hung at a run boundary on a loaded CI machine that way)."""

import os
import signal

import pytest

from labjoint.acquisition.messages import Configure, Output, Record
from labjoint.acquisition.stop_signals import stop_on_signals
from labjoint.cli.signals import terminate_as_interrupt
from test_engine import make


class _HandledInDel:
    """Runs the installed SIGTERM handler from ``__del__``, as CPython does when the signal
    arrives while a weakref callback or finaliser runs: what it raises is 'ignored'."""

    def __del__(self):
        signal.getsignal(signal.SIGTERM)(signal.SIGTERM, None)


def test_stop_on_signals_turns_sigterm_into_an_emergency_stop():
    def on_read(col):
        if col.open_blocks() == 2:
            os.kill(os.getpid(), signal.SIGTERM)

    engine, gen, daq, col = make(on_read=on_read)
    before = signal.getsignal(signal.SIGTERM)
    with stop_on_signals(engine) as received:
        r = engine.run([Configure(400, 10), Output(True), Record("r", n_cycles=500)])
    assert signal.getsignal(signal.SIGTERM) is before
    assert r.status == "aborted" and "SIGTERM" in r.reason and gen.s.output is False
    assert col.docs[-1][1].status == "aborted" and received.name == "SIGTERM"


def test_a_signal_handled_inside_a_finaliser_still_stops_the_plan():
    def on_read(col):
        if col.open_blocks() == 2:
            _HandledInDel()                 # created and finalised at once

    engine, gen, daq, col = make(on_read=on_read)
    with stop_on_signals(engine, (signal.SIGTERM, signal.SIGINT)) as received:
        r = engine.run([Configure(400, 10), Output(True), Record("r", n_cycles=500),
                        Record("s", n_cycles=500)])
    assert r.status == "aborted" and received.name == "SIGTERM"
    assert [run.name for run in r.runs][-1].endswith("r")      # the second never started
    assert col.docs[-1][1].status == "aborted" and gen.s.output is False


def test_no_signal_no_stop():
    engine, gen, daq, col = make()
    with stop_on_signals(engine) as received:
        r = engine.run([Configure(400, 10), Output(True), Record("r", n_cycles=20)])
    assert r.status == "complete" and received.name is None


def test_terminate_as_interrupt_raises_in_the_block():
    before = signal.getsignal(signal.SIGTERM)
    with pytest.raises(KeyboardInterrupt, match="SIGTERM"):
        with terminate_as_interrupt():
            os.kill(os.getpid(), signal.SIGTERM)
            for _ in range(10**6):          # the handler runs at the next bytecode
                pass
    assert signal.getsignal(signal.SIGTERM) is before


@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")
def test_terminate_as_interrupt_a_swallowed_raise_still_ends_as_interrupted():
    done = []
    with pytest.raises(KeyboardInterrupt, match="SIGTERM"):
        with terminate_as_interrupt():
            _HandledInDel()                 # the handler's KeyboardInterrupt is 'ignored'
            done.append("the block went on")
    assert done == ["the block went on"]
