"""write_atomic in an output directory someone else may have prepared (a CI workspace
checked out from a pull request): a symlink is replaced, never followed, and no mode
bits beyond read/write/execute are carried over."""

from __future__ import annotations

import os
import stat

from feedtune.schema.files import write_atomic


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def test_a_symlink_is_replaced_and_its_target_keeps_bytes_and_mode(tmp_path):
    target = tmp_path / "elsewhere" / "tool"
    target.parent.mkdir()
    target.write_bytes(b"#!/bin/sh\n")
    target.chmod(0o4755)  # setuid: its mode must not reach the result
    link = tmp_path / "out" / "result.json"
    link.parent.mkdir()
    link.symlink_to(target)
    write_atomic(link, b"{}\n")
    assert not link.is_symlink() and link.read_bytes() == b"{}\n"
    assert stat.S_IMODE(link.stat().st_mode) == 0o666 & ~_umask()
    assert target.read_bytes() == b"#!/bin/sh\n" and stat.S_IMODE(target.stat().st_mode) == 0o4755


def test_a_regular_files_permissions_are_kept_without_setuid(tmp_path):
    path = tmp_path / "result.json"
    path.write_bytes(b"old")
    path.chmod(0o4750)
    write_atomic(path, b"new")
    assert path.read_bytes() == b"new"
    assert stat.S_IMODE(path.stat().st_mode) == 0o750
