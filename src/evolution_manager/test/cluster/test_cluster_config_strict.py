"""A ``--cluster-config`` file that is not UTF-8 is refused in one line naming the file (a UnicodeDecodeError
traceback before issue 41); a key given twice is among test_cluster's bad settings."""

from __future__ import annotations

import pytest

from evolution_manager.cluster.settings import ClusterError, parse_cluster
from evolution_manager.studies.evolve import evolve


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
