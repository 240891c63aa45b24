"""The hostile-files probe (``ws/probe-hostile``, ``hostile_probe``): its verdicts' rules on made-up
outcomes, and a few of its cases (``hostile_cases.SMOKE``: fast ones, no evolution) run as the probe runs
them, each of which must be OK."""

from __future__ import annotations

import time

import pytest
from hostile_cases import CASES, SMOKE
from hostile_probe import (
    EITHER,
    GUARD_LINE,
    GUARD_STATUS,
    LOST,
    OK,
    SILENT,
    SUCCEED,
    TRACEBACK,
    Case,
    Outcome,
    classify,
    environment,
    fixtures_needed,
    make_fixtures,
    run_cases,
    table,
)

REFUSED = "tool: error: --out x is a symbolic link\n"
CRASHED = "Traceback (most recent call last):\n  File x\nValueError: nan\n"


@pytest.mark.parametrize(
    "expect,outcome,verdict",
    [
        ("refuse", Outcome(2, "", REFUSED), OK),
        ("refuse", Outcome(74, "", REFUSED), OK),
        ("refuse", Outcome(2, "", REFUSED, changed=["outside/saved.txt"]), LOST),
        ("refuse", Outcome(2, "", REFUSED, left=["out.png"]), LOST),
        ("refuse", Outcome(0, "done\n", ""), SILENT),
        ("refuse", Outcome(GUARD_STATUS, "", GUARD_LINE + "\n"), SILENT),
        ("refuse", Outcome(2, "", ""), SILENT),
        ("refuse", Outcome(1, "", CRASHED), TRACEBACK),
        ("refuse", Outcome(2, "", "usage: tool [-h]\ntool: error: bad\n"), TRACEBACK),
        ("refuse", Outcome(None, "", ""), TRACEBACK),
        ("refuse", Outcome(-9, "", ""), TRACEBACK),
        ("refuse", Outcome(1, "", "failed\n"), TRACEBACK),
        ("succeed", Outcome(0, "", "progress\nmore\n"), OK),
        ("succeed", Outcome(0, "", "", missing=["out.png"]), TRACEBACK),
        ("succeed", Outcome(2, "", REFUSED), TRACEBACK),
        ("succeed", Outcome(0, "", "", changed=["run/config.json"]), LOST),
        (EITHER, Outcome(0, "", ""), OK),
        (EITHER, Outcome(2, "", REFUSED), OK),
    ],
)
def test_the_verdicts_rules(expect, outcome, verdict):
    case = Case("a case", "package command", ("--out", "x"), expect=expect)
    assert classify(case, outcome)[0] == verdict


def test_the_guard_is_a_success_only_where_the_case_expects_it():
    guarded = Outcome(GUARD_STATUS, "", GUARD_LINE + "\n")
    assert classify(Case("c", "p c", (), expect=SUCCEED, guard=True), guarded)[0] == OK
    assert classify(Case("c", "p c", (), expect=SUCCEED), guarded)[0] == TRACEBACK


def test_every_case_has_a_distinct_name_per_command_and_a_known_command():
    names = [f"{case.command}|{case.name}" for case in CASES]
    assert len(names) == len(set(names)), [n for n in names if names.count(n) > 1]
    assert set(SMOKE) <= set(names)
    commands = {case.command for case in CASES}
    every = "evolve evaluate experiment report library adapt adapt-benchmark replay recover record snapshot"
    for command in [*every.split(), "explorer", "animate", "trial", "validate", "bt", "task", "main"]:
        assert any(c.split()[1] == command for c in commands), command


def test_a_few_cases_run_as_the_probe_runs_them_are_ok(tmp_path):
    cases = [case for case in CASES if f"{case.command}|{case.name}" in SMOKE]
    started = time.monotonic()
    fixtures = make_fixtures(tmp_path / "fixtures", fixtures_needed(cases))
    verdicts = run_cases(cases, tmp_path / "cases", fixtures, environment(None, tmp_path / "home"), jobs=2)
    shown = table(verdicts)
    print(f"\n{shown}\n({time.monotonic() - started:.1f} s)")
    assert [v.verdict for v in verdicts] == [OK] * len(SMOKE), shown
