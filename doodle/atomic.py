"""Atomic file writing: output appears complete or not at all, never half-written."""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path
from typing import Iterator


def _plain_mode(path: Path, mode: int) -> None:
    """Give a file or folder made private by ``mkstemp``/``mkdtemp`` the mode ``open``/``mkdir`` would give."""
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(path, mode & ~umask)


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success it is renamed over ``path``.

    On any exception the temporary file is removed and ``path`` is left untouched. The folder must exist: a
    mistyped folder is an error, not a surprise folder.

    Raises:
        DoodleError: when ``path``'s folder does not exist or ``path`` is a folder.
    """

    path = Path(path)
    check_folder(path)
    # Hidden, beside the target (same file system, so the rename is atomic), and with the target's suffix:
    # some writers (ffmpeg) pick the format from it.
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}.tmp-", suffix=path.suffix, dir=path.parent)
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        _plain_mode(tmp_path, 0o666)
        os.replace(tmp_path, path)
    except OSError as exc:  # a full disk names no file, or the hidden temporary one: name the target
        tmp_path.unlink(missing_ok=True)
        if exc.errno is None:
            raise
        raise OSError(exc.errno, exc.strerror, str(path)) from exc
    except BaseException:
        tmp_path.unlink(missing_ok=True)
        raise


def check_folder(path: str | os.PathLike) -> None:
    """Raise :class:`~doodle.errors.DoodleError` naming ``path`` when it cannot be written as a file: its folder
    is missing or is a file, or ``path`` is a folder."""
    from .errors import DoodleError

    path = Path(path)
    _no_file_above(path)
    if not path.parent.is_dir():
        raise DoodleError(f"{path}: folder {path.parent} does not exist")
    if path.is_dir():
        raise DoodleError(f"{path}: is a folder")


def _no_file_above(path: Path) -> None:
    """Refuse ``path`` when the nearest of its ancestors that exists is a file (one line naming both)."""
    from .errors import DoodleError

    for parent in path.parents:
        if parent.exists():
            if not parent.is_dir():
                raise DoodleError(f"{path}: {parent} is a file, not a folder")
            return


def check_out_folder(path: str | os.PathLike) -> None:
    """Raise :class:`~doodle.errors.DoodleError` when ``path`` cannot become an output folder: it is a file, or a
    file stands where one of its folders would be."""
    from .errors import DoodleError

    path = Path(path)
    if path.exists() and not path.is_dir():
        raise DoodleError(f"{path}: exists and is not a folder")
    _no_file_above(path)


def check_writable(path: str | os.PathLike) -> None:
    """Fail now, in one line naming ``path``, when a file cannot be written there (see :func:`check_folder`; a
    read-only folder or file system): before minutes of work whose result could not be saved."""
    from .errors import DoodleError

    path = Path(path)
    check_folder(path)
    try:
        fd, probe = tempfile.mkstemp(prefix=f".{path.stem}.probe-", dir=path.parent)
    except OSError as exc:
        raise DoodleError(f"{path}: cannot write in {path.parent} ({exc.strerror or exc})") from None
    os.close(fd)
    os.unlink(probe)


def write_bytes(path: str | os.PathLike, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)


def write_text(path: str | os.PathLike, text: str) -> None:
    """Write UTF-8 ``text`` to ``path`` atomically."""
    write_bytes(path, text.encode("utf-8"))


def _exchange(a: Path, b: Path) -> bool:
    """Swap two paths in one step (Linux ``renameat2(RENAME_EXCHANGE)``); False where unsupported."""
    import ctypes
    import sys

    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        renameat2 = libc.renameat2
    except (OSError, AttributeError):
        return False
    AT_FDCWD, RENAME_EXCHANGE = -100, 2
    return renameat2(AT_FDCWD, os.fsencode(a), AT_FDCWD, os.fsencode(b), RENAME_EXCHANGE) == 0


def _carry_over(old: Path, new: Path) -> None:
    """Hard-link (or copy) what ``old`` holds and ``new`` does not, so a swap loses no unrelated file."""
    import shutil

    for entry in old.iterdir():
        target = new / entry.name
        if target.exists() or target.is_symlink():
            continue
        if entry.is_dir() and not entry.is_symlink():
            shutil.copytree(entry, target, symlinks=True)
        else:
            try:
                os.link(entry, target, follow_symlinks=False)
            except OSError:
                shutil.copy2(entry, target, follow_symlinks=False)


@contextlib.contextmanager
def atomic_folder(path: str | os.PathLike, keep_others: bool = True) -> Iterator[Path]:
    """Yield an empty sibling folder to fill; on success it replaces the files of ``path`` in one step.

    Files of ``path`` that the new content does not replace are kept, unless ``keep_others`` is false (the
    new folder then replaces the old one whole). The swap is one atomic exchange on
    Linux, so a kill at any moment leaves ``path`` entirely old or entirely new (elsewhere two renames).
    A lock beside ``path`` refuses a second writer into the same folder; temporary folders that a killed
    writer left behind are removed by the next one.

    Raises:
        DoodleError: when ``path`` is a file, or another process is writing to it.
    """
    import fcntl
    import shutil

    from .errors import DoodleError

    path = Path(path)
    check_out_folder(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    lock_fd = os.open(path.parent / f".{path.name}.doodle-lock", os.O_CREAT | os.O_RDWR, 0o644)
    try:
        try:
            fcntl.flock(lock_fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise DoodleError(f"{path}: another doodle command is writing to this folder") from None
        for stale in path.parent.glob(f".{path.name}.doodle-*.tmp"):  # left by a killed writer
            shutil.rmtree(stale, ignore_errors=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{path.name}.doodle-new-", suffix=".tmp", dir=path.parent))
        try:
            yield tmp
            _plain_mode(tmp, 0o777)
            if not path.exists():
                os.rename(tmp, path)
            else:
                if keep_others:
                    _carry_over(path, tmp)
                if not _exchange(tmp, path):
                    old = Path(tempfile.mkdtemp(prefix=f".{path.name}.doodle-old-", suffix=".tmp", dir=path.parent))
                    os.rmdir(old)
                    os.rename(path, old)
                    os.rename(tmp, path)
                    tmp = old
                shutil.rmtree(tmp, ignore_errors=True)  # after the swap: the old content
        except BaseException:
            shutil.rmtree(tmp, ignore_errors=True)
            raise
    finally:
        os.close(lock_fd)
