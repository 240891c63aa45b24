"""Every command says a bad option in one line with exit status 2, as evolve does (argparse alone prints its
usage block first)."""

import pytest

from evolution_manager.graph.nodes import recorder, replay, trial
from evolution_manager.viewing import animate, explorer, snapshot

COMMANDS = {
    "replay": replay.main,
    "recover": replay.recover_main,
    "record": recorder.main,
    "explorer": explorer.main,
    "snapshot": snapshot.main,
    "animate": animate.main,
    "trial": trial.main,
}


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_a_bad_option_is_one_line_and_status_2(name, capsys):
    try:
        status = COMMANDS[name](["--no-such-option", "x"])
    except SystemExit as stop:
        status = stop.code
    err = capsys.readouterr().err
    assert status == 2
    assert err.count("\n") == 1 and err.startswith(f"{name}: error: "), err
    assert "usage:" not in err
