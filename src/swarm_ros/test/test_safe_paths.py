"""The workspace's rule for writing where others can plant files (``swarm_ros.safe_paths``) and the ROS
domain locks that follow it (``swarm_ros.isolation``): no write through a link, lock folders of one's own."""

from __future__ import annotations

import os

import pytest

from swarm_ros import isolation
from swarm_ros.safe_paths import (
    UnsafePathError,
    check_folder,
    check_output,
    open_no_follow,
    private_folder,
    refuse_links,
    refuse_links_within,
)


def test_a_planted_link_is_never_opened_for_writing(tmp_path):
    precious = tmp_path / "precious"
    precious.write_text("keep me\n")
    link = tmp_path / "x.lock"
    link.symlink_to(precious)
    with pytest.raises(UnsafePathError) as refused:
        open_no_follow(link, os.O_RDWR | os.O_CREAT)
    assert "symbolic link" in str(refused.value) and "\n" not in str(refused.value)
    assert precious.read_text() == "keep me\n"
    dangling = tmp_path / "y.lock"
    dangling.symlink_to(tmp_path / "nowhere")
    with pytest.raises(UnsafePathError):
        open_no_follow(dangling, os.O_RDWR | os.O_CREAT)
    assert not (tmp_path / "nowhere").exists()


def test_links_below_a_root_are_refused_not_above(tmp_path):
    outside = tmp_path / "outside"
    outside.mkdir()
    run = tmp_path / "run"
    run.mkdir()
    (run / "figures").symlink_to(outside)
    with pytest.raises(UnsafePathError, match="figures is a symbolic link"):
        refuse_links(run / "figures" / "a.png", run)
    alias = tmp_path / "alias"
    alias.symlink_to(run)  # the user's own layout: the root may be reached through a link
    refuse_links(alias / "config.json", alias)


def test_an_output_that_exists_is_refused_unless_forced_and_a_link_always(tmp_path):
    existing = tmp_path / "a.png"
    existing.write_text("old")
    with pytest.raises(UnsafePathError, match="already exists: add --force"):
        check_output(existing)
    assert check_output(existing, force=True) == existing
    link = tmp_path / "b.png"
    link.symlink_to(existing)
    for force in (False, True):
        with pytest.raises(UnsafePathError, match="symbolic link"):
            check_output(link, force)
    with pytest.raises(UnsafePathError, match="is a folder"):
        check_output(tmp_path, True)
    with pytest.raises(UnsafePathError, match=r"a.png is a file, not a folder"):
        check_output(existing / "c.png")


def test_the_domain_locks_are_in_a_private_folder_and_never_follow_links(tmp_path, monkeypatch):
    folder = tmp_path / "domains"
    monkeypatch.setattr(isolation, "LOCK_DIR", folder)
    with isolation.reserved_domain() as domain:
        assert isolation.FIRST_DOMAIN <= domain <= isolation.LAST_DOMAIN
    assert folder.stat().st_mode & 0o777 == 0o700
    assert folder.stat().st_uid == os.getuid()
    # a link planted in place of every lock file: none is written through, the reservation is refused
    precious = tmp_path / "precious"
    precious.write_text("keep me\n")
    for domain in range(isolation.FIRST_DOMAIN, isolation.LAST_DOMAIN + 1):
        (folder / f"{domain}.lock").unlink(missing_ok=True)
        (folder / f"{domain}.lock").symlink_to(precious)
    with pytest.raises(UnsafePathError, match="symbolic link"), isolation.reserved_domain():
        pass
    assert precious.read_text() == "keep me\n"


def test_a_lock_folder_open_to_others_or_a_link_is_refused_in_one_line(tmp_path, monkeypatch):
    shared = tmp_path / "shared"
    shared.mkdir(mode=0o777)
    os.chmod(shared, 0o1777)
    monkeypatch.setattr(isolation, "LOCK_DIR", shared)
    with (
        pytest.raises(UnsafePathError, match=r"mode 1777, expected 0700") as refused,
        isolation.reserved_domain(),
    ):
        pass
    assert "\n" not in str(refused.value)
    link = tmp_path / "link"
    link.symlink_to(tmp_path / "private")
    (tmp_path / "private").mkdir(mode=0o700)
    with pytest.raises(UnsafePathError, match="not a folder"):
        private_folder(link)
    if os.getuid() != 0 and os.path.isdir("/") and os.stat("/").st_uid != os.getuid():
        with pytest.raises(UnsafePathError, match="belongs to user id"):
            private_folder("/")


def test_a_folder_to_write_in_may_exist_but_is_never_a_link_or_a_file(tmp_path):
    (tmp_path / "logs").mkdir()
    assert check_folder(tmp_path / "logs") == tmp_path / "logs"
    assert check_folder(tmp_path / "new" / "logs") == tmp_path / "new" / "logs"
    (tmp_path / "file").write_text("mine\n")
    (tmp_path / "link").symlink_to(tmp_path / "logs")
    (tmp_path / "dangling").symlink_to(tmp_path / "nowhere")
    for path, reason in (
        (tmp_path / "link", "is a symbolic link"),
        (tmp_path / "dangling", "is a symbolic link"),
        (tmp_path / "file", "file is a file, not a folder"),
        (tmp_path / "file" / "logs", "file is a file, not a folder"),
    ):
        with pytest.raises(UnsafePathError, match=reason) as refused:
            check_folder(path, "--logs")
        assert str(refused.value).startswith("--logs ") and "\n" not in str(refused.value)
    assert not (tmp_path / "nowhere").exists()


def test_a_link_anywhere_within_a_folder_is_refused_the_folder_itself_may_be_one(tmp_path):
    """A folder that holds nothing but what a command made (an experiment's): a link at any depth in it is
    refused, the first in name order, one line; the folder itself may be a link (the user's own layout)."""
    outside = tmp_path / "outside"
    outside.mkdir()
    folder = tmp_path / "exp"
    (folder / "runs" / "a" / "run00").mkdir(parents=True)
    (folder / "runs" / "a" / "run00" / "summary.json").write_text("{}")
    refuse_links_within(folder)  # nothing planted
    (tmp_path / "linked").symlink_to(folder, target_is_directory=True)
    refuse_links_within(tmp_path / "linked")
    refuse_links_within(tmp_path / "missing")  # nothing there, nothing to refuse
    (folder / "runs" / "b").symlink_to(outside, target_is_directory=True)
    (folder / "runs" / "a" / "run00" / "z.csv").symlink_to(outside / "nowhere")
    with pytest.raises(UnsafePathError, match=r"exp/runs/a/run00/z\.csv is a symbolic link") as refused:
        refuse_links_within(folder)
    assert "\n" not in str(refused.value) and not (outside / "nowhere").exists()
    (folder / "runs" / "a" / "run00" / "z.csv").unlink()
    with pytest.raises(UnsafePathError, match=r"exp/runs/b is a symbolic link \(to .*outside\)"):
        refuse_links_within(folder)
