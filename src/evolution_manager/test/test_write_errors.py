"""A failed write names the output and, when the system names another file, that file too."""

import errno
import os

from evolution_manager.errors import WriteError


def test_a_write_error_names_the_output_and_the_file_the_system_could_not_find():
    output = "runs/r/figures/heatmap_food.png"
    elsewhere = FileNotFoundError(errno.ENOENT, os.strerror(errno.ENOENT), "/venv/matplotlib/fonts/x.ttf")
    message = str(WriteError.of(output, elsewhere))
    assert message == f"cannot write {output}: {os.strerror(errno.ENOENT)} (/venv/matplotlib/fonts/x.ttf)"
    full = OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), output)
    assert str(WriteError.of(output, full)) == f"cannot write {output}: {os.strerror(errno.ENOSPC)}"
