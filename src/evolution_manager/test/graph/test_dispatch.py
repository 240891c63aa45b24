"""The dispatch bookkeeping without ROS: chunks, re-queueing after timeouts and vanished workers, each result
accepted exactly once, late duplicates ignored."""

from __future__ import annotations

import random

import pytest

from evolution_manager.graph.dispatch import Chunk, Dispatcher, DispatchError, Timeouts, WorkerState

FAST = Timeouts(timeout=10.0, first_timeout=10.0, factor=10.0)


def answer(dispatcher: Dispatcher, chunk: Chunk, now: float) -> int:
    """Answer a chunk with results that name their request (as an evaluator's depend only on it)."""
    return dispatcher.answered(chunk, [f"r{i}" for i in chunk.indices], now)


def test_a_batch_is_split_evenly_over_the_idle_workers_and_capped():
    dispatcher = Dispatcher(max_chunk=50, timeouts=FAST)
    for name in ("a", "b", "c"):
        dispatcher.appeared(name)
    dispatcher.start_batch([10] * 100)
    chunks = dispatcher.assign(0.0)
    assert [len(c.indices) for c in chunks] == [34, 33, 33]
    assert sorted(i for c in chunks for i in c.indices) == list(range(100))
    assert dispatcher.assign(0.1) == []  # everyone busy
    capped = Dispatcher(max_chunk=20, timeouts=FAST)
    capped.appeared("a")
    capped.start_batch([10] * 50)
    sizes = []
    now = 0.0
    while not capped.done:
        (chunk,) = capped.assign(now)
        sizes.append(len(chunk.indices))
        now += 1
        answer(capped, chunk, now)
    assert sizes == [20, 20, 10]
    assert capped.results() == [f"r{i}" for i in range(50)]


def test_chunks_hold_requests_of_one_key_only():
    dispatcher = Dispatcher(max_chunk=50, timeouts=FAST)
    dispatcher.appeared("a")
    dispatcher.start_batch([10, 10, 3, 10, 3])
    keys = []
    while not dispatcher.done:
        (chunk,) = dispatcher.assign(0.0)
        keys.append((chunk.key, chunk.indices))
        answer(dispatcher, chunk, 1.0)
    assert keys == [(10, (0, 1, 3)), (3, (2, 4))]


def test_the_work_of_a_vanished_worker_goes_to_the_others():
    dispatcher = Dispatcher(max_chunk=50, timeouts=FAST)
    for name in ("a", "b", "c"):
        dispatcher.appeared(name)
    dispatcher.start_batch([10] * 30)
    a, b, c = dispatcher.assign(0.0)
    assert dispatcher.vanished("b") == b
    assert dispatcher.state("b") is WorkerState.GONE
    answer(dispatcher, a, 1.0)
    (again,) = dispatcher.assign(1.0)  # only a is idle now
    assert (again.worker, again.indices) == ("a", b.indices)
    answer(dispatcher, c, 1.5)
    answer(dispatcher, again, 2.0)
    assert dispatcher.done
    assert dispatcher.results() == [f"r{i}" for i in range(30)]
    assert dispatcher.resent == 10


def test_a_timed_out_chunk_is_resent_and_its_late_answer_ignored():
    dispatcher = Dispatcher(max_chunk=50, timeouts=FAST)
    dispatcher.appeared("a")
    dispatcher.appeared("b")
    dispatcher.start_batch([10] * 20)
    a, b = dispatcher.assign(0.0)
    answer(dispatcher, a, 1.0)
    assert dispatcher.next_deadline() == 10.0
    assert dispatcher.expire(9.9) == []
    assert dispatcher.expire(10.0) == [b]
    assert dispatcher.state("b") is WorkerState.LATE
    (resent,) = dispatcher.assign(10.0)  # the late worker gets nothing
    assert (resent.worker, resent.indices) == ("a", b.indices)
    assert answer(dispatcher, resent, 11.0) == 10
    assert dispatcher.done
    assert dispatcher.results() == [f"r{i}" for i in range(20)]
    # b answers at last: every result is known already, and b is usable again.
    assert dispatcher.answered(b, ["late"] * 10, 12.0) == 0
    assert dispatcher.duplicates == 10
    assert dispatcher.state("b") is WorkerState.IDLE
    assert dispatcher.results() == [f"r{i}" for i in range(20)]


def test_a_late_answer_that_comes_first_wins_and_the_resent_copy_is_ignored():
    dispatcher = Dispatcher(max_chunk=50, timeouts=FAST)
    dispatcher.appeared("a")
    dispatcher.appeared("b")
    dispatcher.start_batch([10] * 4)
    a, b = dispatcher.assign(0.0)
    dispatcher.expire(20.0)  # both late
    assert not dispatcher.has_capacity()
    assert dispatcher.answered(b, ["B2", "B3"], 21.0) == 2
    (resent,) = dispatcher.assign(21.0)  # b is idle again and takes a's requests
    assert (resent.worker, resent.indices) == ("b", a.indices)
    assert dispatcher.answered(a, ["A0", "A1"], 22.0) == 2
    assert dispatcher.done
    assert dispatcher.answered(resent, ["X0", "X1"], 23.0) == 0
    assert dispatcher.results() == ["A0", "A1", "B2", "B3"]


def test_an_answer_from_an_earlier_batch_is_ignored():
    dispatcher = Dispatcher(max_chunk=50, timeouts=FAST)
    dispatcher.appeared("a")
    dispatcher.appeared("b")
    dispatcher.start_batch([10] * 2)
    first_a, first_b = dispatcher.assign(0.0)
    dispatcher.expire(30.0)
    (resent,) = dispatcher.assign(30.0) or [None]
    assert resent is None  # both late: nobody to send to
    dispatcher.answered(first_a, ["A0"], 31.0)
    (resent,) = dispatcher.assign(31.0)
    answer(dispatcher, resent, 32.0)
    assert dispatcher.results() == ["A0", "r1"]
    dispatcher.start_batch([10] * 2)
    assert dispatcher.answered(first_b, ["old"], 33.0) == 0  # batch 1's chunk
    assert dispatcher.state("b") is WorkerState.IDLE
    chunks = dispatcher.assign(33.0)
    for chunk in chunks:
        answer(dispatcher, chunk, 34.0)
    assert dispatcher.results() == ["r0", "r1"]


def test_a_refused_worker_is_never_used_again():
    dispatcher = Dispatcher(max_chunk=50, timeouts=FAST)
    dispatcher.appeared("a")
    dispatcher.appeared("b")
    dispatcher.start_batch([10] * 6)
    a, b = dispatcher.assign(0.0)
    dispatcher.refused(a)
    dispatcher.appeared("a")  # still listed by discovery: stays refused
    assert dispatcher.state("a") is WorkerState.REFUSED
    answer(dispatcher, b, 1.0)
    (resent,) = dispatcher.assign(1.0)
    assert (resent.worker, resent.indices) == ("b", a.indices)
    with pytest.raises(ValueError, match="refused"):
        dispatcher.answered(resent, ["too few"], 2.0)


def test_a_request_nobody_answers_raises_after_max_attempts():
    dispatcher = Dispatcher(max_chunk=50, timeouts=FAST, max_attempts=3)
    dispatcher.start_batch([10])
    now = 0.0
    with pytest.raises(DispatchError, match=r"request 0 .* sent 3 times"):
        for k in range(10):
            dispatcher.appeared(f"w{k}")
            dispatcher.assign(now)
            now += 100.0
            dispatcher.expire(now)


def test_deadlines_allow_first_calls_and_grow_with_the_work():
    dispatcher = Dispatcher(max_chunk=10, timeouts=Timeouts(timeout=5.0, first_timeout=100.0, factor=10.0))
    dispatcher.appeared("a")
    dispatcher.start_batch([10] * 20, weights=[10] * 20)
    (first,) = dispatcher.assign(0.0)
    assert first.deadline == 100.0  # first call of this worker: compiling
    answer(dispatcher, first, 1.0)  # 100 trials in 1 s
    (second,) = dispatcher.assign(1.0)
    assert second.deadline == pytest.approx(1.0 + 10 * 1.0)  # factor x expected beats the 5 s floor
    answer(dispatcher, second, 2.0)
    dispatcher.start_batch([1] * 10, weights=[1] * 10)
    (third,) = dispatcher.assign(2.0)
    assert third.deadline == pytest.approx(2.0 + 5.0)  # the floor


def test_random_faults_never_lose_or_double_a_result():
    """Workers appear, vanish, answer late or twice in random order; each batch still ends with each
    request's own result, accepted once."""
    rng = random.Random(7)
    dispatcher = Dispatcher(max_chunk=7, timeouts=Timeouts(timeout=3.0, first_timeout=3.0), max_attempts=50)
    names = [f"w{k}" for k in range(4)]
    for name in names:
        dispatcher.appeared(name)
    now = 0.0
    in_flight: list[Chunk] = []
    for batch in range(20):
        size = rng.randint(1, 40)
        dispatcher.start_batch([10] * size)
        while not dispatcher.done:
            now += rng.uniform(0.1, 2.0)
            in_flight += dispatcher.assign(now)
            dispatcher.expire(now)
            event = rng.random()
            if event < 0.1:
                dispatcher.vanished(rng.choice(names))
            elif event < 0.3:
                dispatcher.appeared(rng.choice(names))
            if in_flight and rng.random() < 0.7:
                chunk = in_flight.pop(rng.randrange(len(in_flight)))
                # a vanished worker's answer is lost
                if dispatcher.state(chunk.worker) is not WorkerState.GONE:
                    dispatcher.answered(chunk, [(chunk.batch, i) for i in chunk.indices], now)
            if not dispatcher.has_capacity():
                dispatcher.appeared(rng.choice(names))
        assert dispatcher.results() == [(batch + 1, i) for i in range(size)]
    assert dispatcher.resent > 0
