"""A ``--cluster-config`` file that is not UTF-8, or that gives a key twice, is refused in one line naming the
file (a UnicodeDecodeError traceback, and a silent last-wins, before issue 41)."""

from __future__ import annotations

import pytest

from evolution_manager.cluster.settings import ClusterError, parse_cluster
from evolution_manager.studies.evolve import evolve


@pytest.mark.parametrize(
    "text,expected",
    [
        ("cores: 4\ncores: 8\n", "the key 'cores' appears twice (line 2); expected each setting once"),
        ("jobs: 2\nmemory: 8GB\njobs: 3\n", "the key 'jobs' appears twice (line 3)"),
    ],
)
def test_a_key_given_twice_is_refused_naming_it(tmp_path, text, expected):
    config = tmp_path / "cluster.yaml"
    config.write_text(text)
    with pytest.raises(ClusterError) as caught:
        parse_cluster("slurm", config)
    message = str(caught.value)
    assert message.startswith(f"--cluster-config {config}: ") and expected in message and "\n" not in message


def test_a_config_that_is_not_utf8_is_one_line_and_exit_2(tmp_path, capsys):
    config = tmp_path / "cluster.yaml"
    config.write_bytes(b"cores: 4\npartition: caf\xe9\n")  # Latin-1
    with pytest.raises(ClusterError, match=r"not UTF-8 text \(byte 0xe9 at offset 23\)"):
        parse_cluster("slurm", config)
    out = tmp_path / "run"
    argv = ["--algorithm", "qd", "--objective", "food", "--evaluations", "10", "--out", str(out)]
    assert evolve([*argv, "--cluster", "slurm", "--cluster-config", str(config), "--no-progress"]) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and "not UTF-8 text" in error and str(config) in error, error
    assert not out.exists()
