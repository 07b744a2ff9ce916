"""Which files of a report directory the report may replace or delete.

A report writes ``report.html`` and one PNG per figure into a directory the user names,
which may hold other files, some of them with the same names. The report therefore keeps a
manifest, ``DIR/.feedtune-report.json``, of the files it wrote and the SHA-256 of each:
a file of one of the report's names is replaced or removed only when the manifest lists it
with its current content. Any other file of those names (the user's own ``bode.png``, a
figure edited since, a report of a feedtune without manifests) stops the report before it
writes anything, naming the file. Files of other names are never touched.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

from feedtune.schema.files import write_atomic

#: the manifest's file name inside the report directory
MANIFEST = ".feedtune-report.json"
#: what the manifest says it is, checked on reading
KIND = "feedtune report manifest"


class ReportDirError(ValueError):
    """The report directory holds a file of a name the report writes that it did not write."""


def sha256(data: bytes) -> str:
    """Hex SHA-256 of ``data``."""
    return hashlib.sha256(data).hexdigest()


def read_manifest(out_dir: Path) -> dict[str, list[str]]:
    """{file name: SHA-256 digests it may hold} of the manifest in ``out_dir`` ({} if none).

    Raises
    ------
    ReportDirError
        The manifest exists but is not one a report wrote.
    """
    path = Path(out_dir) / MANIFEST
    if not path.exists() and not path.is_symlink():
        return {}
    try:
        data = json.loads(path.read_bytes()) if path.is_file() and not path.is_symlink() else None
    except (OSError, ValueError):
        data = None
    files = data.get("files") if isinstance(data, dict) and data.get("kind") == KIND else None
    if not (isinstance(files, dict) and all(
            isinstance(digests, list) and all(isinstance(d, str) for d in digests)
            for digests in files.values())):
        raise ReportDirError(f"{path}: not a manifest feedtune's report wrote; move it away or "
                             "choose another directory")
    return files


def check_out_dir(out_dir: Path, names: list[str]) -> dict[str, list[str]]:
    """The manifest of ``out_dir`` after checking that every existing file of ``names`` is
    one the report wrote (listed in the manifest with its current content).

    Raises
    ------
    ReportDirError
        Naming every file that is not the report's.
    """
    out_dir = Path(out_dir)
    owned = read_manifest(out_dir)
    foreign = []
    for name in names:
        path = out_dir / name
        if not path.exists() and not path.is_symlink():
            continue
        if path.is_symlink() or not path.is_file() or sha256(path.read_bytes()) not in owned.get(
                name, []):
            foreign.append(path)
    if foreign:
        listed = ", ".join(str(p) for p in foreign)
        raise ReportDirError(
            f"{listed}: not written by feedtune's report (or changed since; see "
            f"{out_dir / MANIFEST}); the report does not overwrite it: move it away or "
            "choose another directory")
    return owned


def write_files(out_dir: Path, files: dict[str, bytes], names: list[str]) -> None:
    """Write ``files`` ({name: bytes}) into ``out_dir`` and delete the report's files of
    ``names`` an earlier report wrote that are not among them.

    Checks first (:func:`check_out_dir`); the manifest lists old and new digests while the
    files are being replaced, so a kill at any moment leaves every file either listed or
    untouched.
    """
    owned = check_out_dir(out_dir, names)
    digests = {name: sha256(data) for name, data in files.items()}
    pending = {name: sorted(set(owned.get(name, [])) | ({digests[name]} if name in digests
                                                        else set()))
               for name in names if name in owned or name in digests}
    _write_manifest(out_dir, pending)
    for name, data in files.items():
        write_atomic(out_dir / name, data)
    for name in names:
        if name in owned and name not in files:  # stale: checked to hold what we wrote
            (out_dir / name).unlink(missing_ok=True)
    _write_manifest(out_dir, {name: [digest] for name, digest in digests.items()})


def _write_manifest(out_dir: Path, files: dict[str, list[str]]) -> None:
    text = json.dumps({"kind": KIND, "files": files}, indent=1, sort_keys=True) + "\n"
    write_atomic(Path(out_dir) / MANIFEST, text.encode("utf-8"))
